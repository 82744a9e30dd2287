"""Small pure pieces of the navigator's motion: path geometry, the carrot, simple commands (pure).

Why apart from :mod:`.navigator`: they are geometry and kinematics with no state, each tested on its own,
and the navigator (the state: goal, plan, recoveries, traffic) stays readable.

* :class:`Path` — a polyline with arc lengths: project the robot on it, sample it ahead;
* :func:`carrot` — the point the local planner steers at: far along the path, but only as far as the robot
  sees along a free straight line (no cutting corners into obstacles);
* :func:`turn_command` — brake and turn on the spot (always safe for a disc robot);
* :func:`straight_line_clear` — a straight drive stays clear of the grid and of local obstacle points;
* :func:`yield_point` — where to step aside when another robot has the right of way;
* :func:`unicycle` — where a constant ``(v, w)`` carries a pose (the command latency's prediction).

Units: metres, radians, seconds, world frame.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bimbot.shared.occupancy_grid import OccupancyGrid

from .astar import segment_is_free
from .dwa import DwaConfig

SAMPLE_M = 0.1  # spacing of the path samples the carrot is chosen from
MIN_CARROT_M = 0.8  # a carrot at the robot's feet makes the DWA stop


class Path:
    """A polyline with cumulative arc lengths, for projections and look-ahead samples."""

    def __init__(self, points_xy_m: ArrayLike) -> None:
        self.points = np.asarray(points_xy_m, float).reshape(-1, 2)
        seg = np.hypot(*np.diff(self.points, axis=0).T) if len(self.points) > 1 else np.zeros(0)
        self.arc_m = np.concatenate([[0.0], np.cumsum(seg)])

    def project(self, xy_m: ArrayLike) -> tuple[float, float]:
        """Arc length of the point of the path nearest ``xy_m``, and the distance to it."""
        xy = np.asarray(xy_m, float)
        if len(self.points) == 1:
            return 0.0, float(np.hypot(*(xy - self.points[0])))
        a, ab = self.points[:-1], np.diff(self.points, axis=0)
        t = np.clip(((xy - a) * ab).sum(axis=1) / np.maximum((ab**2).sum(axis=1), 1e-12), 0.0, 1.0)
        gap = np.hypot(*(a + t[:, None] * ab - xy).T)
        i = int(np.argmin(gap))
        return float(self.arc_m[i] + t[i] * (self.arc_m[i + 1] - self.arc_m[i])), float(gap[i])

    def samples(self, from_arc_m: float, length_m: float, step_m: float = SAMPLE_M) -> NDArray[np.float64]:
        """Points every ``step_m`` from arc length ``from_arc_m`` over ``length_m`` (clipped at the end)."""
        end = min(from_arc_m + length_m, float(self.arc_m[-1]))
        s = np.append(np.arange(from_arc_m, end, step_m), end)
        x = np.interp(s, self.arc_m, self.points[:, 0])
        return np.column_stack([x, np.interp(s, self.arc_m, self.points[:, 1])])


def carrot(
    ahead: NDArray[np.float64], xy: ArrayLike, lookahead_m: float, grid: OccupancyGrid
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The carrot for the local planner, and the path stretch up to it (every 0.5 m).

    ``ahead`` holds path samples :data:`SAMPLE_M` apart from the robot's projection on the path. The carrot is
    the farthest sample within ``lookahead_m`` seen along a free straight line on ``grid`` from the robot
    (or, when the robot stands in an occupied cell, from the first free sample ahead), and never nearer
    than :data:`MIN_CARROT_M`. Visibility along a path is close to monotone, so it is found by bisection.
    """
    here = np.asarray(xy, float)
    n = min(len(ahead), round(lookahead_m / SAMPLE_M) + 1)
    nearest = min(n - 1, round(MIN_CARROT_M / SAMPLE_M))
    first, origin = 0, here
    if not grid.is_free(*here):
        free = grid.is_free_xy(ahead[:n])
        first = int(np.argmax(free)) if free.any() else n - 1
        origin = ahead[first]
    low, high = first, n - 1
    if not segment_is_free(grid, origin, ahead[high]):
        while high - low > 1:
            mid = (low + high) // 2
            if segment_is_free(grid, origin, ahead[mid]):
                low = mid
            else:
                high = mid
        high = low
    high = max(high, nearest)
    return ahead[high], np.vstack([ahead[:high:5], ahead[high : high + 1]])


def turn_command(
    heading_error_rad: float, v_mps: float, w_radps: float, dwa: DwaConfig
) -> tuple[float, float]:
    """Brake and turn on the spot towards ``heading_error_rad``, within the acceleration limits, never
    faster than lets the robot stop on the heading (w² ≤ 2·α·|error|)."""
    dv, dw = dwa.max_accel_mps2 * dwa.control_period_s, dwa.max_yaw_accel_radps2 * dwa.control_period_s
    v = max(0.0, v_mps - dv) if v_mps >= 0.0 else min(0.0, v_mps + dv)
    w_max = min(dwa.max_yaw_rate_radps, math.sqrt(2.0 * dwa.max_yaw_accel_radps2 * abs(heading_error_rad)))
    w = float(np.clip(math.copysign(w_max, heading_error_rad), w_radps - dw, w_radps + dw))
    return v, w


def straight_line_clear(
    grid: OccupancyGrid,
    from_xy_m: ArrayLike,
    to_xy_m: ArrayLike,
    points_xy_m: NDArray[np.float64],
    clearance_m: float,
) -> bool:
    """A straight drive stays in free cells of ``grid`` and farther than ``clearance_m`` from every point."""
    a, b = np.asarray(from_xy_m, float), np.asarray(to_xy_m, float)
    if not segment_is_free(grid, a, b):
        return False
    if len(points_xy_m) == 0:
        return True
    ab = b - a
    t = np.clip(((points_xy_m - a) @ ab) / max(float(ab @ ab), 1e-12), 0.0, 1.0)
    return bool(np.hypot(*(a + t[:, None] * ab - points_xy_m).T).min() > clearance_m)


def yield_point(
    grid: OccupancyGrid, xy_m: ArrayLike, other_xy_m: ArrayLike, distance_m: float = 2.0
) -> NDArray[np.float64] | None:
    """A free spot ``distance_m`` away, as directly away from ``other_xy_m`` as the grid allows, reachable
    in a straight free line; None when there is none."""
    here, other = np.asarray(xy_m, float), np.asarray(other_xy_m, float)
    away = math.atan2(here[1] - other[1], here[0] - other[0])
    for offset in (0.0, 0.5, -0.5, 1.0, -1.0, 1.5, -1.5):
        for scale in (1.0, 0.6):
            heading = away + offset
            spot = here + scale * distance_m * np.array([math.cos(heading), math.sin(heading)])
            if grid.is_free(*spot) and (not grid.is_free(*here) or segment_is_free(grid, here, spot)):
                return spot
    return None


def unicycle(pose_xy_yaw: ArrayLike, v_mps: float, w_radps: float, seconds: float) -> NDArray[np.float64]:
    """``pose_xy_yaw`` carried by a constant ``(v, w)`` for ``seconds``: the exact arc (a chord along the
    mid-arc heading)."""
    x, y, yaw = (float(value) for value in np.asarray(pose_xy_yaw, dtype=float)[:3])
    turn = w_radps * seconds
    chord = v_mps * seconds * (math.sin(turn / 2.0) / (turn / 2.0) if abs(turn) > 1e-9 else 1.0)
    heading = yaw + turn / 2.0
    return np.array(
        [x + chord * math.cos(heading), y + chord * math.sin(heading), math.remainder(yaw + turn, math.tau)]
    )
