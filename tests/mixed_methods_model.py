"""A small site that needs every construction method but ``in_place`` (ifcopenshell.api), for integration
tests: a ground slab the IFC says is cast in situ, a block wall and a heavy concrete wall standing on it, and
a pad footing on a steel pile, with an anchor bolt embedded in it and a steel column on a base plate over it.

What each element's method comes from, with the default ``prefab`` preset and fleet:

* ``Ground slab`` (5.0 × 3.0 × 0.15 m, concrete): ``Pset_ConcreteElementGeneral.CastingMethod = INSITU``,
  so ``cast_in_place`` from the IFC;
* ``Block wall`` (3.0 × 0.2 × 1.2 m, a masonry material): ``prefab`` lifts masonry, so the test's methods
  file (:data:`MASONRY_LAID`: ``[by_material] masonry = "laid"``) lays it (``method_source`` "user");
* ``Concrete wall`` (5.0 × 0.25 × 3.0 m, concrete, 9 t): heavier than the default fleet's largest lift (the
  tower crane's 8 t), so ``prefab`` panelises it into storey-high panels;
* ``Steel pile`` (``IfcPile``, steel, 0.3 m square, 3 m long, its head under the footing): ``driven`` by
  rule, by the piling rig;
* ``Pad footing`` (1.0 × 1.0 × 0.5 m, top at z = 0, concrete): a foundation, so ``cast_in_place`` by rule;
* ``Anchor bolt`` (``IfcMechanicalFastener`` ANCHORBOLT, steel, 0.42 m long: 0.4 m in the footing, the rest
  through the base plate; no relation names its host): ``with_host``, found by embedment, a guest of the
  footing;
* ``Base plate`` (steel ``IfcPlate``) under ``Column`` (a steel 0.2 m square, 2.4 m): the plate goes with
  the column it is welded to (``with_host``), the column is ``lifted``.

The walls rest on the slab, the footing on the pile and the column on the footing: each waits for the cure
of what it rests on.
"""

from __future__ import annotations

from pathlib import Path

from converter.ifc_builders import add_box, add_material, add_pset, new_model

# The test's methods file: masonry is laid (``prefab`` lifts it); a robot or crane lets a part go 10 s
# after it is set (the default holds, 60-240 s of stepped physics each, are test_connections_run's)
MASONRY_LAID = """
[by_material]
masonry = "laid"

[connections]
bolted_base_s = 10.0
pinned_end_s = 10.0
grouted_s = 10.0

[temporary_supports]
prop_place_s = 0.0
"""
SLAB_TOP_M = 0.15
PLATE_M = 0.02
PILE_M = 3.0


def write_mixed_methods_model(path: Path) -> dict[str, str]:
    """Write the model (see the module) to ``path``; the GlobalId of each element by its name."""
    small = new_model()
    slab = add_box(small, "IfcSlab", "Ground slab", size_m=(5.0, 3.0, SLAB_TOP_M), corner_m=(0.0, 0.0, 0.0))
    add_pset(small, [slab], "Pset_ConcreteElementGeneral", {"CastingMethod": "INSITU"})
    blocks = add_box(small, "IfcWall", "Block wall", size_m=(3.0, 0.2, 1.2), corner_m=(1.0, 0.2, SLAB_TOP_M))
    heavy = add_box(
        small, "IfcWall", "Concrete wall", size_m=(5.0, 0.25, 3.0), corner_m=(0.0, 2.75, SLAB_TOP_M)
    )
    footing = add_box(small, "IfcFooting", "Pad footing", size_m=(1.0, 1.0, 0.5), corner_m=(7.0, 1.0, -0.5))
    pile = add_box(
        small, "IfcPile", "Steel pile", size_m=(0.3, 0.3, PILE_M), corner_m=(7.35, 1.35, -0.5 - PILE_M)
    )
    bolt = add_box(
        small,
        "IfcMechanicalFastener",
        "Anchor bolt",
        size_m=(0.03, 0.03, 0.42),
        corner_m=(7.62, 1.62, -0.4),
        predefined_type="ANCHORBOLT",
    )
    plate = add_box(small, "IfcPlate", "Base plate", size_m=(0.4, 0.4, PLATE_M), corner_m=(7.3, 1.3, 0.0))
    column = add_box(small, "IfcColumn", "Column", size_m=(0.2, 0.2, 2.4), corner_m=(7.4, 1.4, PLATE_M))
    add_material(small, [slab, heavy, footing], "Concrete C30/37", "concrete")
    add_material(small, [blocks], "Concrete block", "masonry")
    add_material(small, [bolt, plate, column, pile], "Steel S355", "steel")
    small.file.write(str(path))
    elements = (slab, blocks, heavy, footing, bolt, plate, column, pile)
    return {str(element.Name): str(element.GlobalId) for element in elements}
