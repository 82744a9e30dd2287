"""DWA local planner: reaches goals, avoids obstacles, obeys limits, falls back to a flagged recovery."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pytest

from bimbot.services.robot.dwa import DwaConfig, DwaResult, RobotState, dwa_step, dynamic_window, rollout

CONFIG = DwaConfig()


@dataclass
class Drive:
    """Outcome of driving a simulated unicycle with DWA commands."""

    reached_at_step: int | None
    states: list[RobotState]
    results: list[DwaResult] = field(default_factory=list)


def drive(
    start: RobotState,
    goal: tuple[float, float],
    obstacles_xy_m: np.ndarray,
    *,
    max_steps: int = 300,
    tolerance_m: float = 0.15,
    path_xy_m: np.ndarray | None = None,
) -> Drive:
    """Integrate each commanded (v, w) over one control period, as the real base would execute it."""
    state, dt = start, CONFIG.control_period_s
    out = Drive(None, [state])
    for step in range(max_steps):
        result = dwa_step(state, goal, obstacles_xy_m, CONFIG, path_xy_m=path_xy_m)
        yaw_mid = state.yaw_rad + 0.5 * result.w_radps * dt
        state = RobotState(
            state.x_m + result.v_mps * dt * math.cos(yaw_mid),
            state.y_m + result.v_mps * dt * math.sin(yaw_mid),
            state.yaw_rad + result.w_radps * dt,
            result.v_mps,
            result.w_radps,
        )
        out.states.append(state)
        out.results.append(result)
        if math.hypot(goal[0] - state.x_m, goal[1] - state.y_m) < tolerance_m:
            out.reached_at_step = step
            break
    return out


def circle_points(centre: tuple[float, float], radius_m: float, n: int = 60) -> np.ndarray:
    angles = np.linspace(0, 2 * math.pi, n, endpoint=False)
    return np.column_stack([centre[0] + radius_m * np.cos(angles), centre[1] + radius_m * np.sin(angles)])


def test_drives_to_goal_in_open_space() -> None:
    run = drive(RobotState(0.0, 0.0, 0.0), (6.0, 3.0), np.empty((0, 2)))
    assert run.reached_at_step is not None and run.reached_at_step < 150
    assert not any(r.recovery for r in run.results)


def test_turns_around_to_reach_a_goal_behind() -> None:
    run = drive(RobotState(0.0, 0.0, 0.0), (-3.0, 0.5), np.empty((0, 2)))
    assert run.reached_at_step is not None and run.reached_at_step < 150


def test_avoids_obstacle_on_the_straight_line_and_still_reaches_goal() -> None:
    obstacle = circle_points((3.0, 0.0), 0.4)
    run = drive(RobotState(0.0, 0.0, 0.0), (6.0, 0.0), obstacle)
    assert run.reached_at_step is not None
    xy = np.array([(s.x_m, s.y_m) for s in run.states])
    min_distance = np.hypot(
        xy[:, None, 0] - obstacle[None, :, 0], xy[:, None, 1] - obstacle[None, :, 1]
    ).min()
    assert min_distance > CONFIG.robot_radius_m


def test_passes_through_a_gap_in_a_wall_when_following_a_path() -> None:
    ys = np.arange(-4.0, 4.01, 0.05)
    wall = np.column_stack([np.full(ys.shape, 3.0), ys])
    wall = wall[np.abs(wall[:, 1] - 1.5) > 0.85]  # 1.7 m gap centred at y = 1.5
    path = np.array([[0.0, 0.0], [2.0, 1.5], [4.0, 1.5], [6.0, 0.0]])
    run = drive(RobotState(0.0, 0.0, 0.0), (6.0, 0.0), wall, path_xy_m=path)
    assert run.reached_at_step is not None
    xy = np.array([(s.x_m, s.y_m) for s in run.states])
    assert np.hypot(xy[:, None, 0] - wall[None, :, 0], xy[:, None, 1] - wall[None, :, 1]).min() > 0.6


def test_commands_respect_velocity_and_acceleration_limits() -> None:
    obstacle = circle_points((3.0, 0.2), 0.4)
    run = drive(RobotState(0.0, 0.0, 0.0), (6.0, 0.0), obstacle)
    v = np.array([s.v_mps for s in run.states])
    w = np.array([s.w_radps for s in run.states])
    dt, eps = CONFIG.control_period_s, 1e-9
    assert v.max() <= CONFIG.max_speed_mps + eps and v.min() >= CONFIG.min_speed_mps - eps
    assert np.abs(w).max() <= CONFIG.max_yaw_rate_radps + eps
    assert np.abs(np.diff(v)).max() <= CONFIG.max_accel_mps2 * dt + eps
    assert np.abs(np.diff(w)).max() <= CONFIG.max_yaw_accel_radps2 * dt + eps
    assert v.max() > 0.8 * CONFIG.max_speed_mps  # it does use the speed it is allowed


def test_dynamic_window_is_clipped_to_limits_and_contains_straight_driving() -> None:
    speeds, yaw_rates = dynamic_window(RobotState(0, 0, 0, v_mps=0.98, w_radps=-1.45), CONFIG)
    assert speeds.min() == pytest.approx(0.88) and speeds.max() == pytest.approx(1.0)
    assert yaw_rates.min() == pytest.approx(-1.5) and yaw_rates.max() == pytest.approx(-1.15)
    _, yaw_rates = dynamic_window(RobotState(0, 0, 0, v_mps=0.5, w_radps=0.1), CONFIG)
    assert 0.0 in yaw_rates


def test_rollout_follows_exact_unicycle_arc() -> None:
    state = RobotState(1.0, 2.0, 0.3)
    traj = rollout(state, np.array([0.8]), np.array([0.5]), CONFIG)[0]
    t = CONFIG.horizon_s
    radius = 0.8 / 0.5
    x = 1.0 + radius * (math.sin(0.3 + 0.5 * t) - math.sin(0.3))
    y = 2.0 - radius * (math.cos(0.3 + 0.5 * t) - math.cos(0.3))
    np.testing.assert_allclose(traj[-1], [x, y, 0.3 + 0.5 * t], atol=1e-9)


def test_no_admissible_velocity_gives_flagged_stop_and_rotate_recovery() -> None:
    surrounding = circle_points((0.0, 0.0), 0.5, n=90)  # obstacle closer than the robot radius all round
    result = dwa_step(RobotState(0.0, 0.0, 0.0, v_mps=0.3), (5.0, 5.0), surrounding, CONFIG)
    assert result.recovery and result.n_admissible == 0
    assert result.v_mps == pytest.approx(0.3 - CONFIG.max_accel_mps2 * CONFIG.control_period_s)
    assert result.w_radps > 0  # turns towards the goal on the left, within the yaw-acceleration limit
    assert result.w_radps <= CONFIG.max_yaw_accel_radps2 * CONFIG.control_period_s + 1e-9


def test_rollouts_reaching_a_wall_ahead_are_inadmissible() -> None:
    wall = np.column_stack([np.full(81, 1.2), np.linspace(-2, 2, 81)])
    result = dwa_step(RobotState(0.0, 0.0, 0.0, v_mps=0.2), (5.0, 0.0), wall, CONFIG)
    assert not result.recovery
    assert result.n_admissible < result.n_candidates
    assert result.min_clearance_m > CONFIG.safety_margin_m
    assert result.trajectory_xy_yaw[:, 0].max() < 1.2 - CONFIG.robot_radius_m
