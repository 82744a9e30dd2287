"""Support graph: contact under gravity and connections give predecessors; derived order honours them."""

from __future__ import annotations

from bimbot.shared.manifest import (
    BoundingBox,
    CollisionMethod,
    Component,
    ComponentFiles,
    Connection,
    Inertia,
    InertiaSource,
    MassSource,
    Pose,
)
from bimbot.shared.support_graph import derive_sequence, support_predecessors, support_violations


def _component(guid: str, ifc_class: str, low: tuple, high: tuple, connections: tuple = ()) -> Component:
    files = ComponentFiles(
        model_dir="m",
        sdf_file="m/model.sdf",
        config_file="m/model.config",
        split_ifc="m/x.ifc",
        visual_dae="a",
        visual_obj="b",
        visual_glb="c",
        collision=[],
    )
    return Component(
        guid=guid,
        key=guid,
        folder=guid,
        ifc_class=ifc_class,
        target_pose_world=Pose(position_m=(0, 0, 0), quat_xyzw=(0, 0, 0, 1), rpy_rad=(0, 0, 0)),
        bbox_world=BoundingBox(min_m=low, max_m=high),
        bbox_local=BoundingBox(min_m=low, max_m=high),
        volume_m3=1.0,
        watertight=True,
        mass_kg=1.0,
        mass_source=MassSource.DEFAULT_DENSITY,
        com_local_m=(0, 0, 0),
        inertia_kg_m2=Inertia(ixx=1, ixy=0, ixz=0, iyy=1, iyz=0, izz=1),
        inertia_source=InertiaSource.MESH,
        collision_method=CollisionMethod.CONVEX_HULL,
        collision_parts=1,
        files=files,
        connections=[
            Connection(relation=r, role="related", other_guid=o, other_class="") for r, o in connections
        ],
    )


def _portal() -> list[Component]:
    """Two footings, two columns, a beam across them, and a lamp hanging off the beam (connected, lower)."""
    return [
        _component("beam", "IfcBeam", (0.0, -0.05, 3.0), (4.0, 0.05, 3.2)),
        _component("col_b", "IfcColumn", (3.95, -0.05, 0.0), (4.05, 0.05, 3.0)),
        _component("foot_a", "IfcFooting", (-0.3, -0.3, -0.3), (0.3, 0.3, 0.0)),
        _component("col_a", "IfcColumn", (-0.05, -0.05, 0.0), (0.05, 0.05, 3.0)),
        _component("foot_b", "IfcFooting", (3.7, -0.3, -0.3), (4.3, 0.3, 0.0)),
        _component(
            "lamp",
            "IfcBuildingElementProxy",
            (1.9, -0.1, 2.5),
            (2.1, 0.1, 2.9),
            (("IfcRelConnectsElements", "beam"),),
        ),
    ]


def test_elements_rest_on_what_touches_them_from_below() -> None:
    preds = support_predecessors(_portal())
    assert preds["col_a"] == {"foot_a"}
    assert preds["col_b"] == {"foot_b"}
    assert preds["beam"] >= {"col_a", "col_b"}
    assert preds["foot_a"] == set()


def test_connection_to_a_lower_element_makes_it_a_support_but_not_upwards() -> None:
    preds = support_predecessors(_portal())
    assert preds["beam"] == {"col_a", "col_b", "lamp"}  # connected and lower: the beam waits for it
    assert "beam" not in preds["lamp"]


def test_footprints_that_do_not_overlap_are_not_supports() -> None:
    components = [
        _component("a", "IfcSlab", (0, 0, 0), (1, 1, 0.2)),
        _component("b", "IfcSlab", (2, 2, 0.2), (3, 3, 0.4)),  # top of a = bottom of b, but elsewhere
    ]
    assert support_predecessors(components)["b"] == set()


def test_derived_sequence_puts_supports_first_and_lists_every_component_once() -> None:
    sequence = derive_sequence(_portal())
    order = sequence.guids()
    assert sorted(order) == sorted(c.guid for c in _portal())
    assert not support_violations(order, support_predecessors(_portal()))
    assert order[:2] == ["foot_a", "foot_b"]
    assert sequence.source == "derived"


def test_violations_name_the_component_and_its_late_support() -> None:
    preds = support_predecessors(_portal())
    bad_order = ["beam", "foot_a", "foot_b", "col_a", "col_b", "lamp"]
    violations = support_violations(bad_order, preds)
    assert ("beam", "col_a") in violations
    assert ("col_a", "foot_a") not in violations


def test_a_beam_framed_into_the_faces_of_two_columns_waits_for_them() -> None:
    """Revit frames beams into column faces: the beam's bottom is below the columns' tops, nothing touches
    it from below, and without the side contact it would be erected first, in the air."""
    components = [
        _component("col_a", "IfcColumn", (-0.15, -0.15, 0.0), (0.15, 0.15, 4.0)),
        _component("col_b", "IfcColumn", (5.85, -0.15, 0.0), (6.15, 0.15, 4.0)),
        _component(
            "beam", "IfcBeam", (0.15, -0.05, 3.5), (5.85, 0.05, 3.8)
        ),  # end to face, 0.2 m below the tops
        _component(
            "far", "IfcBeam", (10.0, -0.05, 3.5), (12.0, 0.05, 3.8)
        ),  # touches nothing: stays as it is
    ]
    preds = support_predecessors(components)
    assert preds["beam"] == {"col_a", "col_b"}
    assert preds["far"] == set()
    assert derive_sequence(components).guids().index("beam") > 1


def test_a_beam_resting_on_one_end_is_also_held_by_the_column_it_is_framed_into() -> None:
    """The hub's channel beam 692716 sits on a channel column at one end and is framed into the face of a
    taller column at the other. With only the first as its support it was erected while the taller
    column was never built (out of the carrier's reach), and tipped off three times; now it waits for both
    (and is blocked by the one not built, which names it)."""
    components = [
        _component("short", "IfcColumn", (5.7, -0.05, 0.0), (6.0, 0.05, 3.2)),
        _component("tall", "IfcColumn", (-0.3, -0.15, 0.0), (0.0, 0.15, 3.9)),
        _component("beam", "IfcBeam", (0.01, -0.05, 3.2), (6.0, 0.05, 3.5)),
    ]
    preds = support_predecessors(components)
    assert preds["beam"] == {"short", "tall"}
    order = derive_sequence(components).guids()
    assert order.index("beam") > max(order.index("short"), order.index("tall"))


def test_a_beam_resting_on_both_ends_gains_no_side_supports() -> None:
    """Balanced on its supports, a beam does not wait for a column it merely touches at its side."""
    components = [
        _component("col_a", "IfcColumn", (-0.05, -0.05, 0.0), (0.05, 0.05, 3.0)),
        _component("col_b", "IfcColumn", (3.95, -0.05, 0.0), (4.05, 0.05, 3.0)),
        _component("beside", "IfcColumn", (2.0, 0.05, 0.0), (2.2, 0.25, 4.0)),  # touches the beam's side
        _component("beam", "IfcBeam", (-0.05, -0.05, 3.0), (4.05, 0.05, 3.2)),
    ]
    assert support_predecessors(components)["beam"] == {"col_a", "col_b"}
