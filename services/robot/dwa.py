"""Dynamic-window local planner (Fox, Burgard & Thrun 1997) for a differential-drive robot.

Why: the local planner of the move_base-style stack. Each control step it samples the velocities
``(v_mps, w_radps)`` reachable within one control period under the acceleration limits (the dynamic
window), rolls every candidate out over a short horizon as a unicycle arc, drops candidates whose arc comes
within the robot radius of a laser hit, and picks the cheapest by a weighted sum of heading, goal distance,
clearance, speed and path-following costs (physical units, no per-step normalisation, so progress
towards the goal always outweighs standing still). Rollout and clearance are vectorised over all
candidates at once (clearance via a k-d tree of the obstacle points); the rollouts and the choice are
compiled (:mod:`.dwa_kernel`: the same formulas as :func:`rollout` and the costs it replaced).

Frames and units: world frame, x right / y up, metres, radians, seconds; obstacles are world-frame laser
hit points ``(n, 2)``. The robot is modelled as a disc of ``robot_radius_m`` (use the circumscribed radius),
so rotating in place never collides.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from bimbot.shared.geometry import wrap_angle

from . import dwa_kernel

logger = logging.getLogger(__name__)

# Up to this many (rollout point, obstacle point) pairs the clearance is found by trying them all (a robot's
# step: ~500 points × ~80 obstacles, 4× faster than a k-d tree); beyond it by a k-d tree. Same distances.
BRUTE_FORCE_PAIRS = 200_000


@dataclass(frozen=True)
class DwaConfig:
    """Limits, sampling and cost weights of the dynamic-window planner (defaults suit a Husky).

    Keep ``horizon_s ≥ max_speed_mps / max_accel_mps2``: then a robot that only ever drives admissible
    rollouts always has an admissible (slower) rollout at the next step, as the braking fits the horizon.
    """

    max_speed_mps: float = 1.0
    min_speed_mps: float = 0.0  # > = 0: no reversing
    max_yaw_rate_radps: float = 1.5
    max_accel_mps2: float = 1.0
    max_yaw_accel_radps2: float = 3.0
    speed_resolution_mps: float = 0.025
    yaw_rate_resolution_radps: float = 0.05
    control_period_s: float = 0.1  # time between commands: sets the size of the dynamic window
    horizon_s: float = 2.0
    sim_dt_s: float = 0.1
    robot_radius_m: float = 0.6
    safety_margin_m: float = 0.05  # also covers the < 3 mm lost between rollout samples at max speed
    clearance_cap_m: float = 1.5  # clearance beyond this earns nothing more
    # Cost = heading_weight·|heading error at the rollout end|/π + goal_distance_weight·(end→goal, m)
    # + clearance_weight·(1 − min(clearance, cap)/cap) + speed_weight·(1 − v/v_max)
    # + path_weight·(end→path, m).
    heading_weight: float = 0.5
    goal_distance_weight: float = 1.0
    clearance_weight: float = 0.8
    speed_weight: float = 0.2
    path_weight: float = 0.6


@dataclass(frozen=True)
class RobotState:
    """Pose and current velocity of the robot in the world frame."""

    x_m: float
    y_m: float
    yaw_rad: float
    v_mps: float = 0.0
    w_radps: float = 0.0


@dataclass(frozen=True, eq=False)
class DwaResult:
    """Command chosen by one DWA step; ``recovery`` is True when no candidate was admissible."""

    v_mps: float
    w_radps: float
    trajectory_xy_yaw: NDArray[np.float64]  # (steps + 1, 3), starting at the current pose
    recovery: bool
    n_candidates: int
    n_admissible: int
    min_clearance_m: float


def dynamic_window(state: RobotState, config: DwaConfig) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Candidate speeds and yaw rates reachable within one control period, both within the hard limits."""
    dt = config.control_period_s
    v_lo = max(config.min_speed_mps, state.v_mps - config.max_accel_mps2 * dt)
    v_hi = min(config.max_speed_mps, state.v_mps + config.max_accel_mps2 * dt)
    w_lo = max(-config.max_yaw_rate_radps, state.w_radps - config.max_yaw_accel_radps2 * dt)
    w_hi = min(config.max_yaw_rate_radps, state.w_radps + config.max_yaw_accel_radps2 * dt)
    if v_lo > v_hi:  # current speed outside the hard limits: return to them
        v_lo = v_hi = v_hi if state.v_mps > v_hi else v_lo
    if w_lo > w_hi:
        w_lo = w_hi = w_hi if state.w_radps > w_hi else w_lo
    speeds = np.linspace(v_lo, v_hi, max(2, math.ceil((v_hi - v_lo) / config.speed_resolution_mps) + 1))
    yaw_rates = np.linspace(
        w_lo, w_hi, max(2, math.ceil((w_hi - w_lo) / config.yaw_rate_resolution_radps) + 1)
    )
    if w_lo < 0.0 < w_hi:  # always offer driving straight
        yaw_rates = np.union1d(yaw_rates, [0.0])
    return np.unique(speeds), np.unique(yaw_rates)


def rollout(
    state: RobotState,
    speeds_mps: NDArray[np.float64],
    yaw_rates_radps: NDArray[np.float64],
    config: DwaConfig,
) -> NDArray[np.float64]:
    """Constant-(v, w) unicycle rollouts (exact arcs), shape ``(k, steps + 1, 3)`` of x, y, yaw: each step
    is a chord of length v·dt·sinc(w·dt/2) along the mid-step heading (:func:`.dwa_kernel.rollouts`)."""
    n_steps = max(1, round(config.horizon_s / config.sim_dt_s))
    speeds, rates = np.asarray(speeds_mps, dtype=float), np.asarray(yaw_rates_radps, dtype=float)
    return dwa_kernel.rollouts(state.x_m, state.y_m, state.yaw_rad, speeds, rates, n_steps, config.sim_dt_s)


def _recovery(state: RobotState, goal: NDArray[np.float64], config: DwaConfig, n: int) -> DwaResult:
    """Brake to a stop and turn in place towards the goal, within the acceleration limits."""
    dt = config.control_period_s
    v = max(0.0, state.v_mps - config.max_accel_mps2 * dt) if state.v_mps >= 0 else 0.0
    heading_error = float(wrap_angle(math.atan2(goal[1] - state.y_m, goal[0] - state.x_m) - state.yaw_rad))
    w_target = math.copysign(config.max_yaw_rate_radps, heading_error)
    dw = config.max_yaw_accel_radps2 * dt
    w = float(np.clip(w_target, state.w_radps - dw, state.w_radps + dw))
    trajectory = rollout(state, np.array([v]), np.array([w]), config)[0]
    logger.debug("no admissible velocity among %d: recovery v=%.2f w=%.2f", n, v, w)
    return DwaResult(v, w, trajectory, True, n, 0, 0.0)


def dwa_step(
    state: RobotState,
    goal_xy_m: ArrayLike,
    obstacles_xy_m: ArrayLike,
    config: DwaConfig,
    path_xy_m: ArrayLike | None = None,
) -> DwaResult:
    """Choose the next ``(v_mps, w_radps)`` command towards ``goal_xy_m`` avoiding ``obstacles_xy_m``.

    ``path_xy_m`` (optional, ``(m, 2)``) is the local stretch of the global plan; when given, trajectories
    whose end strays from it are penalised. A candidate is admissible when every point of its rollout is
    farther than ``robot_radius_m + safety_margin_m`` from every obstacle point.
    """
    goal = np.asarray(goal_xy_m, dtype=float)
    obstacles = np.asarray(obstacles_xy_m, dtype=float).reshape(-1, 2)
    speeds, yaw_rates = dynamic_window(state, config)
    v_grid, w_grid = (g.ravel() for g in np.meshgrid(speeds, yaw_rates, indexing="ij"))
    trajectories = rollout(state, v_grid, w_grid, config)
    k, n_points = trajectories.shape[:2]

    reach_m = config.max_speed_mps * config.horizon_s + config.clearance_cap_m + config.robot_radius_m
    if len(obstacles):
        near = np.hypot(obstacles[:, 0] - state.x_m, obstacles[:, 1] - state.y_m) <= reach_m
        obstacles = obstacles[near]
    if len(obstacles) and k * n_points * len(obstacles) <= BRUTE_FORCE_PAIRS:
        clearance = dwa_kernel.clearances(trajectories, obstacles, config.robot_radius_m)
    elif len(obstacles):
        tree = cKDTree(obstacles)
        dist, _ = tree.query(trajectories[..., :2].reshape(-1, 2), k=1)
        assert isinstance(dist, np.ndarray)  # many points in, an array out (the stubs give float | array)
        clearance = dist.reshape(k, n_points).min(axis=1) - config.robot_radius_m
    else:
        clearance = np.full(k, math.inf)
    path = np.asarray(path_xy_m if path_xy_m is not None else (), dtype=float).reshape(-1, 2)
    weights = (
        config.heading_weight,
        config.goal_distance_weight,
        config.clearance_weight,
        config.speed_weight,
        config.path_weight,
    )
    limits = (config.safety_margin_m, config.clearance_cap_m, config.max_speed_mps)
    best, admissible = dwa_kernel.choose(
        trajectories,
        v_grid,
        clearance,
        float(goal[0]),
        float(goal[1]),
        path,
        np.array(weights),
        np.array(limits),
    )
    if best < 0:
        return _recovery(state, goal, config, k)
    return DwaResult(
        float(v_grid[best]),
        float(w_grid[best]),
        trajectories[best],
        False,
        k,
        admissible,
        float(clearance[best]),
    )
