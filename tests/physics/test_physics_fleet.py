"""Physics spawns the fleet: each robot from its own type's URDF where the site plan puts it; the carrier
drives like the Husky under the same drive model; the tower crane stands still, publishes no scan and its
joints; the concrete pump and the block layer stand on a fixed base and never drive; the site info names
every robot's type; ``--robots N`` keeps the machines that stand fixed."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest
from physics_builders import drive, wrap

from bimbot.services.physics.client import p
from bimbot.services.physics.robots import wheel_torque_nm
from bimbot.services.physics.simulation import Simulation
from bimbot.shared.fleet import default_fleet
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import CmdVelMsg, OdomMsg, RobotPoseMsg, ScanMsg


def _tracking(
    sim: Simulation, robot_id: str, v_mps: float, w_radps: float, seconds: float
) -> dict[str, float]:
    """Per control period: the true speed and yaw rate while commanding ``(v, w)``; their means and RMS
    errors after the first second (spin-up), and the heading turned over the whole time."""
    period = sim.config.control_period_s
    speeds, rates, turned = [], [], 0.0
    previous = sim.robot_pose(robot_id)
    for _ in range(round(seconds / period)):
        drive(sim, robot_id, v_mps, w_radps, period)
        current = sim.robot_pose(robot_id)
        dx, dy = current[0] - previous[0], current[1] - previous[1]
        speeds.append((dx * math.cos(previous[2]) + dy * math.sin(previous[2])) / period)
        rates.append(wrap(current[2] - previous[2]) / period)
        turned += wrap(current[2] - previous[2])
        previous = current
    skip = round(1.0 / period)
    v, w = np.array(speeds[skip:]), np.array(rates[skip:])
    return {
        "mean_v": float(v.mean()),
        "mean_w": float(w.mean()),
        "rms_v": float(np.sqrt(np.mean((v - v_mps) ** 2))),
        "rms_w": float(np.sqrt(np.mean((w - w_radps) ** 2))),
        "turned": turned,
    }


def test_the_carrier_urdf_has_four_wheels_and_the_huskys_torque_per_kilogram(
    make_sim: Callable[..., Simulation],
) -> None:
    sim = make_sim(fleet=default_fleet().with_robots(1, "carrier"))
    carrier = sim.robots["r1"]
    assert carrier.description.name == "carrier" and carrier.drive is not None
    assert len(carrier.drive.left) == len(carrier.drive.right) == 2
    assert carrier.drive.wheel_radius_m == pytest.approx(0.22, abs=1e-6)
    assert carrier.drive.track_m == pytest.approx(0.75, abs=1e-3)
    assert carrier.half_extents_xy_m == pytest.approx((0.7, 0.45), abs=2e-3)  # its 1.4 m x 0.9 m footprint
    assert wheel_torque_nm(60.0, 50.003, 0.17775, 4) == pytest.approx(60.0)  # the Husky's is the reference
    assert 800.0 < carrier.wheel_torque_nm < 1000.0  # ~600 kg on 0.22 m wheels
    assert sim.robot_pose("r1") == pytest.approx(sim.layout.robot_starts[0], abs=1e-6)
    drive(sim, "r1", 0.0, 0.0, 1.0)
    assert sim.robot_pose("r1") == pytest.approx(sim.layout.robot_starts[0], abs=0.01)  # settled, not bounced


@pytest.mark.parametrize("type_name", ["husky", "carrier"])
@pytest.mark.parametrize(("v_mps", "w_radps"), [("top", 0.0), (0.0, 1.0), (0.8, 1.0)])
def test_carrier_and_husky_track_commanded_speed_and_turn_rate_alike(
    make_sim: Callable[..., Simulation], type_name: str, v_mps: float | str, w_radps: float
) -> None:
    """The same bounds hold for both. Measured (8 s, per-period RMS error): carrier 0.8 m/s straight 0.000;
    spinning at 1 rad/s mean 0.99 rad/s, RMS 0.13 rad/s, w·t within 0.1 %; 0.8 m/s with 1 rad/s RMS 0.26
    rad/s — the Husky 0.14 and 0.27 rad/s."""
    sim = make_sim(fleet=default_fleet().with_robots(1, type_name))
    speed = sim.robots["r1"].description.max_speed_mps if v_mps == "top" else float(v_mps)
    seconds = 5.0 if w_radps == 0.0 else 8.0  # straight along the site's main street, well short of the fence
    measured = _tracking(sim, "r1", speed, w_radps, seconds)
    assert measured["mean_v"] == pytest.approx(speed, abs=0.03)
    assert measured["rms_v"] < 0.1
    assert measured["mean_w"] == pytest.approx(w_radps, abs=0.05)
    assert measured["rms_w"] < 0.35
    assert measured["turned"] == pytest.approx(w_radps * seconds, abs=0.04 * w_radps * seconds + 0.01)


def test_each_robot_spawns_from_its_type_and_the_site_info_names_the_types(
    make_sim: Callable[..., Simulation],
) -> None:
    fleet = default_fleet()  # a Husky, a carrier, a tower crane, two pumps, a block layer, a piling rig
    sim = make_sim(fleet=fleet)
    info = sim.info()
    names = ("husky", "carrier", "tower_crane", "concrete_pump", "block_layer", "line_pump", "piling_rig")
    assert info.robot_ids == ["r1", "r2", "r3", "r4", "r5", "r6", "r7"]
    assert info.robot_type_of == dict(zip(info.robot_ids, names, strict=True))
    assert info.robot_types == {name: fleet.types[name] for name in names}
    assert list(info.robot_starts_xy_yaw) == [pytest.approx(start) for start in sim.layout.robot_starts]
    assert len(sim.layout.staging) == 1  # the crane's staging area
    husky, carrier, crane, pump, layer, line, rig = (sim.robots[robot_id] for robot_id in info.robot_ids)
    assert husky.half_extents_xy_m[0] < 0.6 < carrier.half_extents_xy_m[0]  # different bodies
    assert crane.drive is None and crane.rig is not None
    assert crane.top_height_m == pytest.approx(38.5, abs=1e-3)  # the mast collides; jib and hook do not
    assert crane.rig.jib_height_m == pytest.approx(40.0, abs=1e-3)
    for machine, length_m in ((pump, 10.0), (layer, 12.5), (line, 6.0), (rig, 8.5)):  # no wheels, no hook
        assert machine.drive is None and machine.rig is None and not machine.drives
        assert machine.half_extents_xy_m[0] == pytest.approx(length_m / 2.0, abs=2e-3)
        assert machine.base_height_m == pytest.approx(0.0, abs=2e-3)  # on the ground, not sunk or floating


def test_the_pump_and_the_block_layer_never_drive_and_have_no_laser(
    make_sim: Callable[..., Simulation],
) -> None:
    sim = make_sim(fleet=default_fleet())
    machines = ("r4", "r5", "r6")
    starts = {robot_id: sim.layout.robot_starts[index] for index, robot_id in enumerate(machines, 3)}
    for robot_id in starts:
        sim.command(CmdVelMsg(robot_id=robot_id, v_mps=1.0, w_radps=1.0, sim_time_s=0.0))
        assert sim.robots[robot_id].command == (0.0, 0.0)  # its limits are 0: taken, does nothing
    for result in [sim.advance() for _ in range(10)]:
        kinds: dict[str, set[type]] = {}
        for item in result.messages:
            robot_id = getattr(item.message, "robot_id", None)
            if robot_id in starts:
                kinds.setdefault(robot_id, set()).add(type(item.message))
        assert kinds == {robot_id: {OdomMsg, RobotPoseMsg} for robot_id in starts}  # no scan
    for robot_id, start in starts.items():
        assert sim.robot_pose(robot_id) == pytest.approx(start, abs=1e-9)
        assert sim.poses().robots[robot_id].joint_positions == {}


def test_a_laser_sees_each_machine_at_the_edge_of_its_set_up_rectangle(
    make_sim: Callable[..., Simulation],
) -> None:
    """The robots' map holds each machine's set-up rectangle (``SiteLayout.machines``); its URDF fills it
    up to ``MACHINE_BOX_HEIGHT_M``, so a laser at 6 cm hits its edges, and the compiled caster can
    represent every machine's shapes (no fallback to Bullet's slower casting)."""
    sim = make_sim(fleet=default_fleet())
    drive(sim, "r1", 0.0, 0.0, 0.2)  # one period: the scans are cast
    assert sim._ray_scene is not None and sim._ray_scene.unsupported is None
    for rect in sim.layout.machines:
        (x0, y0), (x1, y1) = rect.min_xy, rect.max_xy
        cx, cy = (x0 + x1) / 2.0, (y0 + y1) / 2.0
        for (sx, sy), edge in (((x0 - 1.0, cy), (x0, cy)), ((cx, y1 + 1.0), (cx, y1))):
            hit = p.rayTest((sx, sy, 0.06), (cx, cy, 0.06), physicsClientId=sim.client_id)[0]
            assert hit[0] >= 0, rect
            assert hit[3][:2] == pytest.approx(edge, abs=0.02), rect


def test_robots_n_keeps_the_crane_the_pump_and_the_block_layer(make_sim: Callable[..., Simulation]) -> None:
    sim = make_sim(fleet=default_fleet().with_robots(3))
    info = sim.info()
    assert info.robot_type_of == {
        "r1": "carrier", "r2": "carrier", "r3": "carrier",
        "r4": "tower_crane", "r5": "concrete_pump", "r6": "block_layer", "r7": "line_pump",
        "r8": "piling_rig",
    }  # fmt: skip
    depot = sim.layout.depot
    for robot_id in ("r1", "r2", "r3"):
        x, y, _ = sim.robot_pose(robot_id)
        assert depot.min_xy[0] <= x <= depot.max_xy[0] and depot.min_xy[1] <= y <= depot.max_xy[1]
    assert sim.robots["r4"].rig is not None and len(sim.layout.machines) == 5


def test_the_crane_stands_still_has_no_scan_and_publishes_its_joints(
    make_sim: Callable[..., Simulation],
) -> None:
    sim = make_sim(fleet=default_fleet(), odom_noise=0.05)
    start = sim.layout.robot_starts[2]
    sim.command(CmdVelMsg(robot_id="r3", v_mps=1.0, w_radps=1.0, sim_time_s=0.0))  # taken, does nothing
    assert sim.robots["r3"].command == (0.0, 0.0)
    for result in [sim.advance() for _ in range(10)]:
        by_robot: dict[str, list[object]] = {}
        for item in result.messages:
            robot_id = getattr(item.message, "robot_id", None)
            if robot_id is not None:
                by_robot.setdefault(robot_id, []).append(item.message)
        assert {type(m) for m in by_robot["r1"]} == {OdomMsg, ScanMsg, RobotPoseMsg}
        assert {type(m) for m in by_robot["r3"]} == {OdomMsg, RobotPoseMsg}  # no laser on a crane
        odom = next(m for m in by_robot["r3"] if isinstance(m, OdomMsg))
        pose = next(m for m in by_robot["r3"] if isinstance(m, RobotPoseMsg))
        assert odom.pose_xy_yaw == pose.pose_xy_yaw == pytest.approx(start)  # exact: no noise
        assert pose.joint_positions == {"slew": 0.0, "trolley": 2.5, "hoist": 0.0}
        ground = next(m for m in by_robot["r1"] if isinstance(m, RobotPoseMsg))
        assert ground.joint_positions == {}
    assert sim.robot_pose("r3") == pytest.approx(start, abs=1e-9)
    assert sim.poses().robots["r3"].joint_positions == {"slew": 0.0, "trolley": 2.5, "hoist": 0.0}


def test_without_a_fleet_the_site_holds_default_robots(make_sim: Callable[..., Simulation]) -> None:
    info = make_sim(robots=2).info()
    assert info.robot_type_of == {"r1": "default", "r2": "default"}
    assert list(info.robot_types) == ["default"]


def test_a_tall_buildings_crane_is_loaded_and_served_as_erected_for_it(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    """A part whose top is at 46.5 m: physics erects the tower crane at 51 m under hook (the pure rule is
    tests/shared/test_crane_erection.py), loads its URDF with the mast that much taller, so the hook it
    draws and moves loads from hangs where the description says, and serves that description."""
    low = make_sim(fleet=default_fleet())
    assert low.robots["r3"].rig is not None
    assert low.robots["r3"].rig.jib_height_m == pytest.approx(40.0, abs=0.01)
    beam = frame_manifest.components[-1]
    box = beam.bbox_world.model_copy(update={"max_m": (*beam.bbox_world.max_m[:2], 46.5)})
    tall = frame_manifest.model_copy(
        update={"components": [*frame_manifest.components[:-1], beam.model_copy(update={"bbox_world": box})]}
    )
    sim = make_sim(manifest=tall, fleet=default_fleet())
    rig = sim.robots["r3"].rig
    assert rig is not None and rig.jib_height_m == pytest.approx(51.0, abs=0.01)
    served = sim.info().robot_types["tower_crane"]
    assert served.crane is not None and served.crane.jib_height_m == 51.0
    assert served.max_place_height_m == 47.0
