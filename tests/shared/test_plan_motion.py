"""The plan fidelity's timed motion: turn onto each leg at the turn limit, drive it at the speed limit."""

from __future__ import annotations

import math

import pytest

from bimbot.shared.plan_motion import standing, trajectory


def test_a_leg_takes_its_turn_then_its_length_at_the_limits() -> None:
    motion = trajectory([(0.0, 0.0), (0.0, 2.0)], 0.0, 10.0, speed_mps=1.0, turn_radps=0.5)
    turn_s = (math.pi / 2) / 0.5
    assert motion.end_s == pytest.approx(10.0 + turn_s + 2.0)
    assert motion.pose_at(10.0 + turn_s / 2) == pytest.approx((0.0, 0.0, math.pi / 4))
    assert motion.pose_at(10.0 + turn_s + 1.0) == pytest.approx((0.0, 1.0, math.pi / 2))
    assert motion.pose_at(1e6) == pytest.approx((0.0, 2.0, math.pi / 2))
    assert motion.distance_at(10.0 + turn_s + 0.5) == pytest.approx(0.5)
    assert motion.length_m == pytest.approx(2.0)


def test_turns_go_the_short_way_across_pi() -> None:
    motion = trajectory([(0.0, 0.0), (-1.0, -0.01)], math.radians(170), 0.0, speed_mps=1.0, turn_radps=1.0)
    assert motion.times_s[1] < math.radians(25)  # about 19°, not 341°


def test_a_path_of_its_start_alone_is_standing_still() -> None:
    motion = trajectory([(1.0, 2.0), (1.0, 2.0)], 0.3, 5.0, speed_mps=1.0, turn_radps=1.0)
    assert motion.end_s == 5.0
    assert motion.pose_at(9.0) == pytest.approx(standing((1.0, 2.0, 0.3), 5.0).pose_at(9.0))
