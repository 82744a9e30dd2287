"""A generated site model for integration tests: a small frame, an enclosed room and a too-heavy part.

What real Revit models bring and the bundled frame does not, kept small enough for a test to build:

* **a small steel frame** — ``Column A1`` at (0, 0) and ``Column A2`` at (3, 0) (SHS-sized solid 0.15 m
  squares, 2.5 m high, steel) and ``Beam A1-A2`` (0.10 × 0.20 m, 3.15 m along +x) resting on both tops;
* **an enclosed room** (``room=True``) — four timber walls 2.0 m high and 0.10 m thick, ``Wall R-S``,
  ``Wall R-N`` (3.4 m along x) and ``Wall R-W``, ``Wall R-E`` (3.0 m along y), closing a 3.0 × 3.0 m space
  centred at ``ROOM_CENTRE_M`` = (8, 0), with ``Column R1`` (0.15 m square, 2.0 m, steel) at its centre,
  an ``IfcSpace`` "Room R" (never a component) and, with ``furniture=True``, ``Table R1``
  (``IfcFurnishingElement`` in IFC2X3, ``IfcFurniture`` later; left out of a conversion by default). Once
  the four walls stand, the column's target is cut off: the nearest point outside the walls is 2.2 m
  from the room centre for the default robot (radius 0.6 m), so ``Column R1`` is 2.1 m away, beyond
  ``DEFAULT_ROBOT.reach_m`` (1.5 m). Build the column before the walls (``GOOD_ORDER``) or it cannot be
  built (``WALLS_FIRST_ORDER``);
* **a part too heavy for the default robot** (``heavy``): ``"footing"`` (default) puts ``Footing A1``, a
  2.0 × 2.0 × 0.6 m concrete pad (top at z = 0) under ``Column A1``, so the column and the beam depend on
  it; ``"slab"`` puts ``Slab H1``, a 4.0 × 3.0 × 0.25 m concrete ground slab, alone north of the frame
  (nothing depends on it); ``None`` leaves it out. Both are 2400 kg/m³ concrete with
  ``Pset_MaterialCommon.MassDensity`` on the material: 5,760 kg and 7,200 kg (``HEAVY_MASS_KG``), far
  above ``DEFAULT_ROBOT.payload_kg`` (1000 kg). Every other component stays below 500 kg.

``schedule`` (a sequence of element names, e.g. ``GOOD_ORDER`` or ``WALLS_FIRST_ORDER`` for the default
model, ``construction_order(heavy, room, walls_first=…)`` for the others) writes an IFC 4D
work schedule: one ``IfcTask`` per name ("Build <name>", T001…), assigned to its product and chained
FINISH_START in that order, which ``bimbot convert`` turns into ``sequence.xml`` (components the schedule
leaves out are appended in derived order). Without one the converter derives the sequence from supports.

Elements are created in ``construction_order(heavy, room)`` (so STEP ids, and the manifest, follow it;
the table last), with
deterministic GlobalIds (UUID5 of the element's class and name): regenerating gives the same GUIDs, and
:meth:`SiteModel.guid` finds them by name. Lengths are written in millimetres (the api converts from the
metres used here); the model is valid IFC2X3, IFC4 and IFC4X3.

Usage::

    from site_models import GOOD_ORDER, WALLS_FIRST_ORDER, build_site_model

    site = build_site_model(heavy="slab", schedule=WALLS_FIRST_ORDER)
    path = site.write(tmp_path / "site.ifc")   # then bimbot convert path -o build/
    site.guid("Column R1")

``tests/`` is on ``sys.path`` for every test (``tests/conftest.py``), so ``import site_models`` works from
any test folder.
"""

from __future__ import annotations

import itertools
import uuid
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import ifcopenshell
import ifcopenshell.api.aggregate
import ifcopenshell.api.context
import ifcopenshell.api.control
import ifcopenshell.api.geometry
import ifcopenshell.api.material
import ifcopenshell.api.owner
import ifcopenshell.api.project
import ifcopenshell.api.pset
import ifcopenshell.api.root
import ifcopenshell.api.sequence
import ifcopenshell.api.spatial
import ifcopenshell.api.unit
import ifcopenshell.guid
import ifcopenshell.util.unit
import numpy as np

Entity = ifcopenshell.entity_instance
HeavyKind = Literal["footing", "slab"]

ROOM_CENTRE_M = (8.0, 0.0)
ROOM_INNER_M = 3.0  # clear width and depth of the room
WALL_THICKNESS_M = 0.1
WALL_HEIGHT_M = 2.0
COLUMN_SIZE_M = 0.15
FRAME_HEIGHT_M = 2.5
STEEL_KG_M3 = 7850.0
TIMBER_KG_M3 = 500.0
CONCRETE_KG_M3 = 2400.0
FOOTING_SIZE_M = (2.0, 2.0, 0.6)
SLAB_SIZE_M = (4.0, 3.0, 0.25)
SLAB_CORNER_M = (-0.5, 3.0)  # south-west corner of the heavy slab on the ground
HEAVY_MASS_KG = {
    "footing": float(np.prod(FOOTING_SIZE_M)) * CONCRETE_KG_M3,  # 5,760 kg
    "slab": float(np.prod(SLAB_SIZE_M)) * CONCRETE_KG_M3,  # 7,200 kg
}
HEAVY_NAME = {"footing": "Footing A1", "slab": "Slab H1"}

FRAME = ("Column A1", "Column A2", "Beam A1-A2")
ROOM_WALLS = ("Wall R-S", "Wall R-W", "Wall R-N", "Wall R-E")


def construction_order(
    heavy: HeavyKind | None = "footing", room: bool = True, *, walls_first: bool = False
) -> tuple[str, ...]:
    """Every component's name in a construction order for the model with these options: a footing first,
    then the frame, then the room's column before its walls (``walls_first``: after them, which cuts the
    column off), a heavy slab last."""
    order: list[str] = ["Footing A1"] if heavy == "footing" else []
    order += FRAME
    if room:
        order += [*ROOM_WALLS, "Column R1"] if walls_first else ["Column R1", *ROOM_WALLS]
    if heavy == "slab":
        order.append("Slab H1")
    return tuple(order)


GOOD_ORDER = construction_order()  # for the default model (heavy footing, room)
WALLS_FIRST_ORDER = construction_order(walls_first=True)  # the walls close the room before its column

GUID_NAMESPACE = uuid.uuid5(uuid.NAMESPACE_URL, "https://github.com/bimbot/tests/site-models")


@dataclass(frozen=True)
class SiteModel:
    """The generated model and its elements by name."""

    file: ifcopenshell.file
    elements: dict[str, Entity] = field(default_factory=dict)

    def guid(self, name: str) -> str:
        return str(self.elements[name].GlobalId)

    def write(self, path: Path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        self.file.write(str(path))
        return path


def expected_masses_kg(heavy: HeavyKind | None = "footing", room: bool = True) -> dict[str, float]:
    """Name → mass (kg) of every component a default conversion gives (volume × density)."""
    column = COLUMN_SIZE_M**2 * STEEL_KG_M3
    masses = {
        "Column A1": column * FRAME_HEIGHT_M,
        "Column A2": column * FRAME_HEIGHT_M,
        "Beam A1-A2": 0.10 * 0.20 * (3.0 + COLUMN_SIZE_M) * STEEL_KG_M3,
    }
    if room:
        long_m, short_m = ROOM_INNER_M + 2 * WALL_THICKNESS_M, ROOM_INNER_M
        wall = WALL_THICKNESS_M * WALL_HEIGHT_M * TIMBER_KG_M3
        masses |= {"Column R1": column * WALL_HEIGHT_M}
        masses |= {
            name: wall * (long_m if name in ("Wall R-S", "Wall R-N") else short_m) for name in ROOM_WALLS
        }
    if heavy is not None:
        masses[HEAVY_NAME[heavy]] = HEAVY_MASS_KG[heavy]
    return masses


def build_site_model(
    *,
    schema: str = "IFC4",
    room: bool = True,
    heavy: HeavyKind | None = "footing",
    furniture: bool = True,
    schedule: Sequence[str] | None = None,
) -> SiteModel:
    """The site model described in the module docstring. ``schedule`` names must be elements of it."""
    if heavy not in (None, "footing", "slab"):
        raise ValueError(f"heavy must be 'footing', 'slab' or None, got {heavy!r}")
    builder = _Builder(schema)
    if heavy == "footing":
        width, depth, height = FOOTING_SIZE_M
        builder.box(
            "IfcFooting", "Footing A1", (width, depth, height), (-width / 2, -depth / 2, -height), "concrete"
        )
    half = COLUMN_SIZE_M / 2
    for name, x_m in (("Column A1", 0.0), ("Column A2", 3.0)):
        builder.box(
            "IfcColumn",
            name,
            (COLUMN_SIZE_M, COLUMN_SIZE_M, FRAME_HEIGHT_M),
            (x_m - half, -half, 0.0),
            "steel",
        )
    builder.box(
        "IfcBeam", "Beam A1-A2", (3.0 + COLUMN_SIZE_M, 0.10, 0.20), (-half, -0.05, FRAME_HEIGHT_M), "steel"
    )
    if room:
        cx, cy = ROOM_CENTRE_M
        builder.box(
            "IfcColumn",
            "Column R1",
            (COLUMN_SIZE_M, COLUMN_SIZE_M, WALL_HEIGHT_M),
            (cx - half, cy - half, 0.0),
            "steel",
        )
        inner, t = ROOM_INNER_M / 2, WALL_THICKNESS_M
        walls = {
            "Wall R-S": ((2 * inner + 2 * t, t, WALL_HEIGHT_M), (cx - inner - t, cy - inner - t, 0.0)),
            "Wall R-W": ((t, 2 * inner, WALL_HEIGHT_M), (cx - inner - t, cy - inner, 0.0)),
            "Wall R-N": ((2 * inner + 2 * t, t, WALL_HEIGHT_M), (cx - inner - t, cy + inner, 0.0)),
            "Wall R-E": ((t, 2 * inner, WALL_HEIGHT_M), (cx + inner, cy - inner, 0.0)),
        }
        for name, (size, corner) in walls.items():
            builder.box("IfcWall", name, size, corner, "timber")
        builder.space("Room R", (2 * inner, 2 * inner, WALL_HEIGHT_M), (cx - inner, cy - inner, 0.0))
        if furniture:
            furniture_class = "IfcFurnishingElement" if builder.file.schema == "IFC2X3" else "IfcFurniture"
            builder.box(furniture_class, "Table R1", (1.2, 0.6, 0.75), (cx - 1.4, cy + 0.6, 0.0), "timber")
    if heavy == "slab":
        builder.box("IfcSlab", "Slab H1", SLAB_SIZE_M, (*SLAB_CORNER_M, 0.0), "concrete")
    if schedule is not None:
        builder.schedule(schedule)
    builder.assign_guids()
    return SiteModel(builder.file, dict(builder.elements))


class _Builder:
    """Project, millimetre units, Body context, site → building → storey, three materials with densities."""

    def __init__(self, schema: str) -> None:
        self.file = ifcopenshell.api.project.create_file(version=schema)
        if self.file.schema == "IFC2X3":
            ifcopenshell.api.owner.add_application(self.file)
            person = ifcopenshell.api.owner.add_person(self.file, identification="bimbot", family_name="Test")
            org = ifcopenshell.api.owner.add_organisation(self.file, identification="bimbot", name="bimbot")
            ifcopenshell.api.owner.add_person_and_organisation(self.file, person=person, organisation=org)
        project = ifcopenshell.api.root.create_entity(
            self.file, ifc_class="IfcProject", name="bimbot site model"
        )
        units = [
            ifcopenshell.api.unit.add_si_unit(self.file, unit_type="LENGTHUNIT", prefix="MILLI"),
            ifcopenshell.api.unit.add_si_unit(self.file, unit_type="AREAUNIT"),
            ifcopenshell.api.unit.add_si_unit(self.file, unit_type="VOLUMEUNIT"),
        ]
        ifcopenshell.api.unit.assign_unit(self.file, units=units)
        model_context = ifcopenshell.api.context.add_context(self.file, context_type="Model")
        self.body = ifcopenshell.api.context.add_context(
            self.file,
            context_type="Model",
            context_identifier="Body",
            target_view="MODEL_VIEW",
            parent=model_context,
        )
        parent = project
        for ifc_class, name in (
            ("IfcSite", "Test Site"),
            ("IfcBuilding", "Test Building"),
            ("IfcBuildingStorey", "Level 0"),
        ):
            spatial = ifcopenshell.api.root.create_entity(self.file, ifc_class=ifc_class, name=name)
            ifcopenshell.api.aggregate.assign_object(self.file, products=[spatial], relating_object=parent)
            ifcopenshell.api.geometry.edit_object_placement(self.file, product=spatial, matrix=np.eye(4))
            parent = spatial
        self.storey = parent
        self.materials = {
            "steel": self._material("Steel S235", "steel", STEEL_KG_M3),
            "timber": self._material("Timber C24", "wood", TIMBER_KG_M3),
            "concrete": self._material("Concrete C30/37", "concrete", CONCRETE_KG_M3),
        }
        self.elements: dict[str, Entity] = {}
        self.mm_per_m = 1.0 / ifcopenshell.util.unit.calculate_unit_scale(self.file)

    def _material(self, name: str, category: str, density_kg_m3: float) -> Entity:
        category_or_none = None if self.file.schema == "IFC2X3" else category
        material = ifcopenshell.api.material.add_material(self.file, name=name, category=category_or_none)
        pset = ifcopenshell.api.pset.add_pset(self.file, product=material, name="Pset_MaterialCommon")
        ifcopenshell.api.pset.edit_pset(self.file, pset=pset, properties={"MassDensity": density_kg_m3})
        return material

    def _box_representation(self, size_m: Sequence[float]) -> Entity:
        """A box of ``size_m`` from the local origin along +x, +y, +z: a rectangle extruded up."""
        x_mm, y_mm = (float(v) * self.mm_per_m for v in size_m[:2])
        centre = self.file.createIfcCartesianPoint((x_mm / 2, y_mm / 2))
        position = self.file.createIfcAxis2Placement2D(centre, None)
        profile = self.file.createIfcRectangleProfileDef("AREA", None, position, x_mm, y_mm)
        return ifcopenshell.api.geometry.add_profile_representation(
            self.file, context=self.body, profile=profile, depth=float(size_m[2])
        )

    def _place(self, product: Entity, corner_m: Sequence[float]) -> None:
        matrix = np.eye(4)
        matrix[:3, 3] = corner_m
        ifcopenshell.api.geometry.edit_object_placement(self.file, product=product, matrix=matrix)

    def box(
        self, ifc_class: str, name: str, size_m: Sequence[float], corner_m: Sequence[float], material: str
    ) -> Entity:
        """An ``ifc_class`` element: an axis-aligned box of ``size_m``, min corner at ``corner_m``."""
        element = ifcopenshell.api.root.create_entity(self.file, ifc_class=ifc_class, name=name)
        ifcopenshell.api.geometry.assign_representation(
            self.file, product=element, representation=self._box_representation(size_m)
        )
        self._place(element, corner_m)
        ifcopenshell.api.spatial.assign_container(
            self.file, products=[element], relating_structure=self.storey
        )
        ifcopenshell.api.material.assign_material(
            self.file, products=[element], material=self.materials[material]
        )
        self.elements[name] = element
        return element

    def space(self, name: str, size_m: Sequence[float], corner_m: Sequence[float]) -> Entity:
        """An IfcSpace (spatial, never a component) aggregated under the storey."""
        space = ifcopenshell.api.root.create_entity(self.file, ifc_class="IfcSpace", name=name)
        ifcopenshell.api.aggregate.assign_object(self.file, products=[space], relating_object=self.storey)
        ifcopenshell.api.geometry.assign_representation(
            self.file, product=space, representation=self._box_representation(size_m)
        )
        self._place(space, corner_m)
        return space

    def schedule(self, names: Sequence[str]) -> None:
        """A work schedule with one task per name, chained FINISH_START in the given order."""
        unknown = [name for name in names if name not in self.elements]
        if unknown:
            raise ValueError(f"schedule names elements the model does not have: {', '.join(unknown)}")
        work_schedule = ifcopenshell.api.sequence.add_work_schedule(self.file, name="Construction")
        tasks = []
        for number, name in enumerate(names, start=1):
            if self.file.schema == "IFC2X3":  # no Identification or PredefinedType on an IFC2X3 task
                task = ifcopenshell.api.sequence.add_task(self.file, name=f"Build {name}")
                task.TaskId = f"T{number:03d}"
            else:
                task = ifcopenshell.api.sequence.add_task(
                    self.file,
                    name=f"Build {name}",
                    identification=f"T{number:03d}",
                    predefined_type="CONSTRUCTION",
                )
            ifcopenshell.api.sequence.assign_product(
                self.file, relating_product=self.elements[name], related_object=task
            )
            tasks.append(task)
        ifcopenshell.api.control.assign_control(
            self.file, relating_control=work_schedule, related_objects=tasks
        )
        for before, after in itertools.pairwise(tasks):
            if self.file.schema == "IFC2X3":  # the api's sequence cascade needs IFC4 task times
                relation = ifcopenshell.api.root.create_entity(self.file, ifc_class="IfcRelSequence")
                relation.RelatingProcess, relation.RelatedProcess = before, after
                relation.TimeLag, relation.SequenceType = 0.0, "FINISH_START"
            else:
                ifcopenshell.api.sequence.assign_sequence(
                    self.file, relating_process=before, related_process=after, sequence_type="FINISH_START"
                )

    def assign_guids(self) -> None:
        """GlobalIds from each element's class and name; the rest keep the api's random ones."""
        for name, element in self.elements.items():
            key = f"{element.is_a()}:{name}"
            element.GlobalId = ifcopenshell.guid.compress(uuid.uuid5(GUID_NAMESPACE, key).hex)
