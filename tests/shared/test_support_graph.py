"""Support graph: contact under gravity and connections give predecessors; derived order honours them."""

from __future__ import annotations

import logging

import pytest

from bimbot.shared.connection_kinds import SupportKind, SupportWhen, TemporarySupportNeed
from bimbot.shared.manifest import (
    BoundingBox,
    CollisionMethod,
    Component,
    ComponentFiles,
    Connection,
    Inertia,
    InertiaSource,
    Joint,
    JointSource,
    MassSource,
    Pose,
)
from bimbot.shared.sequence import sequence_from_predecessors
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
        connections=[  # (relation, other) or (relation, other, role)
            Connection(relation=r, role=(role or ["related"])[0], other_guid=o, other_class="")
            for r, o, *role in connections
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


def _door_under_its_header_wall() -> list[Component]:
    """The Janesville restaurant's storefront: a thin brick wall over a door (z 2.489–2.565 m) hosts the
    door (IfcRelFillsElement), whose frame reaches from the floor (0.051 m) to the wall's top. The wall
    rests on nothing from above: it would float, so it is held by what it touches at its side with a lower
    bottom, the door, which is set into it."""
    return [
        _component("slab", "IfcSlab", (-1.0, -1.0, -0.2), (5.0, 1.0, 0.05)),
        _component(
            "door",
            "IfcDoor",
            (1.0, -0.1, 0.051),
            (2.8, 0.1, 2.565),
            (("IfcRelFillsElement", "header", "filling"),),
        ),
        _component(
            "header",
            "IfcWall",
            (0.9, -0.1, 2.489),
            (2.9, 0.1, 2.565),
            (("IfcRelFillsElement", "door", "host"),),
        ),
    ]


def test_a_wall_and_the_door_it_hosts_each_resting_on_the_other_make_no_cycle() -> None:
    """Before, the wall rested on the door (at its side) and the door on its host, the wall: a precedence
    cycle, and ``bimbot convert`` of the restaurant (and of a Revit office) ended in a traceback."""
    components = _door_under_its_header_wall()
    preds = support_predecessors(components)
    assert preds["door"] == {"slab", "header"}  # the host first, whatever the heights
    assert "door" not in preds["header"]
    assert derive_sequence(components).guids() == ["slab", "header", "door"]


def _joint(part: str, member: str, *, source: JointSource = JointSource.RULE, directed: bool = True) -> Joint:
    return Joint(guids=(part, member), depth_m=0.05, source=source, rule="test", directed=directed)


def test_joints_order_their_pair_the_lower_first_else_the_one_that_bears_else_the_larger() -> None:
    components = [
        _component("footing", "IfcFooting", (-0.5, -0.5, -0.5), (0.5, 0.5, 0.0)),
        _component("column", "IfcColumn", (-0.15, -0.15, -0.05), (0.15, 0.15, 3.0)),  # 50 mm into the footing
        _component("main", "IfcBeam", (0.0, -0.1, 3.0), (6.0, 0.1, 3.4)),
        _component("secondary", "IfcBeam", (3.0, 0.05, 3.0), (3.1, 4.0, 3.4)),  # same bottom as the main
        _component("wall_a", "IfcWall", (10.0, 0.0, 0.0), (14.0, 0.2, 3.0)),
        _component("wall_b", "IfcWall", (13.8, 0.0, 0.0), (14.0, 2.0, 3.0)),  # smaller, same bottom
    ]
    joints = [
        _joint("column", "footing"),  # as a rule could state it the wrong way round: the lower goes first
        _joint("main", "secondary"),  # the secondary beam bears on the main one
        _joint("wall_b", "wall_a", source=JointSource.RELATION, directed=False),  # no direction: the larger
    ]
    preds = support_predecessors(components, joints=joints)
    assert "footing" in preds["column"] and "column" not in preds["footing"]
    assert preds["secondary"] >= {"main"} and "secondary" not in preds["main"]
    assert preds["wall_b"] == {"wall_a"} and preds["wall_a"] == set()


def test_joints_and_connections_in_both_directions_make_no_cycle() -> None:
    """Two beams at one level that the IFC connects both ways, and that two joints name each way round."""
    components = [
        _component(
            "a", "IfcBeam", (0.0, 0.0, 3.0), (4.0, 0.2, 3.4), (("IfcRelConnectsElements", "b", "relating"),)
        ),
        _component(
            "b", "IfcBeam", (3.9, 0.0, 3.0), (8.0, 0.2, 3.4), (("IfcRelConnectsElements", "a", "relating"),)
        ),
    ]
    preds = support_predecessors(components, joints=[_joint("a", "b"), _joint("b", "a")])
    assert len(derive_sequence(components, support=preds).guids()) == 2
    assert preds["a"] & {"b"} == set() or preds["b"] & {"a"} == set()


def test_a_component_a_broken_cycle_leaves_with_no_support_is_held_by_what_it_touches_at_its_side() -> None:
    """Two beams 3 m up that two joints order each way round, and a column beside both: the cycle is
    broken, and the beam it left with nothing before it would be set in the air (the duplex's upper
    partition, whose only support was a guard rail a cycle took away, fell 2.7 m): it waits for the column
    it touches, as a beam that never had a support does."""
    components = [
        _component("a", "IfcBeam", (0.0, 0.0, 3.0), (4.0, 0.2, 3.4)),
        _component("b", "IfcBeam", (3.9, 0.0, 3.0), (8.0, 0.2, 3.4)),
        _component("c", "IfcColumn", (3.8, 0.2, 0.0), (4.1, 0.5, 3.4)),
    ]
    preds = support_predecessors(components, joints=[_joint("a", "b"), _joint("b", "a")])
    assert preds["a"] and preds["b"]  # neither floats
    emptied = "a" if "b" not in preds["a"] else "b"
    assert preds[emptied] == {"c"}
    assert len(derive_sequence(components, support=preds).guids()) == 3


def test_a_cycle_in_a_given_support_map_is_broken_with_a_warning(caplog: pytest.LogCaptureFixture) -> None:
    components = _portal()
    support = {component.guid: set() for component in components}
    support["col_a"] = {"beam"}
    support["beam"] = {"col_a"}
    with pytest.raises(ValueError, match="precedence cycle"):  # what derive_sequence used to raise
        sequence_from_predecessors(
            ["col_a", "beam"], {"col_a": {"beam"}, "beam": {"col_a"}}, source="derived"
        )
    with caplog.at_level(logging.WARNING, logger="bimbot.shared.support_graph"):
        order = derive_sequence(components, support=support).guids()
    assert sorted(order) == sorted(c.guid for c in components)
    assert "would wait for itself" in caplog.text
    assert support["beam"] == {"col_a"}  # the caller's map is left as it was


def test_what_is_set_down_over_a_foundations_open_pit_waits_for_it_though_they_do_not_touch() -> None:
    """The restaurant's courtyard: a 0.7 m slab at -1.52..-0.81 m, a floor panel drawn 0.4 m above it, a
    curb 0.1 m above it and a handrail 0.9 m above it (the fill between is not modelled). Released first,
    each fell into the slab's pit. A panel beside the excavation does not wait for it, nor a column on its
    own footing inside the excavation (the steel may go up before the slab on grade is poured)."""
    slab = _component("slab", "IfcSlab", (0, 0, -1.52), (10, 10, -0.81))
    panel = _component("panel", "IfcSlab", (2, 2, -0.41), (4, 4, -0.1))
    curb = _component("curb", "IfcWall", (9.5, 0, -0.71), (10.2, 10, 0.08))
    rail = _component("rail", "IfcRailing", (5, 5, 0.08), (5.2, 9, 0.99))
    beside = _component("beside", "IfcSlab", (10.3, 0, -0.41), (12, 10, -0.1))
    footing = _component("footing", "IfcFooting", (6, 6, -2.0), (7, 7, -1.52))
    column = _component("column", "IfcColumn", (6.4, 6.4, -1.52), (6.6, 6.6, 3.0))
    preds = support_predecessors([slab, panel, curb, rail, beside, footing, column])
    assert "slab" in preds["panel"] and "slab" in preds["curb"] and "slab" in preds["rail"]
    assert "slab" not in preds["beside"] and preds["column"] == {"footing"}
    assert preds["slab"] == {"footing"} and preds["footing"] == set()


def test_a_propped_member_waits_for_the_foundation_whose_pit_its_props_would_stand_in() -> None:
    """The Revit duplex: a first-floor joist panel 2.8 m over the 127 mm slab on grade, framed at its side
    into an exterior wall, stands on props until its neighbours hold it; its props stand in the slab's pit,
    so the slab is poured first. Unpropped, the same panel does not wait for the slab: its wall holds it."""
    slab = _component("slab", "IfcSlab", (0.4, -9.7, -0.13), (8.4, -0.4, 0.0))
    wall = _component("wall", "IfcWall", (8.4, -9.7, -0.13), (8.8, -0.4, 3.1))
    panel = _component("panel", "IfcSlab", (4.7, -6.8, 2.8), (8.38, -4.7, 3.1))
    props = TemporarySupportNeed(kind=SupportKind.PROPS, count=2, place_s=90.0, when=SupportWhen.UNCONNECTED)
    propped = panel.model_copy(update={"temporary_support": props})
    assert "slab" in support_predecessors([slab, wall, propped])["panel"]
    assert support_predecessors([slab, wall, panel])["panel"] == {"wall"}


def test_a_wall_part_over_the_ceiling_line_rests_on_the_wall_below_not_on_the_ceiling() -> None:
    """Revit splits a wall at a level: its part above the ceiling line stands on the wall below, where the
    ceiling's edge is drawn into that wall. A ceiling is hung: it carries no wall (the restaurant's kitchen
    strips waited for the ceiling, which waits for the walls that close the kitchen). A lamp set in the
    ceiling still rests on it."""
    ceiling = _component("ceiling", "IfcCovering", (0.0, 0.0, 3.69), (3.0, 3.0, 3.746))
    ceiling = ceiling.model_copy(update={"predefined_type": "CEILING"})
    floor = _component("floor", "IfcSlab", (-1.0, -1.0, -0.2), (4.0, 4.0, 0.0))
    wall = _component("wall", "IfcWallStandardCase", (2.95, 0.0, 0.0), (3.05, 3.0, 3.75))
    strip = _component("strip", "IfcWallStandardCase", (2.95, 0.0, 3.75), (3.05, 3.0, 3.87))
    lamp = _component("lamp", "IfcLightFixture", (1.0, 1.0, 3.746), (1.3, 1.3, 3.8))
    preds = support_predecessors([ceiling, floor, wall, strip, lamp])
    assert preds["strip"] == {"wall"}
    assert preds["lamp"] == {"ceiling"}
    flooring = ceiling.model_copy(
        update={"predefined_type": "FLOORING", "guid": "flooring", "key": "flooring"}
    )
    assert support_predecessors([flooring, floor, wall, strip])["strip"] == {"wall", "flooring"}


# --- linings: a thin wall against a thicker one's face goes up after it ---------------------------------


def test_a_furring_against_a_party_wall_face_goes_up_after_it_whatever_their_order() -> None:
    """The Revit duplex: a 152 mm stud furring drawn 57 mm into its 550 mm CMU party wall's box, face to
    face over 2 m on the same floor. Listed first, it still waits for the wall."""
    party = _component("party", "IfcWall", (4.125, -11.72, 3.1), (4.675, -8.907, 6.0))
    furring = _component("furring", "IfcWall", (4.618, -10.95, 3.1), (4.77, -6.79, 5.695))
    preds = support_predecessors([furring, party])
    assert preds["furring"] == {"party"} and preds["party"] == set()


def test_no_lining_at_a_t_junction_between_equal_walls_or_under_a_metre_of_run() -> None:
    """A partition's end against another's face runs the crossing wall's thickness, not a face; two walls
    of one thickness side by side are no lining; a stud wall touching a thick wall for 0.6 m is none."""
    crossing = _component("crossing", "IfcWall", (0.0, 0.0, 0.0), (6.0, 0.124, 2.7))
    ending = _component("ending", "IfcWall", (2.0, 0.124, 0.0), (2.124, 4.0, 2.7))
    twin = _component("twin", "IfcWall", (0.0, 0.124, 0.0), (6.0, 0.248, 2.7))
    thick = _component("thick", "IfcWall", (10.0, 0.0, 0.0), (10.5, 6.0, 2.7))
    short = _component("short", "IfcWall", (10.5, 0.0, 0.0), (10.65, 0.6, 2.7))
    preds = support_predecessors([crossing, ending, twin, thick, short])
    assert all(not supports for supports in preds.values()), preds


def test_a_floor_finish_goes_in_after_the_walls_beside_it_and_before_a_wall_standing_on_it() -> None:
    """The duplex's 13 mm tile floor touches the furring standing on the slab beside it: the tiles go in
    after it, cut to it. A partition drawn standing on a 40 mm board floor is carried by it: the boards go
    first. A 200 mm slab beside a wall is no finish."""
    furring = _component("furring", "IfcWall", (4.03, -7.582, 0.0), (8.383, -7.43, 2.795))
    tiles = _component("tiles", "IfcSlab", (2.574, -7.43, 0.0), (8.383, -5.2, 0.013))
    boards = _component("boards", "IfcCovering", (20.0, 0.0, 0.0), (24.0, 4.0, 0.04))
    partition = _component("partition", "IfcWall", (21.0, 1.0, 0.04), (21.124, 4.0, 2.7))
    slab = _component("slab", "IfcSlab", (30.0, 0.0, 0.0), (34.0, 4.0, 0.2))
    beside = _component("beside", "IfcWall", (34.0, 0.0, 0.0), (34.2, 4.0, 2.7))
    preds = support_predecessors([tiles, furring, boards, partition, slab, beside])
    assert preds["tiles"] == {"furring"} and preds["furring"] == set()
    assert preds["partition"] == {"boards"} and preds["boards"] == set()
    assert preds["slab"] == set()


def test_a_cycle_is_a_warning_for_the_converter_and_said_at_info_by_what_reads_the_build_again(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """The duplex's two cycles were printed again by fleet check and run: the converter warns once, the
    readers of its build (fleet check, planner, physics) log the same cycle at INFO."""
    components = [
        _component(
            "a", "IfcBeam", (0.0, 0.0, 3.0), (4.0, 0.2, 3.4), (("IfcRelConnectsElements", "b", "relating"),)
        ),
        _component(
            "b", "IfcBeam", (3.9, 0.0, 3.0), (8.0, 0.2, 3.4), (("IfcRelConnectsElements", "a", "relating"),)
        ),
    ]
    joints = [_joint("a", "b"), _joint("b", "a")]
    with caplog.at_level(logging.INFO, logger="bimbot.shared.support_graph"):
        support_predecessors(components, joints=joints)
        support_predecessors(components, joints=joints, cycles_level=logging.INFO)
    levels = [record.levelno for record in caplog.records if "would wait for itself" in record.message]
    assert levels == [logging.WARNING, logging.INFO]
