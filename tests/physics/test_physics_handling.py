"""Attach, carry, place and drop: reach checks with reasons, a carried load follows its robot, a placement
ends exactly at the requested pose and stays, placed footings stay below ground, a lost robot's load is
put down on the ground."""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from physics_builders import angle_between, bottom_z, distance_to_footprint, drive, idle, pose, west_of

from bimbot.services.physics.client import p
from bimbot.services.physics.handling_state import Phase
from bimbot.services.physics.pits import Pit
from bimbot.services.physics.scene import (
    component_pose,
    compose,
    distance_to_rect,
    footprint,
    set_component_pose,
)
from bimbot.services.physics.simulation import Simulation
from bimbot.shared.connection_kinds import (
    ConnectionKind,
    ConnectionLink,
    SupportKind,
    SupportWhen,
    TemporarySupportNeed,
)
from bimbot.shared.manifest import Component, Manifest, read_manifest
from bimbot.shared.messages import (
    AttachRequest,
    ComponentPoseMsg,
    DropRequest,
    PhysicsReply,
    PlaceRequest,
    PoseMsg,
    RobotPoseMsg,
)
from bimbot.shared.site_plan import Rect
from bimbot.shared.yard_slot import GROUND_CLEARANCE_M


@pytest.fixture(scope="module")
def frame_manifest(bundled_build: Path) -> Manifest:
    """The frame without the converter's connection links and temporary supports: what is under test here
    is release itself (resting, tipping, what a robot pushes), with connections made only beside what is
    built (links and supports: tests/physics/test_connections.py)."""
    manifest = read_manifest(bundled_build)
    unlinked = [
        c.model_copy(update={"connection_links": [], "temporary_support": None}) for c in manifest.components
    ]
    return manifest.model_copy(update={"components": unlinked})


def _first_in_row(sim: Simulation, manifest: Manifest, ifc_class: str) -> Component:
    """A component of ``ifc_class`` whose yard slot faces its aisle on the west side."""
    return next(
        c for c in manifest.components if c.ifc_class == ifc_class and sim.layout.slots[c.guid].aisle_side < 0
    )


def _picked(sim: Simulation, component: Component, robot_id: str = "r1") -> None:
    """``robot_id`` stands beside ``component`` in the yard, attaches it and waits for the lift."""
    slot = sim.layout.slots[component.guid]
    spot = slot.footprint
    x = spot.min_xy[0] - 0.8 if slot.aisle_side < 0 else spot.max_xy[0] + 0.8
    sim.teleport_robot(robot_id, (x, (spot.min_xy[1] + spot.max_xy[1]) / 2.0, math.pi / 2))  # in its aisle
    reply = sim.attach(AttachRequest(robot_id=robot_id, guid=component.guid))
    assert reply.ok, reply.reason
    idle(sim, 1.2)


def _beside_target(sim: Simulation, component: Component, robot_id: str = "r1") -> None:
    target = footprint(
        component, (component.target_pose_world.position_m, component.target_pose_world.quat_xyzw)
    )
    sim.teleport_robot(robot_id, west_of(target, 0.8))


def _place(
    sim: Simulation, component: Component, duration_s: float = 2.0, robot_id: str = "r1"
) -> PlaceRequest:
    target = component.target_pose_world
    return PlaceRequest(
        robot_id=robot_id,
        guid=component.guid,
        pose=pose(target.position_m, target.quat_xyzw),
        duration_s=duration_s,
    )


def _footing(manifest: Manifest) -> Component:
    return next(c for c in manifest.components if c.ifc_class == "IfcFooting")


def test_attach_out_of_reach_is_refused_with_the_distance(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    sim = make_sim(robots=1)
    footing = _footing(frame_manifest)
    reply = sim.attach(AttachRequest(robot_id="r1", guid=footing.guid))
    assert not reply.ok
    match = re.fullmatch(
        rf"robot r1 \(default\) is (\d+\.\d\d) m from {re.escape(footing.guid)}, reach is 1.5 m", reply.reason
    )
    assert match, reply.reason
    x, y, _ = sim.robot_pose("r1")
    expected = distance_to_rect((x, y), sim.layout.slots[footing.guid].footprint)
    assert float(match.group(1)) == pytest.approx(expected, abs=0.006)
    assert reply.distance_m == pytest.approx(expected, abs=1e-6)  # for the robot: is it where it believes?
    assert sim.handling.items[footing.guid].phase is Phase.RESTING


def test_attach_within_reach_is_accepted_and_other_requests_are_refused_with_reasons(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    sim = make_sim(robots=2)
    column = _first_in_row(sim, frame_manifest, "IfcColumn")
    beam = _first_in_row(sim, frame_manifest, "IfcBeam")
    sim.teleport_robot("r1", west_of(sim.layout.slots[column.guid].footprint, 0.8))
    accepted = sim.attach(AttachRequest(robot_id="r1", guid=column.guid))
    assert accepted.ok and accepted.pose is not None
    assert accepted.pose.position_m == pytest.approx(sim.layout.slots[column.guid].position_m)
    sim.teleport_robot("r2", west_of(sim.layout.slots[beam.guid].footprint, 0.8))
    refusals = {
        "unknown robot r9": AttachRequest(robot_id="r9", guid=column.guid),
        "unknown component nope": AttachRequest(robot_id="r1", guid="nope"),
        f"robot r1 already carries {column.guid}": AttachRequest(robot_id="r1", guid=beam.guid),
        f"{column.guid} is already carried by r1": AttachRequest(robot_id="r2", guid=column.guid),
    }
    for reason, request in refusals.items():
        reply = sim.attach(request)
        assert (reply.ok, reply.reason) == (False, reason)
    assert sim.attach(AttachRequest(robot_id="r2", guid=beam.guid)).ok


def test_the_carried_component_follows_the_robot(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    sim = make_sim(robots=1)
    column = _first_in_row(sim, frame_manifest, "IfcColumn")
    _picked(sim, column)
    results = drive(sim, "r1", 0.5, 0.3, 2.0)
    robot = sim.robots["r1"]
    item = sim.handling.items[column.guid]
    expected = compose(robot.frame(sim.client_id), item.offset)
    actual = component_pose(sim.client_id, item.body)
    assert np.allclose(actual[0], expected[0], atol=1e-6) and angle_between(actual[1], expected[1]) < 1e-6
    base_z = robot.frame(sim.client_id)[0][2]
    assert bottom_z(column, actual) > base_z + robot.top_height_m  # on top of the robot
    for result in results:  # published every period, as carried
        poses = [m.message for m in result.messages if isinstance(m.message, ComponentPoseMsg)]
        mine = [m for m in poses if m.guid == column.guid]
        assert mine and mine[0].attached_to == "r1" and not mine[0].fixed
        robot_pose = next(m.message for m in result.messages if isinstance(m.message, RobotPoseMsg))
        assert robot_pose.carrying == column.guid


def _joined(sim: Simulation, component: Component) -> None:
    """``component`` already built: at its target, joined to the structure (as a restarted physics puts a
    constructed one back)."""
    target = component.target_pose_world
    sim.handling.restore(component.guid, (target.position_m, target.quat_xyzw), fixed=True, carrier=None)
    sim.handling.note_constructed(component.guid, True)


def _named(manifest: Manifest, name: str) -> Component:
    return next(c for c in manifest.components if c.name == name)


def _placed_and_answered(
    sim: Simulation, component: Component, request: PlaceRequest | None = None, within_s: float | None = None
) -> tuple[PhysicsReply, list]:
    """Pick ``component``, stand beside its target, place it; the reply and the periods until it came
    (within 12 s plus the longest hold its connections and temporary supports may ask of the robot)."""
    if within_s is None:
        need = component.temporary_support
        within_s = 12.0 + max((link.time_s for link in component.connection_links), default=0.0)
        within_s += need.count * need.place_s if need is not None else 0.0
    _picked(sim, component)
    _beside_target(sim, component)
    assert sim.place(request or _place(sim, component, duration_s=1.0), tag="ticket") is None
    periods = []
    for _ in range(round(within_s / sim.config.control_period_s)):
        result = sim.advance()
        periods.append(result)
        if result.replies:
            (tag, reply), *_ = result.replies
            assert tag == "ticket"
            return reply, periods
    raise AssertionError(f"no reply to the placement of {component.name} within {within_s} s")


def test_a_placed_column_comes_to_rest_on_its_footing_and_joins_the_structure_where_it_rests(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    sim = make_sim(robots=1)  # the default robot: a perfect hand, no localisation error asked for
    column = _named(frame_manifest, "Column A1")
    footing = _named(frame_manifest, "Footing A1")
    _joined(sim, footing)
    reply, periods = _placed_and_answered(sim, column)
    assert reply.ok and len(periods) > round(1.0 / sim.config.control_period_s)  # motion, then settling
    message = next(m.message for m in periods[-1].messages if getattr(m.message, "guid", None) == column.guid)
    assert message.fixed and not message.joined and message.attached_to is None
    assert message.supports == [footing.guid]  # it rests on its footing
    assert message.drift_m is not None and message.drift_m < 0.003  # Bullet's contact: ~1 mm
    target = column.target_pose_world
    rest = component_pose(sim.client_id, sim.handling.items[column.guid].body)
    assert math.dist(rest[0], target.position_m) < 0.003 and angle_between(rest[1], target.quat_xyzw) < 1e-3
    assert sim.handling.items[column.guid].phase is Phase.PLACED
    sim.handling.note_constructed(column.guid, True)  # its agent verified it
    assert sim.handling.items[column.guid].phase is Phase.JOINED
    assert sim.handling.pose_message(column.guid, sim.sim_time_s).joined
    drive(sim, "r1", -0.5, 0.0, 2.0)  # the robot backs away; the joined column stays exactly
    after = component_pose(sim.client_id, sim.handling.items[column.guid].body)
    assert after[0] == pytest.approx(rest[0], abs=1e-9) and angle_between(after[1], rest[1]) < 1e-9
    assert (
        sim.attach(AttachRequest(robot_id="r1", guid=column.guid)).reason
        == f"{column.guid} is constructed (joined to the structure)"
    )


def test_a_beam_on_a_single_column_tips_off_and_says_how_far_it_moved_and_what_held_it(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest, caplog: pytest.LogCaptureFixture
) -> None:
    sim = make_sim(robots=1)
    for name in ("Footing A1", "Column A1"):  # Beam A1-A2 also needs Column A2, which is not there
        _joined(sim, _named(frame_manifest, name))
    beam = _named(frame_manifest, "Beam A1-A2")
    reply, _ = _placed_and_answered(sim, beam)
    assert reply.ok  # physics placed it; whether it holds is its agent's verdict
    message = sim.handling.pose_message(beam.guid, sim.sim_time_s)
    assert message.drift_m is not None and message.drift_m > 0.5  # its free end fell
    assert message.pose.position_m[2] < beam.target_pose_world.position_m[2] - 0.5
    assert f"{beam.guid} moved" in caplog.text and "unstable" in caplog.text


def test_a_column_placed_before_its_footing_drops_into_the_open_pit(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    sim = make_sim(robots=1)
    column, footing = _named(frame_manifest, "Column A1"), _named(frame_manifest, "Footing A1")
    depth = -footing.bbox_world.min_m[2]
    _placed_and_answered(sim, column)
    message = sim.handling.pose_message(column.guid, sim.sim_time_s)
    assert message.drift_m == pytest.approx(depth, abs=0.05)  # down to the pit's floor (it may lean)
    assert message.pose.position_m[2] < column.target_pose_world.position_m[2] - 0.2


def test_a_robot_that_believes_itself_elsewhere_places_off_by_its_error(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    """The placement is commanded from the robot's belief: localised 4 cm east of where it stands, it puts
    the footing 4 cm west of the target."""
    sim = make_sim(robots=1)
    footing = _named(frame_manifest, "Footing A1")
    _picked(sim, footing)
    _beside_target(sim, footing)
    x, y, yaw = sim.robot_pose("r1")
    request = _place(sim, footing, duration_s=0.5).model_copy(update={"believed_xy_yaw": (x + 0.04, y, yaw)})
    assert sim.place(request, tag="t") is None
    idle(sim, 4.0)
    rest = component_pose(sim.client_id, sim.handling.items[footing.guid].body)
    target = footing.target_pose_world.position_m
    assert rest[0][0] - target[0] == pytest.approx(-0.04, abs=0.003)
    assert rest[0][1] == pytest.approx(target[1], abs=0.003)


def test_a_placed_component_not_yet_constructed_can_be_taken_off_again_for_its_retry(
    make_sim, frame_manifest: Manifest
) -> None:
    sim = make_sim(robots=1)
    footing = _named(frame_manifest, "Footing A1")
    _placed_and_answered(sim, footing)
    assert sim.handling.items[footing.guid].phase is Phase.PLACED
    reply = sim.attach(AttachRequest(robot_id="r1", guid=footing.guid))  # misplaced: the robot retries
    assert reply.ok, reply.reason
    item = sim.handling.items[footing.guid]
    assert item.carrier == "r1" and item.phase is Phase.CARRIED and footing.guid not in sim.handling.watch
    assert p.getDynamicsInfo(item.body.body_id, -1, physicsClientId=sim.client_id)[0] == 0.0  # kinematic


def test_a_constructed_claim_for_a_placement_still_settling_joins_nothing_and_the_placement_is_answered(
    make_sim, frame_manifest: Manifest
) -> None:
    """A forged ``constructed`` on an open bus, heard while the footing settles, once joined it there and
    dropped its pending answer: the robot waited 1,200 s and the footing could never be retried."""
    sim = make_sim(robots=1)
    footing = _named(frame_manifest, "Footing A1")
    _picked(sim, footing)
    _beside_target(sim, footing)
    assert sim.place(_place(sim, footing, duration_s=1.0), tag="ticket") is None
    claimed = False
    for _ in range(120):
        result = sim.advance()
        if sim.handling.items[footing.guid].phase is Phase.SETTLING and not claimed:
            sim.handling.note_constructed(footing.guid, True)  # nobody can have verified it yet
            claimed = True
            assert sim.handling.items[footing.guid].phase is Phase.SETTLING
        if result.replies:
            assert [tag for tag, _ in result.replies] == ["ticket"] and result.replies[0][1].ok
            break
    else:
        raise AssertionError("the placement was never answered")
    assert claimed and sim.handling.items[footing.guid].phase is Phase.PLACED
    sim.handling.note_constructed(footing.guid, True)  # its agent's verdict, after the answer
    assert sim.handling.items[footing.guid].phase is Phase.JOINED


def test_a_joined_component_its_agent_then_calls_misplaced_is_released_and_can_be_retried(
    make_sim, frame_manifest: Manifest
) -> None:
    sim = make_sim(robots=1)
    footing = _named(frame_manifest, "Footing A1")
    _placed_and_answered(sim, footing)
    sim.handling.note_constructed(footing.guid, True)  # a forged claim, before the agent's verdict
    assert sim.handling.items[footing.guid].phase is Phase.JOINED
    sim.handling.note_constructed(footing.guid, False)  # the agent: misplaced (constructed would be final)
    item = sim.handling.items[footing.guid]
    assert item.phase is Phase.PLACED and sim.handling.watch[footing.guid].settled
    assert p.getDynamicsInfo(item.body.body_id, -1, physicsClientId=sim.client_id)[0] == pytest.approx(
        footing.mass_kg
    )
    reply = sim.attach(AttachRequest(robot_id="r1", guid=footing.guid))  # the retry takes it up again
    assert reply.ok, reply.reason


def test_place_refusals_name_the_problem(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    sim = make_sim(robots=2)
    column = _first_in_row(sim, frame_manifest, "IfcColumn")
    footing = _footing(frame_manifest)
    assert sim.place(_place(sim, footing)).reason == f"robot r1 does not carry {footing.guid}"
    _picked(sim, column)
    far = sim.place(_place(sim, column))
    assert not far.ok and re.fullmatch(
        rf"robot r1 \(default\) is \d+\.\d\d m from the target of {re.escape(column.guid)}, reach is 1.5 m",
        far.reason,
    )
    _beside_target(sim, column)
    assert sim.place(_place(sim, column, robot_id="r2")).reason == f"{column.guid} is carried by r1, not r2"
    # a zero quaternion or a negative duration no longer passes decode (message bounds), but physics still
    # refuses one handed to it in-process (model_construct and model_copy skip validation)
    zero_quat = PoseMsg.model_construct(position_m=(0.0, 0.0, 0.0), quat_xyzw=(0.0, 0.0, 0.0, 0.0))
    bad_quat = _place(sim, column).model_copy(update={"pose": zero_quat})
    assert sim.place(bad_quat).reason.startswith("invalid pose")
    negative = _place(sim, column).model_copy(update={"duration_s": -1.0})
    assert sim.place(negative).reason.startswith("duration_s must be within")
    outside = _place(sim, column).model_copy(update={"pose": pose((1e4, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))})
    assert "outside the site" in sim.place(outside).reason
    assert sim.place(_place(sim, column)) is None
    assert sim.place(_place(sim, column)).reason == f"{column.guid} is already being placed by r1"


def test_placed_footings_below_ground_are_not_pushed_up(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    sim = make_sim(robots=1)
    footing = _footing(frame_manifest)
    assert footing.bbox_world.min_m[2] < 0.0 and footing.bbox_world.max_m[2] == pytest.approx(0.0)
    _placed_and_answered(sim, footing)  # into its pit, onto the pit's floor
    body = sim.handling.items[footing.guid].body
    placed = component_pose(sim.client_id, body)
    assert placed[0] == pytest.approx(footing.target_pose_world.position_m, abs=0.003)
    sim.handling.note_constructed(footing.guid, True)
    x = sim.robot_pose("r1")[0]
    drive(sim, "r1", 0.6, 0.0, 3.0)  # drive right over it
    assert sim.robot_pose("r1")[0] > x + 1.0
    after = component_pose(sim.client_id, body)
    assert after[0] == pytest.approx(placed[0], abs=1e-9)
    assert p.getContactPoints(sim.ground_id, body.body_id, physicsClientId=sim.client_id) == ()


def test_a_lost_robot_puts_its_load_down_on_the_ground_beside_it(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    sim = make_sim(robots=2)
    sim.set_alive("r1", True)
    beam = _first_in_row(sim, frame_manifest, "IfcBeam")
    _picked(sim, beam)
    drive(sim, "r1", 0.0, 0.4, 1.0)
    messages = sim.set_alive("r1", False)
    assert [m.message.guid for m in messages] == [beam.guid]
    dropped = messages[0].message
    assert dropped.attached_to is None and not dropped.fixed
    item = sim.handling.items[beam.guid]
    assert item.phase is Phase.RESTING and "r1" not in sim.handling.carrying
    assert bottom_z(beam, item.pose) == pytest.approx(GROUND_CLEARANCE_M, abs=1e-9)  # lying on the ground
    x, y, _ = sim.robot_pose("r1")
    half_width = sim.robots["r1"].half_extents_xy_m[1]
    assert distance_to_footprint(beam, item.pose, (x, y)) > half_width + 0.2  # beside the robot, not under it
    results = idle(sim, 1.0)
    assert (
        next(m.message for m in results[-1].messages if isinstance(m.message, RobotPoseMsg)).carrying is None
    )
    assert component_pose(sim.client_id, item.body)[0] == pytest.approx(item.pose[0], abs=1e-9)
    sim.teleport_robot("r2", (x, y, 0.0))
    sim.teleport_robot("r1", (x - 5.0, y, 0.0))
    assert sim.attach(AttachRequest(robot_id="r2", guid=beam.guid)).ok  # the task can be redone


def test_a_robot_that_cannot_deliver_its_load_drops_it_on_request_and_another_robot_picks_it_up(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    sim = make_sim(robots=2)
    beam = _first_in_row(sim, frame_manifest, "IfcBeam")
    refused = sim.drop(DropRequest(robot_id="r1", guid=beam.guid))
    assert (refused.ok, refused.reason) == (
        False,
        f"robot r1 does not carry {beam.guid} (carried by no robot)",
    )
    _picked(sim, beam)
    drive(sim, "r1", 0.3, 0.0, 1.0)
    other = sim.drop(DropRequest(robot_id="r2", guid=beam.guid))
    assert (other.ok, other.reason) == (False, f"robot r2 does not carry {beam.guid} (carried by r1)")
    assert sim.drop(DropRequest(robot_id="r9", guid=beam.guid)).reason == "unknown robot r9"

    reply = sim.drop(DropRequest(robot_id="r1", guid=beam.guid))
    assert reply.ok and reply.pose is not None
    item = sim.handling.items[beam.guid]
    assert item.phase is Phase.RESTING and item.carrier is None and "r1" not in sim.handling.carrying
    assert reply.pose.position_m == pytest.approx(item.pose[0])
    assert bottom_z(beam, item.pose) == pytest.approx(GROUND_CLEARANCE_M, abs=1e-9)
    x, y, _ = sim.robot_pose("r1")
    assert distance_to_footprint(beam, item.pose, (x, y)) > sim.robots["r1"].half_extents_xy_m[1] + 0.2
    again = sim.drop(DropRequest(robot_id="r1", guid=beam.guid))  # a repeated delivery of the request
    assert again.ok and again.pose == reply.pose
    poses = [m.message for m in sim.advance().messages if isinstance(m.message, ComponentPoseMsg)]
    dropped = next(m for m in poses if m.guid == beam.guid)
    assert dropped.attached_to is None and not dropped.fixed, "the new pose goes out: resting, free to pick"
    sim.teleport_robot("r2", (x, y, 0.0))
    sim.teleport_robot("r1", (x - 5.0, y, 0.0))
    assert sim.attach(AttachRequest(robot_id="r2", guid=beam.guid)).ok


def test_a_load_being_placed_is_not_dropped(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    sim = make_sim(robots=1)
    footing = _footing(frame_manifest)
    _picked(sim, footing)
    _beside_target(sim, footing)
    assert sim.place(_place(sim, footing, duration_s=2.0), "tag") is None
    reply = sim.drop(DropRequest(robot_id="r1", guid=footing.guid))
    assert not reply.ok and reply.reason == f"{footing.guid} is being placed by r1: it cannot be dropped now"


def test_a_target_whose_frame_lies_off_site_but_whose_footprint_stands_on_it_is_placed(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    """Revit elements may keep an identity placement with world-coordinate geometry: the frame is far from
    the element. The site check follows the footprint, as the reach rule does."""
    sim = make_sim(robots=1)
    column = _first_in_row(sim, frame_manifest, "IfcColumn")
    _picked(sim, column)
    _beside_target(sim, column)
    offset = np.array([500.0, 0.0, 0.0])  # geometry 500 m east of the frame, frame 500 m west of the site
    box = column.bbox_local
    shifted = column.model_copy(
        update={
            "bbox_local": box.model_copy(
                update={"min_m": tuple(np.add(box.min_m, offset)), "max_m": tuple(np.add(box.max_m, offset))}
            )
        }
    )
    sim.handling.items[column.guid].component = shifted
    target = column.target_pose_world
    request = _place(sim, column).model_copy(
        update={"pose": pose(tuple(np.subtract(target.position_m, offset)), target.quat_xyzw)}
    )
    assert sim.place(request) is None  # accepted: the footprint is where the column stands


def test_falling_off_the_site_is_judged_by_the_centre_of_mass_not_the_frame_origin(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    """A Revit element with an identity placement has its frame at the model's origin, possibly off the
    site, while its geometry stands on it: the hub's steel had 11 columns "fall off the site" at release."""
    sim = make_sim(robots=1)
    footing = _named(frame_manifest, "Footing A1")
    _placed_and_answered(sim, footing)
    item = sim.handling.items[footing.guid]
    (x, y, z), quat = item.pose
    item.pose = ((x - 1000.0, y, z), quat)  # its frame far off the site, its body where it rests
    assert not sim.handling.watching.fell_off(item)
    p.resetBasePositionAndOrientation(item.body.body_id, [x, y, -50.0], quat, physicsClientId=sim.client_id)
    assert sim.handling.watching.fell_off(item)  # its centre of mass 50 m below the ground: stopped


def test_a_component_that_falls_off_the_site_is_stopped_and_reported_not_a_crash(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    """A released component that slid off a pit's floor would fall for ever and its pose leave the bounds
    every message keeps (physics once died of it on a large site): it is stopped, static, and its drift
    says it did not hold."""
    sim = make_sim(robots=0)
    column = _named(frame_manifest, "Column A1")
    sim.handling.set_down(column.guid, sim.sim_time_s, tag="t")
    body = sim.handling.items[column.guid].body
    p.resetBasePositionAndOrientation(
        body.body_id, (0.0, 0.0, -40.0), (0, 0, 0, 1), physicsClientId=sim.client_id
    )
    replies = [reply for result in idle(sim, 1.0) for reply in result.replies]
    assert [tag for tag, _ in replies] == ["t"]  # answered at once: it will not come to rest
    message = sim.handling.pose_message(column.guid, sim.sim_time_s)  # within the message bounds
    assert message.drift_m is not None and message.drift_m > 30.0
    assert p.getDynamicsInfo(body.body_id, -1, physicsClientId=sim.client_id)[0] == 0.0  # static


def test_a_footing_set_down_beside_its_open_pit_rests_on_the_ground_at_its_edge(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    """Released with its centre of mass beside its pit (a robot 0.35 m off), a footing rests on the ground
    overhanging the pit, as on a real site, instead of falling through the ground beside the pit's floor;
    centred over its pit it drops in."""
    sim = make_sim(robots=1)
    footing = _named(frame_manifest, "Footing A1")
    width = footing.bbox_world.max_m[0] - footing.bbox_world.min_m[0]
    _picked(sim, footing)
    _beside_target(sim, footing)
    x, y, yaw = sim.robot_pose("r1")
    off = width / 2.0 + 0.05  # centre of mass 5 cm beyond the pit's edge, away from the robot (east)
    request = _place(sim, footing, duration_s=0.5).model_copy(update={"believed_xy_yaw": (x - off, y, yaw)})
    assert sim.place(request, tag="t") is None
    idle(sim, 6.0)
    rest = component_pose(sim.client_id, sim.handling.items[footing.guid].body)
    target = footing.target_pose_world.position_m
    assert rest[0][0] - target[0] == pytest.approx(off, abs=0.05)
    depth = -footing.bbox_world.min_m[2]
    assert rest[0][2] == pytest.approx(target[2] + depth, abs=0.05), "on the ground, not in the pit"
    assert sim.handling.pose_message(footing.guid, sim.sim_time_s).open_pits == []


def test_a_footing_in_its_own_pit_names_no_open_pit(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    """Its own pit is where a foundation goes, not a pit "not placed yet": a Revit slab's unstable reason
    had listed itself among the open pits it came to rest in (and --check-stability would advise placing it
    before itself)."""
    sim = make_sim(robots=1)
    footing = _named(frame_manifest, "Footing A1")
    _picked(sim, footing)
    _beside_target(sim, footing)
    assert sim.place(_place(sim, footing, duration_s=0.5), tag="t") is None
    idle(sim, 6.0)
    assert footing.guid not in sim.handling.pose_message(footing.guid, sim.sim_time_s).open_pits


def test_a_component_lying_where_a_robot_dropped_it_is_no_clash_in_the_ifc(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    """A trial on the Revit house: a panel's unstable reason said "the model puts it into" a mullion 267 mm
    deep, "a clash in the IFC", while the two lie 1.8 m apart in the model: a robot had given the mullion's
    task back and put it down there. Only components placed where the model puts them make a clash."""
    sim = make_sim(robots=0)
    first, second = _named(frame_manifest, "Footing A1"), _named(frame_manifest, "Footing A2")
    item = sim.handling.items[first.guid]
    x, y, z = second.target_pose_world.position_m
    dropped = ((x + 0.3, y, z), second.target_pose_world.quat_xyzw)  # lying half in A2's target, resting
    item.pose = dropped
    set_component_pose(sim.client_id, item.body, dropped)
    p.performCollisionDetection(physicsClientId=sim.client_id)
    assert item.phase is Phase.RESTING
    sim.handling.set_down(second.guid, sim.sim_time_s)
    assert sim.handling.pose_message(second.guid, sim.sim_time_s).clash_depth_m == {}


def test_a_placed_component_that_falls_off_after_it_rested_is_stopped_too(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    """A placement at rest but not yet joined is still dynamic and may tip off later (a misplaced footing
    waiting for its retry did, and fell until physics died): stopped, static, within the message bounds."""
    sim = make_sim(robots=1)
    column = _named(frame_manifest, "Column A1")
    reply, _ = _placed_and_answered(sim, column)
    assert reply.ok
    body = sim.handling.items[column.guid].body
    p.resetBasePositionAndOrientation(
        body.body_id, (0.0, 0.0, -40.0), (0, 0, 0, 1), physicsClientId=sim.client_id
    )
    idle(sim, 1.0)
    message = sim.handling.pose_message(column.guid, sim.sim_time_s)
    assert message.pose.position_m[2] > -45.0 and message.drift_m is not None and message.drift_m > 30.0
    assert p.getDynamicsInfo(body.body_id, -1, physicsClientId=sim.client_id)[0] == 0.0  # static


def test_a_carrier_overlapping_what_it_released_does_not_push_it_but_a_robot_driving_into_it_is_named(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    """Carried kinematically, a load may end its placement inside its carrier's bounding box; released, the
    two must not collide until they are clear of each other. They did: the release filter gave the load
    the dynamic group, which the carrier's mask holds, and pybullet lets a pair collide when either mask
    admits the other's group. The hub's concrete columns were kicked 0.2–1.4 m by the carrier that had
    just set them down (2 cm of overlap), and some toppled on every attempt."""
    sim = make_sim(robots=1)
    column = _named(frame_manifest, "Column A1")
    _joined(sim, _named(frame_manifest, "Footing A1"))
    _picked(sim, column)
    target = footprint(column, (column.target_pose_world.position_m, column.target_pose_world.quat_xyzw))
    robot = sim.robots["r1"]
    sim.teleport_robot("r1", west_of(target, 0.8))
    front_x = max(
        p.getAABB(robot.body_id, link, physicsClientId=sim.client_id)[1][0]
        for link in range(-1, p.getNumJoints(robot.body_id, physicsClientId=sim.client_id))
    )
    overlap_m = 0.02  # the robot's front 2 cm inside the column's footprint, as a carrier at the hub stood
    sim.teleport_robot("r1", west_of(target, 0.8 - (target.min_xy[0] - front_x) - overlap_m))
    assert sim.place(_place(sim, column, duration_s=1.0), tag="ticket") is None
    replies = [
        reply for _ in range(round(12.0 / sim.config.control_period_s)) for reply in sim.advance().replies
    ]
    assert replies and replies[0][1].ok
    item = sim.handling.items[column.guid]
    assert item.separating_from is robot  # still inside its carrier's box: they pass through each other
    assert sim.handling.watch[column.guid].drift_m < 0.003  # not kicked over
    drive(sim, "r1", -0.5, 0.0, 3.0)  # the carrier backs out: clear, they collide again
    assert item.separating_from is None
    assert sim.handling.watch[column.guid].bumped_by is None  # passing through its releaser is no touch
    rest = component_pose(sim.client_id, item.body)
    drive(sim, "r1", 0.6, 0.0, 4.0)  # and driving into the column now moves it
    assert math.dist(component_pose(sim.client_id, item.body)[0], rest[0]) > 0.01
    # and physics says who did it, so its agent's verdict names the robot, not a column that cannot stand
    watch = sim.handling.watch[column.guid]
    assert (
        watch.bumped_by == "r1"
        and watch.bumped_at_s is not None
        and watch.bumped_at_s > replies[0][1].sim_time_s
    )
    message = sim.handling.pose_message(column.guid, sim.sim_time_s)
    assert message.bumped_by == "r1" and message.bumped_at_s == watch.bumped_at_s


def test_a_robot_that_a_released_component_fell_onto_is_not_named_as_its_cause(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    """A beam that tipped off its column lands on the carrier beside it: the carrier touched it, but only
    after it had moved, so its verdict must not blame the carrier (a hub run named the carrier for three
    channel beams that had fallen 2.75 m onto it)."""
    sim = make_sim(robots=1)
    column = _named(frame_manifest, "Column A1")
    _joined(sim, _named(frame_manifest, "Footing A1"))
    reply, _ = _placed_and_answered(sim, column)
    assert reply.ok
    drive(sim, "r1", -0.5, 0.0, 3.0)  # the carrier backs out, clear of the column
    item = sim.handling.items[column.guid]
    moved = component_pose(sim.client_id, item.body)
    fallen = ((moved[0][0], moved[0][1] + 1.0, moved[0][2]), moved[1])  # as if it had slid 1 m away
    set_component_pose(sim.client_id, item.body, fallen)
    idle(sim, 0.4)
    assert sim.handling.watch[column.guid].drift_m > 0.5
    target = footprint(column, component_pose(sim.client_id, item.body))
    sim.teleport_robot("r1", west_of(target, 0.8))
    drive(sim, "r1", 0.6, 0.0, 4.0)  # the robot now runs into it where it lies
    assert math.dist(component_pose(sim.client_id, item.body)[0], fallen[0]) > 0.01  # it was touched
    assert sim.handling.watch[column.guid].bumped_by is None
    assert sim.handling.pose_message(column.guid, sim.sim_time_s).bumped_by is None


def test_a_component_released_into_another_names_the_clash_in_its_pose(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    """A model that puts two components in one place (a clash in the IFC): physics pushes them apart and
    the pose message names the other and how deep, so the agent's reason can say it (the Revit hub's
    footing, 229 mm inside the strip footing, had been reported as merely unstable)."""
    sim = make_sim(robots=0)
    first, second = _named(frame_manifest, "Footing A1"), _named(frame_manifest, "Footing A2")  # 0.6 m wide
    x, y, z = first.target_pose_world.position_m
    into_first = second.target_pose_world.model_copy(update={"position_m": (x + 0.3, y, z)})
    sim.handling.items[second.guid].component = second.model_copy(update={"target_pose_world": into_first})
    sim.handling.set_down(first.guid, sim.sim_time_s)
    p.performCollisionDetection(physicsClientId=sim.client_id)  # its box where it is now, as a step leaves it
    sim.handling.set_down(second.guid, sim.sim_time_s)  # half its width into the first, still at its target
    clashes = sim.handling.pose_message(second.guid, sim.sim_time_s).clash_depth_m
    assert list(clashes) == [first.guid]
    assert clashes[first.guid] == pytest.approx(0.3, abs=0.01)
    assert sim.handling.pose_message(first.guid, sim.sim_time_s).clash_depth_m == {}


def test_a_beam_bolted_to_standing_columns_over_an_open_excavation_stands_and_is_not_propped(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    """The restaurant's handrails, bolted to standing walls, hang over the pit of a floor slab not yet cast
    under them: they are connected to what stands and stay. No crew props anything there, though: what
    would rest on the pit's foundation still falls in (a column placed before its footing, above)."""
    columns = [_named(frame_manifest, name) for name in ("Column A1", "Column A2")]
    bolts = [
        ConnectionLink(other_guid=c.guid, kind=ConnectionKind.PINNED_END, time_s=5.0, source="joint")
        for c in columns
    ]
    props = TemporarySupportNeed(kind=SupportKind.PROPS, count=2, place_s=1.0, when=SupportWhen.ALWAYS)
    beam = _named(frame_manifest, "Beam A1-A2").model_copy(
        update={"connection_links": bolts, "temporary_support": props}
    )
    manifest = frame_manifest.model_copy(
        update={"components": [beam if c.guid == beam.guid else c for c in frame_manifest.components]}
    )
    sim = make_sim(robots=1, manifest=manifest)
    for name in ("Footing A1", "Column A1", "Footing A2", "Column A2"):
        _joined(sim, _named(manifest, name))
    low, high = beam.bbox_world.min_m, beam.bbox_world.max_m
    x, y = (low[0] + high[0]) / 2, (low[1] + high[1]) / 2
    under = _named(manifest, "Footing B3")  # not placed: its excavation stands open
    pits = sim.handling.state.pits
    assert pits is not None
    pits.pits.append(Pit(under.guid, Rect((x - 1.0, y - 1.0), (x + 1.0, y + 1.0)), -1.0, -1))
    reply, _ = _placed_and_answered(sim, beam)
    assert reply.ok
    message = sim.handling.pose_message(beam.guid, sim.sim_time_s)
    assert message.open_pits == [under.guid]
    assert message.fixed and (message.drift_m or 0.0) < 0.003
    made = sim.handling.state.supports.kinds.get(beam.guid, {})
    assert made == {c.guid: ConnectionKind.PINNED_END for c in columns}, "bolted to both columns"
    assert beam.guid not in sim.handling.state.supports.standing, "no props over an open pit"


def test_a_foundation_at_its_target_goes_into_its_own_excavation_where_its_centre_is_over_none_of_it(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    """A ring of strip footings: its centre of mass is over none of its pit's parts. It was lifted onto the
    ground as if set down off its pit, as far above its target as it reaches below the ground."""
    sim = make_sim(robots=1)
    footing = _named(frame_manifest, "Footing A1")
    pits = sim.handling.state.pits
    assert pits is not None
    index = next(i for i, pit in enumerate(pits.pits) if pit.owner == footing.guid)
    low, high = pits.pits[index].footprint.min_xy, pits.pits[index].footprint.max_xy
    strip = Rect(low, (low[0] + 0.2 * (high[0] - low[0]), high[1]))  # one edge strip: not under its centre
    pits.pits[index] = dataclasses.replace(pits.pits[index], footprint=strip)
    _picked(sim, footing)
    _beside_target(sim, footing)
    assert sim.place(_place(sim, footing, duration_s=0.5), tag="t") is None
    idle(sim, 6.0)
    rest = component_pose(sim.client_id, sim.handling.items[footing.guid].body)
    assert math.dist(rest[0], footing.target_pose_world.position_m) < 0.005, rest[0]
