"""A robot asleep through its drive is woken alone when a part comes to rest across the rest of its way, at
the first step at which it can know of the part, and never for a part it had taken before it slept, one off
its way, or one behind it. Physics then waits for it from that step, and the clock in its sensors names the
wake, so the robot tells from its sensors alone that it woke (reckoned by steps: same seed, same wakes)."""

from __future__ import annotations

import numpy as np

from bimbot.services.physics.app import _woken_alone
from bimbot.services.physics.clock import LockStepBarrier
from bimbot.services.physics.crossed_drives import CrossedDrives, remaining_points_xy
from bimbot.services.physics.simulation import Outgoing
from bimbot.shared.messages import ClockMsg, OdomMsg, SensorsMsg
from bimbot.shared.plan_motion import trajectory
from bimbot.shared.step_gate import DELAY_STEPS, woken

RADIUS_M = 0.6


def _square(centre_x: float, centre_y: float, half_m: float = 0.2) -> np.ndarray:
    x, y = centre_x, centre_y
    return np.array(
        [
            [x - half_m, y - half_m],
            [x + half_m, y - half_m],
            [x + half_m, y + half_m],
            [x - half_m, y + half_m],
        ]
    )


def _drive_east(start_s: float = 0.0):
    """From (0, 0) to (20, 0) at 1 m/s, facing east: 20 s."""
    return trajectory([(0.0, 0.0), (20.0, 0.0)], 0.0, start_s, speed_mps=1.0, turn_radps=1.0)


def test_the_rest_of_a_drive_is_sampled_from_where_the_robot_is() -> None:
    motion = _drive_east()
    points = remaining_points_xy(motion, 5.0)
    assert np.allclose(points[0], (5.0, 0.0))
    assert np.allclose(points[-1], (20.0, 0.0))
    assert np.max(np.diff(points[:, 0])) <= 0.1 + 1e-9
    assert len(remaining_points_xy(motion, 25.0)) == 0


def test_a_part_set_down_ahead_wakes_the_driver_when_it_can_know_of_it() -> None:
    crossed = CrossedDrives()
    motions, radius = {"r1": _drive_east()}, {"r1": RADIUS_M}
    crossed.came_to_rest(12, "wall", [_square(15.0, 0.5)])  # ahead, within the robot's radius of its path
    asleep = {"r1": 10}  # it said at step 10 that it sleeps through its drive
    for step in range(12, 12 + DELAY_STEPS):  # not yet: it takes the part's pose only at step 14
        assert crossed.to_wake(step, 6.0, asleep, motions, radius) == []
    assert crossed.to_wake(12 + DELAY_STEPS, 6.0, asleep, motions, radius) == ["r1"]


def test_a_sleep_not_known_for_certain_is_tested_only_once_it_is() -> None:
    crossed = CrossedDrives()
    motions, radius = {"r1": _drive_east()}, {"r1": RADIUS_M}
    crossed.came_to_rest(9, "wall", [_square(15.0, 0.0)])  # came to rest just before the robot slept
    asleep = {"r1": 10}
    assert crossed.to_wake(11, 3.0, asleep, motions, radius) == []  # physics may not have heard the sleep
    assert crossed.to_wake(10 + DELAY_STEPS, 3.0, asleep, motions, radius) == ["r1"]


def test_parts_off_the_way_behind_or_taken_before_the_sleep_wake_nobody() -> None:
    crossed = CrossedDrives()
    motions, radius = {"r1": _drive_east()}, {"r1": RADIUS_M}
    crossed.came_to_rest(10 - DELAY_STEPS, "taken", [_square(15.0, 0.0)])  # the robot had it before sleeping
    crossed.came_to_rest(13, "aside", [_square(12.0, 3.0)])  # 2.8 m off its path: it drives past
    crossed.came_to_rest(14, "behind", [_square(2.0, 0.0)])  # where it was, not where it goes
    asleep = {"r1": 10}
    woken_at = [step for step in range(11, 40) if crossed.to_wake(step, 8.0, asleep, motions, radius)]
    assert woken_at == []


def test_each_part_is_tested_once_and_old_ones_are_let_go() -> None:
    crossed = CrossedDrives()
    motions, radius = {"r1": _drive_east(), "r2": _drive_east()}, {"r1": RADIUS_M, "r2": RADIUS_M}
    for step in range(1, 200):
        crossed.came_to_rest(step, f"p{step}", [_square(-50.0, -50.0)])  # far from every way
        assert crossed.to_wake(step, 1.0, {"r1": 0, "r2": 100}, motions, radius) == []
    assert len(crossed.rests) <= 2 * DELAY_STEPS + 1


def test_a_woken_driver_is_waited_for_and_told_by_its_own_clock() -> None:
    barrier = LockStepBarrier(timeout_s=10.0)
    barrier.record("r1", 10, sleeps=True, wakes_at_s=30.0)  # asleep through its drive
    barrier.record("r2", 10, sleeps=True, wakes_at_s=30.0)
    sleepers = barrier.sleepers
    assert sleepers.asleep_driving() == {"r1": 10, "r2": 10}
    barrier.wake_one("r1", 14)
    barrier.open(14, 0.0)
    assert barrier.missing(["r1", "r2"]) == ["r1"]  # r1 answers step 14, r2 sleeps on
    assert sleepers.sends_sensors("r1", 14) and not sleepers.sends_sensors("r2", 15)
    clock = ClockMsg(sim_time_s=6.0, step=14, real_time_factor=1.0, lock_step=True, last_wake_step=None)
    odom = OdomMsg(robot_id="r1", pose_xy_yaw=(6.0, 0.0, 0.0), v_mps=0.0, w_radps=0.0, sim_time_s=6.0)
    item = _woken_alone(Outgoing("k", SensorsMsg(robot_id="r1", clock=clock, odom=odom)), sleepers)
    assert isinstance(item.message, SensorsMsg)
    assert item.message.clock.last_wake_step == 14 and woken(10, item.message.clock.last_wake_step)
    other = SensorsMsg(robot_id="r2", clock=clock, odom=odom.model_copy(update={"robot_id": "r2"}))
    assert _woken_alone(Outgoing("k", other), sleepers).message is other  # r2's clock is the common one
