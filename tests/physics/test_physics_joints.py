"""Joints in physics (services/physics/joints.py), with real pybullet on the bundled frame.

Column A1 is drawn 50 mm down into Footing A1, as real models draw a column into its footing. As a joint
(``Manifest.joints``) the column set at its target is connected to the built footing where it was set: it
stays within the agents' tolerances and names no clash. Without the joint the same overlap is a clash in
the IFC: reported with its depth, and physics pushes the two apart.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from contextlib import ExitStack
from pathlib import Path

import pytest

from bimbot.services.physics.client import p
from bimbot.services.physics.connections import ConnectionConfig
from bimbot.services.physics.handling_state import target_frame
from bimbot.services.physics.model_clashes import model_clashes
from bimbot.services.physics.release import Watch
from bimbot.services.physics.scene import component_pose, set_component_pose
from bimbot.services.physics.simulation import SimConfig, Simulation
from bimbot.shared.connection_hold import longest_hold_s
from bimbot.shared.manifest import Component, Joint, JointSource, Manifest
from bimbot.shared.verification import Tolerances

DRAWN_INTO_M = 0.05
HOLD_S = 2.0  # short, so that the tests stay fast; the default is 20 s


def _named(manifest: Manifest, name: str) -> Component:
    return next(c for c in manifest.components if c.name == name)


def _column_drawn_into_its_footing(manifest: Manifest, *, jointed: bool) -> Manifest:
    """The bundled frame with Column A1's target 50 mm lower: its foot inside Footing A1."""
    column, footing = _named(manifest, "Column A1"), _named(manifest, "Footing A1")
    x, y, z = column.target_pose_world.position_m
    target = column.target_pose_world.model_copy(update={"position_m": (x, y, z - DRAWN_INTO_M)})
    low, high = column.bbox_world.min_m, column.bbox_world.max_m
    box = column.bbox_world.model_copy(
        update={
            "min_m": (low[0], low[1], low[2] - DRAWN_INTO_M),
            "max_m": (high[0], high[1], high[2] - DRAWN_INTO_M),
        }
    )
    moved = column.model_copy(update={"target_pose_world": target, "bbox_world": box})
    components = [moved if c.guid == column.guid else c for c in manifest.components]
    joints = (
        [
            Joint(
                guids=(footing.guid, column.guid),
                depth_m=DRAWN_INTO_M,
                source=JointSource.RULE,
                rule="IfcColumn into IfcFooting, up to 100 mm",
            )
        ]
        if jointed
        else []
    )
    return manifest.model_copy(update={"components": components, "joints": joints})


@pytest.fixture
def stack() -> Iterator[ExitStack]:
    with ExitStack() as opened:
        yield opened


def _set_on_built_footing(stack: ExitStack, manifest: Manifest, build: Path) -> tuple[Simulation, Watch]:
    """Footing A1 built, then Column A1 set down at its target as a robot's placement releases it; the
    column's watch once the placement is answered."""
    config = SimConfig(robots=0, odom_noise=0.0, connections=ConnectionConfig(hold_s=HOLD_S))
    sim = stack.enter_context(Simulation(manifest, build, config))
    footing, column = _named(manifest, "Footing A1"), _named(manifest, "Column A1")
    target = footing.target_pose_world
    sim.handling.restore(footing.guid, (target.position_m, target.quat_xyzw), fixed=True, carrier=None)
    sim.handling.note_constructed(footing.guid, True)
    sim.handling.set_down(column.guid, sim.sim_time_s, tag="column")
    for _ in range(round((20.0 + longest_hold_s(column, HOLD_S)) / config.control_period_s)):
        if any(tag == "column" for tag, _ in sim.advance().replies):
            return sim, sim.handling.watch[column.guid]
    raise AssertionError("the column's placement was never answered")


def test_a_column_drawn_into_its_footing_as_a_joint_is_connected_and_stays_at_its_target(
    stack: ExitStack, frame_manifest: Manifest, bundled_build: Path
) -> None:
    manifest = _column_drawn_into_its_footing(frame_manifest, jointed=True)
    sim, watch = _set_on_built_footing(stack, manifest, bundled_build)
    footing, column = _named(manifest, "Footing A1"), _named(manifest, "Column A1")
    assert watch.connected_to == (footing.guid,)  # the joint is its connection: the footing is below it
    assert watch.clashes == ()
    for _ in range(round(3.0 / sim.config.control_period_s)):  # and it does not fall afterwards
        sim.advance()
    rest = component_pose(sim.client_id, sim.handling.items[column.guid].body)
    tolerances = Tolerances()
    assert math.dist(rest[0], column.target_pose_world.position_m) < tolerances.position_m
    assert sim.handling.pose_message(column.guid, sim.sim_time_s).drift_m < tolerances.drift_m
    assert sim.handling.pose_message(column.guid, sim.sim_time_s).clash_depth_m == {}


def test_the_same_overlap_without_a_joint_is_a_clash_with_its_depth(
    stack: ExitStack, frame_manifest: Manifest, bundled_build: Path
) -> None:
    manifest = _column_drawn_into_its_footing(frame_manifest, jointed=False)
    sim, watch = _set_on_built_footing(stack, manifest, bundled_build)
    footing, column = _named(manifest, "Footing A1"), _named(manifest, "Column A1")
    assert [guid for guid, _ in watch.clashes] == [footing.guid]
    assert dict(watch.clashes)[footing.guid] == pytest.approx(DRAWN_INTO_M, abs=0.005)
    assert watch.connected_to == ()  # a clash is never connected
    assert sim.handling.pose_message(column.guid, sim.sim_time_s).clash_depth_m == dict(watch.clashes)
    rest = component_pose(sim.client_id, sim.handling.items[column.guid].body)
    assert rest[0][2] - column.target_pose_world.position_m[2] > 0.04  # pushed out of the footing


def test_the_model_clash_scan_leaves_joints_out(
    stack: ExitStack, frame_manifest: Manifest, bundled_build: Path
) -> None:
    for jointed, expected in ((False, 1), (True, 0)):
        manifest = _column_drawn_into_its_footing(frame_manifest, jointed=jointed)
        sim = stack.enter_context(Simulation(manifest, bundled_build, SimConfig(robots=0)))
        items = sim.handling.items
        clashes = model_clashes(
            sim.client_id,
            {guid: item.body for guid, item in items.items()},
            {guid: target_frame(item.component) for guid, item in items.items()},
            sim.handling.joints,
        )
        assert len(clashes) == expected, jointed


def test_a_placement_off_its_target_into_a_neighbour_is_no_clash_in_the_ifc(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    """Two 0.6 m footings side by side, touching at their targets. The second set down 25 mm into the
    built first is moved back out to the contact (the robot stops there) and names no clash: the model
    does not put the two into each other, the placement did (a house run had failed a wall "unstable: a
    clash in the IFC" for a 10 mm placement error into the wall it meets). The same 25 mm drawn by the
    model stays a clash (test_physics_handling.py)."""
    sim = make_sim(robots=0)
    first, second = _named(frame_manifest, "Footing A1"), _named(frame_manifest, "Footing A2")
    (x, y, z), quat = target_frame(first)
    beside = second.target_pose_world.model_copy(update={"position_m": (x + 0.6, y, z)})
    item = sim.handling.items[second.guid]
    item.component = second.model_copy(update={"target_pose_world": beside})
    sim.handling.restore(first.guid, ((x, y, z), quat), fixed=True, carrier=None)
    sim.handling.note_constructed(first.guid, True)
    item.motion_to = ((x + 0.575, y, z), quat)  # as a robot 25 mm off
    set_component_pose(sim.client_id, item.body, item.motion_to)  # where its assembly motion brought it
    p.performCollisionDetection(physicsClientId=sim.client_id)  # its box there, as the steps leave it
    sim.handling.releasing.release(item, None, sim.sim_time_s, tag=None)
    watch = sim.handling.watch[second.guid]
    assert watch.clashes == ()
    assert sim.handling.pose_message(second.guid, sim.sim_time_s).clash_depth_m == {}
    assert watch.released[0][0] == pytest.approx(x + 0.6, abs=0.003)  # moved back out to the contact
    pose = sim.handling.pose_message(second.guid, sim.sim_time_s)  # its agent's stack-up advice reads this
    assert pose.set_against == [first.guid] and pose.set_against_shift_m == pytest.approx(0.025, abs=0.003)


def _released_beside_a_part_built_off_its_target(
    stack: ExitStack,
    frame_manifest: Manifest,
    bundled_build: Path,
    *,
    built_off_m: float,
    framed: bool,
    boards_of: tuple[str, str] | None = None,
) -> tuple[Simulation, Component, Component, float]:
    """Footing A2 framed to Footing A1 at an end, drawn touching it (0.6 m footings side by side). A1 is
    built ``built_off_m`` off its target towards A2; A2 is let go at its own target. Its released x, with
    A1's target x. With ``boards_of``, the two are covering panels cut from those elements instead."""
    first, second = _named(frame_manifest, "Footing A1"), _named(frame_manifest, "Footing A2")
    if boards_of is not None:
        first = first.model_copy(update={"ifc_class": "IfcCovering", "parent_guid": boards_of[0]})
        second = second.model_copy(update={"ifc_class": "IfcCovering", "parent_guid": boards_of[1]})
    (x, y, z), quat = target_frame(first)
    beside = second.target_pose_world.model_copy(update={"position_m": (x + 0.6, y, z)})
    moved = second.model_copy(update={"target_pose_world": beside})
    joints = (
        [
            Joint(
                guids=(first.guid, second.guid),
                depth_m=0.0,
                source=JointSource.FRAMED,
                rule="IfcBeam framed to IfcBeam, 10 mm erection clearance",
                clearance_m=0.010,
            )
        ]
        if framed
        else []
    )
    replaced = {first.guid: first, second.guid: moved}
    components = [replaced.get(c.guid, c) for c in frame_manifest.components]
    manifest = frame_manifest.model_copy(update={"components": components, "joints": joints})
    sim = stack.enter_context(Simulation(manifest, bundled_build, SimConfig(robots=0)))
    sim.handling.restore(first.guid, ((x + built_off_m, y, z), quat), fixed=True, carrier=None)
    sim.handling.note_constructed(first.guid, True)
    item = sim.handling.items[second.guid]
    item.motion_to = ((x + 0.6, y, z), quat)  # a robot that placed it exactly at its target
    set_component_pose(sim.client_id, item.body, item.motion_to)
    p.performCollisionDetection(physicsClientId=sim.client_id)
    sim.handling.releasing.release(item, None, sim.sim_time_s, tag=None)
    return sim, first, moved, x


def test_a_framed_end_takes_its_part_s_erection_error_in_its_clearance(
    stack: ExitStack, frame_manifest: Manifest, bundled_build: Path
) -> None:
    """The part stands 8 mm off towards the member (within the 10 mm tolerance): the member framed to it
    with a 10 mm erection clearance stays on its own target; without the framed joint it is moved 8 mm out
    of the part, as the hub's 150PFC was pushed off its target by the 300PFC it frames into."""
    sim, first, second, x = _released_beside_a_part_built_off_its_target(
        stack, frame_manifest, bundled_build, built_off_m=0.008, framed=True
    )
    watch = sim.handling.watch[second.guid]
    assert watch.released[0][0] == pytest.approx(x + 0.6, abs=0.0005)
    assert sim.handling.pose_message(second.guid, sim.sim_time_s).set_against == []
    sim, first, second, x = _released_beside_a_part_built_off_its_target(
        stack, frame_manifest, bundled_build, built_off_m=0.008, framed=False
    )
    watch = sim.handling.watch[second.guid]
    assert watch.released[0][0] == pytest.approx(x + 0.608, abs=0.002)
    assert sim.handling.pose_message(second.guid, sim.sim_time_s).set_against == [first.guid]


def test_a_part_off_by_more_than_the_clearance_still_moves_the_framed_member_out(
    stack: ExitStack, frame_manifest: Manifest, bundled_build: Path
) -> None:
    """15 mm into the member is deeper than its 10 mm clearance: the gap is closed, it is set against the
    part as any neighbour."""
    sim, first, second, x = _released_beside_a_part_built_off_its_target(
        stack, frame_manifest, bundled_build, built_off_m=0.015, framed=True
    )
    watch = sim.handling.watch[second.guid]
    assert watch.released[0][0] == pytest.approx(x + 0.615, abs=0.002)
    assert sim.handling.pose_message(second.guid, sim.sim_time_s).set_against == [first.guid]


def test_a_board_set_against_the_board_beside_it_built_off_its_target_is_trimmed_to_it(
    stack: ExitStack, frame_manifest: Manifest, bundled_build: Path
) -> None:
    """Two boards cut from one ceiling: the first stands 8 mm off towards the second (within its
    tolerance); the second, let go at its own target, stays there (a site trims its edge by up to the
    15 mm joint between them), where the Janesville restaurant's gypsum board was moved 17.6 mm out and
    failed. Boards of two different ceilings are not trimmed to each other: moved 8 mm out."""
    sim, first, second, x = _released_beside_a_part_built_off_its_target(
        stack, frame_manifest, bundled_build, built_off_m=0.008, framed=False, boards_of=("C", "C")
    )
    assert sim.handling.watch[second.guid].released[0][0] == pytest.approx(x + 0.6, abs=0.0005)
    assert sim.handling.pose_message(second.guid, sim.sim_time_s).set_against == []
    sim, first, second, x = _released_beside_a_part_built_off_its_target(
        stack, frame_manifest, bundled_build, built_off_m=0.008, framed=False, boards_of=("C", "D")
    )
    assert sim.handling.watch[second.guid].released[0][0] == pytest.approx(x + 0.608, abs=0.002)
    assert sim.handling.pose_message(second.guid, sim.sim_time_s).set_against == [first.guid]
