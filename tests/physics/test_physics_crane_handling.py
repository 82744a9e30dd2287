"""Payload and reach by each robot's own description: a ground robot refuses a component heavier than its
payload; a tower crane refuses inside its smallest hook radius, beyond its reach and beyond its load
chart; a crane lifts a load on its hook, places it at height with its joints following, drops it straight
down when lost, and a restarted physics gives it back its joints and its load."""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from pathlib import Path

import pytest
from physics_builders import bottom_z, idle, pose, west_of

from bimbot.services.physics.client import p
from bimbot.services.physics.crane import hook_position, load_top
from bimbot.services.physics.handling_state import Phase
from bimbot.services.physics.restore import restore_site
from bimbot.services.physics.scene import Frame, footprint
from bimbot.services.physics.simulation import Simulation
from bimbot.services.physics.snapshot import SnapshotRecorder, load_snapshot
from bimbot.shared.connection_hold import longest_hold_s
from bimbot.shared.fleet import Fleet, default_fleet
from bimbot.shared.manifest import Component, Manifest
from bimbot.shared.messages import AttachRequest, PlaceRequest
from bimbot.shared.yard_slot import GROUND_CLEARANCE_M


def _crane_fleet(chart: list[tuple[float, float]] | None = None) -> Fleet:
    """A Husky (r1) and a tower crane (r2), the crane with ``chart`` (radius m, payload kg) if given."""
    base = default_fleet()
    crane = base.types["tower_crane"].model_dump()
    if chart is not None:
        crane["crane"]["load_chart"] = [{"radius_m": r, "payload_kg": kg} for r, kg in chart]
        crane["payload_kg"], crane["reach_m"] = max(kg for _, kg in chart), chart[-1][0]
    return Fleet.model_validate(
        {
            "types": {"husky": base.types["husky"].model_dump(), "tower_crane": crane},
            "robots": [{"type": "husky", "count": 1}, {"type": "tower_crane", "count": 1}],
        }
    )


def _named(manifest: Manifest, name: str) -> Component:
    return next(c for c in manifest.components if c.name == name)


def _lay_at(sim: Simulation, component: Component, xy: tuple[float, float]) -> Frame:
    """Move ``component`` (resting, as it lies in the yard) so that its footprint is centred on ``xy``."""
    item = sim.handling.items[component.guid]
    spot = footprint(component, item.pose)
    centre = ((spot.min_xy[0] + spot.max_xy[0]) / 2.0, (spot.min_xy[1] + spot.max_xy[1]) / 2.0)
    (x, y, z), quat = item.pose
    frame: Frame = ((x + xy[0] - centre[0], y + xy[1] - centre[1], z), quat)
    sim.handling.restore(component.guid, frame, fixed=False, carrier=None)
    return frame


def _hook_tip(sim: Simulation) -> tuple[float, ...]:
    crane = sim.robots["r2"]
    assert crane.rig is not None
    state = p.getLinkState(crane.body_id, crane.rig.indices[2], physicsClientId=sim.client_id)
    return tuple(state[4])


def test_a_ground_robot_refuses_a_component_heavier_than_its_payload(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    sim = make_sim(fleet=_crane_fleet())
    footing = _named(frame_manifest, "Footing A1")  # 259 kg; a Husky carries 75
    sim.teleport_robot("r1", west_of(sim.layout.slots[footing.guid].footprint, 0.5))
    reply = sim.attach(AttachRequest(robot_id="r1", guid=footing.guid))
    assert not reply.ok and reply.distance_m is None
    assert reply.reason == f"Footing A1 ({footing.guid}, 259 kg) exceeds r1's payload (husky, 75 kg)"
    column = _named(frame_manifest, "Column A1")  # 45 kg: within its payload
    sim.teleport_robot("r1", west_of(sim.layout.slots[column.guid].footprint, 0.5))
    assert sim.attach(AttachRequest(robot_id="r1", guid=column.guid)).ok


def test_a_crane_refuses_inside_its_smallest_radius_beyond_its_reach_and_beyond_its_chart(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    sim = make_sim(fleet=_crane_fleet([(5.0, 300.0), (40.0, 50.0)]))
    x, y, yaw = sim.robot_pose("r2")
    heading = (math.cos(yaw), math.sin(yaw))
    footing, column = _named(frame_manifest, "Footing A1"), _named(frame_manifest, "Column A1")

    _lay_at(sim, column, (x + 1.2 * heading[0], y + 1.2 * heading[1]))
    inside = sim.attach(AttachRequest(robot_id="r2", guid=column.guid))
    assert not inside.ok and inside.distance_m is not None and inside.distance_m < 2.5
    assert re.fullmatch(
        rf"crane r2 \(tower_crane\) is \d\.\d\d m from {column.guid}, "
        r"inside its smallest hook radius of 2.5 m",
        inside.reason,
    )

    _lay_at(sim, column, (x + 45.0 * heading[0], y + 45.0 * heading[1]))
    beyond = sim.attach(AttachRequest(robot_id="r2", guid=column.guid))
    assert not beyond.ok and beyond.distance_m is not None and 40.0 < beyond.distance_m < 45.0
    assert beyond.reason.startswith("crane r2 (tower_crane) is ") and beyond.reason.endswith("reach is 40 m")

    _lay_at(sim, footing, (x + 20.0 * heading[0], y + 20.0 * heading[1]))  # the chart: ~190 kg at 20 m
    heavy = sim.attach(AttachRequest(robot_id="r2", guid=footing.guid))
    assert not heavy.ok and heavy.distance_m is None
    assert re.fullmatch(
        rf"Footing A1 \({footing.guid}, 259 kg\) exceeds r2's load chart at 20\.\d\d m "
        r"\(tower_crane, 19\d kg there; it lifts 259 kg out to 10\.7\d m\)",
        heavy.reason,
    )
    _lay_at(sim, footing, (x + 8.0 * heading[0], y + 8.0 * heading[1]))  # 259 kg out to 10.74 m
    assert sim.attach(AttachRequest(robot_id="r2", guid=footing.guid)).ok


def test_a_crane_lifts_a_beam_on_its_hook_and_places_it_at_height(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    sim = make_sim(fleet=_crane_fleet())
    crane = sim.robots["r2"]
    assert crane.rig is not None
    beam = _named(frame_manifest, "Beam A1-B1")  # its target: 3.16–3.32 m up, on the columns A1 and B1
    below = ("Footing A1", "Footing B1", "Footing A2", "Footing B2", "Column A1", "Column B1", "Column A2")
    for name in (*below, "Column B2", "Beam A1-A2", "Beam B1-B2"):  # built already
        built = _named(frame_manifest, name).target_pose_world
        sim.handling.restore(
            _named(frame_manifest, name).guid, (built.position_m, built.quat_xyzw), fixed=True, carrier=None
        )
        sim.handling.note_constructed(_named(frame_manifest, name).guid, True)
    lying = sim.handling.items[beam.guid].pose

    assert sim.attach(AttachRequest(robot_id="r2", guid=beam.guid)).ok
    idle(sim, 1.5)
    item = sim.handling.items[beam.guid]
    assert item.phase is Phase.CARRIED and item.pose[0] == pytest.approx(
        (lying[0][0], lying[0][1], lying[0][2] + 1.0), abs=1e-9
    )  # on the hook, 1 m straight up from where it lay
    bbox = beam.bbox_local
    above = load_top(bbox.min_m, bbox.max_m, *item.pose)
    joints = crane.rig.joints
    assert hook_position(crane.start_xy_yaw, joints, crane.rig.jib_height_m) == pytest.approx(above, abs=1e-6)
    assert _hook_tip(sim) == pytest.approx(above, abs=1e-3)  # the URDF's hook is where the kinematics says
    published = sim.poses().robots["r2"]
    assert published.carrying == beam.guid and published.joint_positions == joints.by_name()

    target = beam.target_pose_world
    request = PlaceRequest(
        robot_id="r2", guid=beam.guid, pose=pose(target.position_m, target.quat_xyzw), duration_s=3.0
    )
    assert sim.place(request, "beam") is None
    halfway = idle(sim, 1.5)
    assert not any(reply for result in halfway for reply in result.replies)
    assert sim.handling.items[beam.guid].phase is Phase.ASSEMBLING
    assert crane.rig.joints != joints  # the hook follows the load
    set_down = idle(sim, 1.7)  # the motion ends: released onto the columns
    assert not any(result.replies for result in set_down)  # answered once it rests
    assert crane.rig.joints.hoist_m == pytest.approx(crane.rig.jib_height_m - 3.32, abs=0.01)
    assert _hook_tip(sim)[2] == pytest.approx(3.32, abs=0.01)  # the hook where it set the beam down
    held_s = longest_hold_s(beam, 0.0)  # the crane holds it while its ends are bolted
    replies = [reply for result in idle(sim, 3.0 + held_s) for reply in result.replies]
    assert [(tag, reply.ok) for tag, reply in replies] == [("beam", True)]
    placed = sim.handling.items[beam.guid]
    precision_m = crane.description.placement_precision_m  # 1σ per axis: the crane's hand is not perfect
    assert (
        placed.phase is Phase.PLACED
        and math.dist(placed.pose[0][:2], target.position_m[:2]) < 4 * precision_m
    )
    assert placed.pose[0][2] == pytest.approx(target.position_m[2], abs=0.003)
    top = load_top(bbox.min_m, bbox.max_m, *placed.pose)
    assert top[2] == pytest.approx(3.32, abs=0.01)
    assert set(sim.handling.watch[beam.guid].supports) == {
        _named(frame_manifest, name).guid for name in ("Beam A1-A2", "Beam B1-B2")
    }
    assert "r2" not in sim.handling.carrying


def test_a_lost_crane_lets_its_load_down_below_the_hook(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    sim = make_sim(fleet=_crane_fleet())
    beam = _named(frame_manifest, "Beam A1-A2")
    lying = sim.handling.items[beam.guid].pose
    assert sim.attach(AttachRequest(robot_id="r2", guid=beam.guid)).ok
    idle(sim, 1.5)
    sim.set_alive("r2", True)
    sim.set_alive("r2", False)
    item = sim.handling.items[beam.guid]
    assert item.phase is Phase.RESTING and item.carrier is None
    assert item.pose[0] == pytest.approx(lying[0], abs=1e-6)  # where it lay: straight below the hook
    assert bottom_z(beam, item.pose) == pytest.approx(GROUND_CLEARANCE_M, abs=1e-6)


def test_a_restarted_physics_gives_a_crane_back_its_joints_and_its_load(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest, tmp_path: Path
) -> None:
    first = make_sim(fleet=default_fleet())  # r1 husky, r2 carrier, r3 tower crane
    recorder = SnapshotRecorder(tmp_path, first.epoch)
    beam = _named(frame_manifest, "Beam B1-B2")
    recorder.record(item.message for item in first.start_messages())
    assert first.attach(AttachRequest(robot_id="r3", guid=beam.guid)).ok
    for result in idle(first, 1.5):
        recorder.record(item.message for item in result.messages)
        recorder.write()
    recorder.close()
    rig = first.robots["r3"].rig
    assert rig is not None
    joints = rig.joints.by_name()
    hanging = first.component_frame(beam.guid)
    poses = {robot_id: first.robot_pose(robot_id) for robot_id in first.robot_ids}

    snapshot = load_snapshot(tmp_path)
    assert snapshot is not None and snapshot.robots["r3"].pose.joint_positions == pytest.approx(joints)
    second = make_sim(fleet=default_fleet())
    restored_rig = second.robots["r3"].rig
    assert restored_rig is not None and restored_rig.joints.by_name() != pytest.approx(joints)
    restore_site(second, snapshot, [])
    assert restored_rig.joints.by_name() == pytest.approx(joints)
    for robot_id, where in poses.items():  # by id, the crane where it stands
        assert second.robot_pose(robot_id) == pytest.approx(where, abs=0.02)
    assert second.handling.carrying == {"r3": beam.guid}
    idle(second, 0.5)
    assert second.component_frame(beam.guid)[0] == pytest.approx(hanging[0], abs=1e-6)  # still on the hook


def test_a_hand_off_puts_the_load_down_on_the_side_nearest_its_staging_spot(frame_manifest: Manifest) -> None:
    from bimbot.services.physics.load_rules import drop_beside
    from bimbot.shared.site_plan import Rect

    beam = _named(frame_manifest, "Beam A1-A2")
    robot: Frame = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))  # facing +x
    site = Rect((-50.0, -50.0), (50.0, 50.0))
    centres = {}
    for near in ((0.0, 10.0), (0.0, -10.0), (-10.0, 0.0), (10.0, 0.0)):
        frame = drop_beside(beam, robot, (0.5, 0.35), [], site, near_xy_m=near)
        spot = footprint(beam, frame)
        centres[near] = ((spot.min_xy[0] + spot.max_xy[0]) / 2.0, (spot.min_xy[1] + spot.max_xy[1]) / 2.0)
    assert centres[(0.0, 10.0)][1] > 0.5 and centres[(0.0, -10.0)][1] < -0.5  # left, right
    assert centres[(-10.0, 0.0)][0] < -0.5 and centres[(10.0, 0.0)][0] > 0.5  # behind, ahead
