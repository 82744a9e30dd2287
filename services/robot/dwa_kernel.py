"""The dynamic-window planner's arithmetic, compiled: rollouts of every candidate and the choice among them.

Why: the DWA step ran on two thirds of a robot's control periods and took 0.40 ms of its 0.78 ms answer
(a 1-carrier build of the bundled frame: 3,545 steps, 82 obstacle points on average), most of it numpy's
per-call overhead on arrays of a hundred candidates. The robot's answer is what physics waits for in
lock-step, so it is the simulator's speed. The formulas are :mod:`.dwa`'s, term for term and in the same
order (numpy's ``sinc``, ``cumsum`` and ``argmin`` included), so the same command comes out; the clearance
stays a k-d tree query between the two kernels (:func:`.dwa.dwa_step`).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

_TWO_PI = 2.0 * math.pi


@numba.njit(cache=True, nogil=True)
def rollouts(  # noqa: PLR0917 - numba kernels take plain positional arguments
    x_m: float,
    y_m: float,
    yaw_rad: float,
    speeds_mps: NDArray[np.float64],
    yaw_rates_radps: NDArray[np.float64],
    n_steps: int,
    dt_s: float,
) -> NDArray[np.float64]:
    """Constant-(v, w) unicycle arcs, ``(k, n_steps + 1, 3)`` of x, y, yaw (:func:`.dwa.rollout`)."""
    k = len(speeds_mps)
    out = np.empty((k, n_steps + 1, 3))
    for i in range(k):
        v, w = speeds_mps[i], yaw_rates_radps[i]
        sinc_x = w * dt_s / (2 * math.pi)
        sinc_y = math.pi * (1.0e-20 if sinc_x == 0.0 else sinc_x)  # numpy's sinc at 0
        chord_m = v * dt_s * (math.sin(sinc_y) / sinc_y)
        out[i, 0, 0], out[i, 0, 1], out[i, 0, 2] = x_m, y_m, yaw_rad + w * 0.0
        sum_x = sum_y = 0.0
        for j in range(n_steps):
            yaw_mid = (yaw_rad + w * (j * dt_s)) + 0.5 * w * dt_s
            sum_x += chord_m * math.cos(yaw_mid)
            sum_y += chord_m * math.sin(yaw_mid)
            out[i, j + 1, 0] = sum_x + x_m
            out[i, j + 1, 1] = sum_y + y_m
            out[i, j + 1, 2] = yaw_rad + w * ((j + 1) * dt_s)
    return out


@numba.njit(cache=True, nogil=True)
def clearances(
    trajectories: NDArray[np.float64], obstacles_xy_m: NDArray[np.float64], robot_radius_m: float
) -> NDArray[np.float64]:
    """Each candidate's clearance: its rollout's nearest obstacle point, less the robot's radius. The same
    distances as a k-d tree's (``sqrt(dx² + dy²)``), found by trying every pair: with the tens of candidates
    and obstacle points of a robot's step that is faster than building and querying a tree."""
    k, n_points = trajectories.shape[0], trajectories.shape[1]
    out = np.empty(k)
    for i in range(k):
        nearest2 = math.inf
        for j in range(n_points):
            x, y = trajectories[i, j, 0], trajectories[i, j, 1]
            for o in range(len(obstacles_xy_m)):
                dx, dy = x - obstacles_xy_m[o, 0], y - obstacles_xy_m[o, 1]
                d2 = dx * dx + dy * dy
                nearest2 = min(nearest2, d2)
        out[i] = math.sqrt(nearest2) - robot_radius_m
    return out


@numba.njit(cache=True, nogil=True)
def _distance_to_polyline(x: float, y: float, path_xy: NDArray[np.float64]) -> float:
    if len(path_xy) == 1:
        return math.hypot(x - path_xy[0, 0], y - path_xy[0, 1])
    best = math.inf
    for s in range(len(path_xy) - 1):
        ax, ay = path_xy[s, 0], path_xy[s, 1]
        abx, aby = path_xy[s + 1, 0] - ax, path_xy[s + 1, 1] - ay
        len2 = max(abx * abx + aby * aby, 1e-12)
        t = min(max(((x - ax) * abx + (y - ay) * aby) / len2, 0.0), 1.0)
        dx, dy = x - (ax + t * abx), y - (ay + t * aby)
        best = min(best, math.sqrt(dx * dx + dy * dy))
    return best


@numba.njit(cache=True, nogil=True)
def choose(  # noqa: PLR0917 - numba kernels take plain positional arguments
    trajectories: NDArray[np.float64],
    speeds_mps: NDArray[np.float64],
    clearance_m: NDArray[np.float64],
    goal_x_m: float,
    goal_y_m: float,
    path_xy_m: NDArray[np.float64],
    weights: NDArray[np.float64],
    limits: NDArray[np.float64],
) -> tuple[int, int]:
    """(index of the cheapest admissible candidate or -1, number admissible). ``weights``: heading, goal
    distance, clearance, speed, path (0: no path term); ``limits``: safety margin, clearance cap, top
    speed — :class:`.dwa.DwaConfig`'s."""
    heading_w, goal_w, clearance_w, speed_w, path_w = (
        weights[0],
        weights[1],
        weights[2],
        weights[3],
        weights[4],
    )
    safety_m, cap_m, max_speed = limits[0], limits[1], limits[2]
    use_path = path_w > 0.0 and len(path_xy_m) > 0
    best, best_total, admissible = -1, math.inf, 0
    for i in range(len(speeds_mps)):
        if not clearance_m[i] > safety_m:
            continue
        admissible += 1
        end_x, end_y, end_yaw = trajectories[i, -1, 0], trajectories[i, -1, 1], trajectories[i, -1, 2]
        to_x, to_y = goal_x_m - end_x, goal_y_m - end_y
        heading = (math.atan2(to_y, to_x) - end_yaw + math.pi) % _TWO_PI - math.pi
        heading_cost = abs(heading) / math.pi
        goal_cost_m = math.hypot(to_x, to_y)
        clearance_cost = (cap_m - min(clearance_m[i], cap_m)) / cap_m
        speed_cost = (max_speed - speeds_mps[i]) / max_speed
        total = heading_w * heading_cost + goal_w * goal_cost_m + clearance_w * clearance_cost
        total = total + speed_w * speed_cost
        if use_path:
            total = total + path_w * _distance_to_polyline(end_x, end_y, path_xy_m)
        if total < best_total:
            best, best_total = i, total
    return best, admissible


def warm_up() -> None:
    """Compile (or load from numba's cache) both kernels on a tiny input."""
    speeds, rates = np.array([0.0, 0.5]), np.array([0.0, 0.3])
    trajectories = rollouts(0.0, 0.0, 0.0, speeds, rates, 2, 0.1)
    clearances(trajectories, np.ones((1, 2)), 0.5)
    choose(trajectories, speeds, np.array([1.0, 2.0]), 1.0, 0.0, np.zeros((2, 2)), np.ones(5), np.ones(3))
