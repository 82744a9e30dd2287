"""Robots: the Husky's drive is read from its URDF, it drives ~v·t and turns ~w·t under cmd_vel within
its limits, and odometry is exact without noise and has the configured spread with it."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest
from physics_builders import drive, wrap

from bimbot.services.physics.client import p
from bimbot.services.physics.odometry import Odometry
from bimbot.services.physics.simulation import Simulation
from bimbot.shared.fleet import default_fleet
from bimbot.shared.messages import OdomMsg, RobotPoseMsg


def test_husky_wheels_radius_and_track_come_from_the_urdf(make_sim: Callable[..., Simulation]) -> None:
    robot = make_sim(robots=1).robots["r1"]
    assert [joint for joint, _ in robot.drive.left] == [2, 4]
    assert [joint for joint, _ in robot.drive.right] == [3, 5]
    assert robot.drive.wheel_radius_m == pytest.approx(0.17775, abs=1e-6)
    assert robot.drive.track_m == pytest.approx(2 * 0.2854, abs=1e-3)


def test_robots_start_at_the_depot_on_their_wheels(make_sim: Callable[..., Simulation]) -> None:
    sim = make_sim(robots=3)
    for robot_id, start in zip(sim.robot_ids, sim.layout.robot_starts, strict=True):
        assert sim.robot_pose(robot_id) == pytest.approx(start, abs=1e-6)
    drive(sim, "r1", 0.0, 0.0, 1.0)
    for robot_id, start in zip(sim.robot_ids, sim.layout.robot_starts, strict=True):
        assert sim.robot_pose(robot_id) == pytest.approx(start, abs=0.01)  # settled, not bounced away


def test_the_husky_drives_forward_v_times_t(make_sim: Callable[..., Simulation]) -> None:
    sim = make_sim(robots=1)
    x0, y0, yaw0 = sim.robot_pose("r1")
    drive(sim, "r1", 0.5, 0.0, 4.0)
    x, y, yaw = sim.robot_pose("r1")
    assert math.hypot(x - x0, y - y0) == pytest.approx(2.0, abs=0.1)
    assert abs(y - y0) < 0.05 and abs(wrap(yaw - yaw0)) < 0.03


@pytest.mark.parametrize(("v_mps", "w_radps"), [(0.0, 1.0), (0.0, -0.6), (0.5, 0.5)])
def test_the_husky_turns_w_times_t(make_sim: Callable[..., Simulation], v_mps: float, w_radps: float) -> None:
    sim = make_sim(robots=1)
    previous = sim.robot_pose("r1")[2]
    turned = 0.0
    for _ in drive(sim, "r1", v_mps, w_radps, 0.1) + drive(sim, "r1", v_mps, w_radps, 2.9):
        heading = sim.robot_pose("r1")[2]
        turned += wrap(heading - previous)
        previous = heading
    assert turned == pytest.approx(w_radps * 3.0, rel=0.1)


def test_commands_are_clamped_to_the_husky_limits(make_sim: Callable[..., Simulation]) -> None:
    sim = make_sim(robots=1)
    x0, y0, _ = sim.robot_pose("r1")
    drive(sim, "r1", 5.0, 0.0, 3.0)
    x, y, _ = sim.robot_pose("r1")
    assert math.hypot(x - x0, y - y0) < 1.0 * 3.0 + 0.05
    assert sim.robots["r1"].command == (1.0, 0.0)
    sim.robots["r1"].set_command(float("nan"), 1.0)
    assert sim.robots["r1"].command == (0.0, 0.0)


def test_odometry_is_the_true_pose_without_noise(make_sim: Callable[..., Simulation]) -> None:
    sim = make_sim(robots=1, odom_noise=0.0)
    results = drive(sim, "r1", 0.6, 0.4, 3.0)
    last = results[-1].messages
    odom = next(m.message for m in last if isinstance(m.message, OdomMsg))
    truth = next(m.message for m in last if isinstance(m.message, RobotPoseMsg))
    assert odom.pose_xy_yaw == pytest.approx(truth.pose_xy_yaw, abs=1e-9)
    assert odom.v_mps == pytest.approx(0.6, abs=0.1)
    assert odom.w_radps == pytest.approx(0.4, abs=0.15)


def test_odometry_noise_has_the_configured_spread_and_is_seeded() -> None:
    noise, step = 0.05, (0.08, 0.0, 0.0)
    odometry = Odometry((0.0, 0.0, 0.0), noise, np.random.default_rng([7, 0]))
    ratios = []
    for _ in range(4000):
        before = odometry.pose_xy_yaw
        reading = odometry.update((0.0, 0.0, 0.0), step, 0.1)
        ratios.append(
            math.hypot(reading.pose_xy_yaw[0] - before[0], reading.pose_xy_yaw[1] - before[1]) / 0.08
        )
    assert float(np.std(ratios)) == pytest.approx(noise, rel=0.1)
    assert float(np.mean(ratios)) == pytest.approx(1.0, abs=0.005)
    again = Odometry((0.0, 0.0, 0.0), noise, np.random.default_rng([7, 0]))
    other = Odometry((0.0, 0.0, 0.0), noise, np.random.default_rng([8, 0]))
    assert again.update((0, 0, 0), step, 0.1) == Odometry(
        (0.0, 0.0, 0.0), noise, np.random.default_rng([7, 0])
    ).update((0, 0, 0), step, 0.1)
    assert other.update((0, 0, 0), step, 0.1) != again.update((0, 0, 0), step, 0.1)
    still = Odometry((1.0, 2.0, 0.3), noise, np.random.default_rng(1))
    for _ in range(10):
        still.update((1.0, 2.0, 0.3), (1.0, 2.0, 0.3), 0.1)
    assert still.pose_xy_yaw == pytest.approx((1.0, 2.0, 0.3), abs=1e-12)  # standing still: no drift


def test_simulated_odometry_drifts_from_the_truth_with_noise(make_sim: Callable[..., Simulation]) -> None:
    sim = make_sim(robots=1, odom_noise=0.05, seed=3)
    last = drive(sim, "r1", 0.8, 0.2, 3.0)[-1].messages
    odom = next(m.message for m in last if isinstance(m.message, OdomMsg))
    truth = next(m.message for m in last if isinstance(m.message, RobotPoseMsg))
    error = math.hypot(odom.pose_xy_yaw[0] - truth.pose_xy_yaw[0], odom.pose_xy_yaw[1] - truth.pose_xy_yaw[1])
    assert 1e-4 < error < 0.5


def test_a_robot_told_to_stand_still_falls_asleep_and_a_command_wakes_it(
    make_sim: Callable[..., Simulation],
) -> None:
    """Bullet stops simulating a robot at rest (a sleeping body costs the step almost nothing); a command
    to drive wakes it, and it drives as an awake one does."""
    sim = make_sim(robots=1)
    drive(sim, "r1", 0.5, 0.0, 1.0)
    drive(sim, "r1", 0.0, 0.0, 4.0)  # stop, then rest for Bullet's deactivation time (2 s)
    x0, y0, _ = sim.robot_pose("r1")
    drive(sim, "r1", 0.0, 0.0, 2.0)
    assert sim.robot_pose("r1")[:2] == pytest.approx((x0, y0), abs=1e-9)  # asleep: not even a jitter
    drive(sim, "r1", 0.5, 0.0, 2.0)
    x, y, _ = sim.robot_pose("r1")
    assert math.hypot(x - x0, y - y0) == pytest.approx(1.0, abs=0.1)


@pytest.mark.parametrize("kind", ["husky", "carrier"])
def test_each_ground_type_drives_up_onto_a_floor_of_its_step_and_not_one_3_cm_higher(
    make_sim: Callable[..., Simulation], kind: str
) -> None:
    """The fleet's ``max_step_m`` is what the robot's wheels really climb: the site map lets it drive on a
    built floor that high, so physics must carry it over the edge (and stop it at a higher one)."""
    step_m = default_fleet().types[kind].max_step_m
    assert step_m > 0.0
    travelled = {}
    for height_m in (step_m, step_m + 0.03):
        sim = make_sim(fleet=default_fleet().with_robots(1, kind))
        robot_id = sim.robot_ids[0]
        x0, y0, yaw = sim.robot_pose(robot_id)
        cid = sim.client_id
        slab = p.createCollisionShape(p.GEOM_BOX, halfExtents=[1.0, 1.5, height_m / 2], physicsClientId=cid)
        ahead = (x0 + 2.5 * math.cos(yaw), y0 + 2.5 * math.sin(yaw), height_m / 2)
        p.createMultiBody(
            0,
            slab,
            basePosition=ahead,
            baseOrientation=p.getQuaternionFromEuler([0, 0, yaw]),
            physicsClientId=cid,
        )
        drive(sim, robot_id, 0.5, 0.0, 8.0)
        x, y, _ = sim.robot_pose(robot_id)
        travelled[height_m] = math.hypot(x - x0, y - y0)
    assert travelled[step_m] > 3.8, "over the floor (1.5-3.5 m ahead) and down its far edge"
    assert travelled[step_m + 0.03] < 2.0, "stopped at the higher edge"
