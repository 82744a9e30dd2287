"""The navigator's recovery chain, its progress watchdog and the reason it gives when it fails (pure).

Why: a robot must never stay trapped, and it must never fail without saying why. Like Nav2's behaviour
tree navigator (a recovery subtree of clear-costmap, spin, back-up behaviours between retries, a progress
checker that aborts a goal that does not advance), the navigator answers trouble with a fixed sequence of
recoveries, each at most once per goal, and only then reports FAILED with a :class:`~bimbot.shared.reasons.
Reason`. Trouble is any of: no path to the goal for ``no_path_recover_s`` more, the robot not moving
(``stuck_window_s``), or the :class:`ProgressWatchdog` expiring (no progress towards the goal within
``progress_window_s``). The executor then re-chooses the approach pose (the fifth step, on any side of the
component, away from the stand-points that failed) and after its own bound gives the task back.

The chain, as data (:data:`RECOVERY_CHAIN`):

=================  =====================================================================================
``clear_marks``    plan without the laser marks for ``clear_marks_s`` (stale or spurious hits, a robot
                   that has moved on); the local planner still sees every live laser point
``rotate``         turn on the spot for ``rotate_s`` (fresh laser views, the localiser re-converges)
``back_up``        reverse ``backup_s`` at ``backup_speed_mps`` when the way behind is clear (else skipped)
``plan_out``       plan from the nearest free cell of the planning grid within ``plan_out_max_m`` (a
                   growing search) when the robot's own cell lies in an inflated or occupied zone; when
                   none is in a straight line, along the cells its body fits (:func:`escape_path`)
=================  =====================================================================================

:func:`diagnose` names the failure on the static inflated grid (laser marks left out, so another robot in
the way never makes a goal "unreachable"): ``robot_trapped`` when the free space the robot can reach is
smaller than ``trapped_area_m2``, ``unreachable`` when the goal lies outside it (a flood fill of the grid
from the robot), else ``no_progress``; each message ends with the components within ``beside_m`` of the
robot, nearest first (what may hold it up: a beam that fell beside it).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass
from enum import StrEnum

import numpy as np
from numpy.typing import ArrayLike

from bimbot.shared.occupancy_grid import OccupancyGrid, nearest_free_cell
from bimbot.shared.reasons import Reason, ReasonCode

from .approach import reachable_region
from .astar import segment_is_free

ESCAPE_MAX_M = 10.0  # a way out through cells the robot's body fits is searched this far around it
_EIGHT_STEPS = ((-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1))


class Recovery(StrEnum):
    CLEAR_MARKS = "clear_marks"
    ROTATE = "rotate"
    BACK_UP = "back_up"
    PLAN_OUT = "plan_out"


RECOVERY_CHAIN: tuple[Recovery, ...] = (
    Recovery.CLEAR_MARKS,
    Recovery.ROTATE,
    Recovery.BACK_UP,
    Recovery.PLAN_OUT,
)
"""The navigator's recoveries in the order it tries them, each at most once per goal."""


@dataclass
class ProgressWatchdog:
    """Expires when neither the straight-line distance to the goal nor the remaining path length got
    ``min_progress_m`` shorter than its best within ``window_s`` sim seconds (a detour that lengthens the
    path is progress as long as the robot gains on it)."""

    window_s: float
    min_progress_m: float
    since_s: float = 0.0
    best_m: tuple[float, float] = (math.inf, math.inf)

    def reset(self, sim_s: float) -> None:
        """Start a new window now (after a recovery, a hold, a wait): the robot gets the full window."""
        self.since_s, self.best_m = sim_s, (math.inf, math.inf)

    def expired(self, distance_m: float, path_left_m: float, sim_s: float) -> bool:
        """Record the distances at ``sim_s``; True when the window passed without progress."""
        straight, path = self.best_m
        if distance_m < straight - self.min_progress_m or path_left_m < path - self.min_progress_m:
            self.since_s = sim_s
            self.best_m = (min(straight, distance_m), min(path, path_left_m))
            return False
        return sim_s - self.since_s > self.window_s


def next_recovery(level: int, *, clear_behind: bool) -> tuple[Recovery | None, int]:
    """The recovery to run at chain position ``level`` (skipping a back-up with no room behind) and the
    next level; None when the chain is exhausted."""
    while level < len(RECOVERY_CHAIN):
        kind = RECOVERY_CHAIN[level]
        level += 1
        if kind is Recovery.BACK_UP and not clear_behind:
            continue
        return kind, level
    return None, level


def plan_start(
    grid: OccupancyGrid, xy_m: ArrayLike, max_snap_m: float, body_grid: OccupancyGrid | None = None
) -> tuple[float, float] | None:
    """Where A* starts: the robot's own cell when free, else the nearest free cell within ``max_snap_m``
    that the robot can drive to in a straight line clear of ``body_grid`` (the obstacles grown by the
    robot's half-width: never the free cell just beyond a wall), None when there is none."""
    xy = np.asarray(xy_m, float)
    if grid.is_free(*xy):
        return float(xy[0]), float(xy[1])
    reach = math.ceil(max_snap_m / grid.resolution_m)
    rc = grid.world_to_cell(xy)
    rows, cols = grid.shape
    r0, r1 = max(0, int(rc[0]) - reach), min(rows, int(rc[0]) + reach + 1)
    c0, c1 = max(0, int(rc[1]) - reach), min(cols, int(rc[1]) + reach + 1)
    if r0 >= r1 or c0 >= c1:
        return None
    cells = np.argwhere(~grid.occupied[r0:r1, c0:c1]) + np.array([r0, c0])
    if len(cells) == 0:
        return None
    points = grid.cell_to_world(cells)
    distance = np.hypot(*(points - xy).T)
    order = [i for i in np.argsort(distance, kind="stable") if distance[i] <= max_snap_m]
    for i in order[:400]:
        if body_grid is None or segment_is_free(body_grid, xy, points[i]):
            return float(points[i, 0]), float(points[i, 1])
    return None


def escape_path(
    grid: OccupancyGrid, xy_m: ArrayLike, body_grid: OccupancyGrid, max_m: float = ESCAPE_MAX_M
) -> list[tuple[float, float]] | None:
    """Waypoints from the robot, through cells clear of ``body_grid`` (its body fits), to the nearest free
    cell of ``grid`` they join within ``max_m``: the way out of a space that what was built beside the
    robot has narrowed below its inflated width (a Husky in a 1.4 m lane between new walls). None when
    there is none (the robot is walled in)."""
    xy = np.asarray(xy_m, float)
    rc = grid.world_to_cell(xy)
    reach = math.ceil(max_m / grid.resolution_m)
    rows, cols = grid.shape
    r0, r1 = max(0, int(rc[0]) - reach), min(rows, int(rc[0]) + reach + 1)
    c0, c1 = max(0, int(rc[1]) - reach), min(cols, int(rc[1]) + reach + 1)
    body_free = ~body_grid.occupied[r0:r1, c0:c1]
    free = ~grid.occupied[r0:r1, c0:c1]
    start = (int(rc[0]) - r0, int(rc[1]) - c0)
    shape = body_free.shape
    if not (0 <= start[0] < shape[0] and 0 <= start[1] < shape[1]) or not body_free[start]:
        return None
    parent = {start: start}
    frontier = deque([start])  # breadth first: the free cell fewest steps away, not the nearest in a line
    end = None
    while frontier:
        cell = frontier.popleft()
        if free[cell]:
            end = cell
            break
        for d_row, d_col in _EIGHT_STEPS:
            nxt = (cell[0] + d_row, cell[1] + d_col)
            if 0 <= nxt[0] < shape[0] and 0 <= nxt[1] < shape[1] and body_free[nxt] and nxt not in parent:
                parent[nxt] = cell
                frontier.append(nxt)
    if end is None:
        return None
    cells = [end]
    while cells[-1] != start:
        cells.append(parent[cells[-1]])
    points = grid.cell_to_world(np.array(cells[::-1][1:], dtype=np.int64).reshape(-1, 2) + np.array([r0, c0]))
    return [(float(xy[0]), float(xy[1])), *((float(x), float(y)) for x, y in points)]


def held_where_it_stands(
    grid: OccupancyGrid, body_grid: OccupancyGrid, xy_m: ArrayLike, max_snap_m: float
) -> bool:
    """Whether a robot at ``xy_m`` cannot leave where it stands: its cell is not free on ``grid`` (the
    inflated planning grid), no free cell lies within a straight drive of ``max_snap_m`` clear of
    ``body_grid`` (:func:`plan_start`), and no way its body fits leads out (:func:`escape_path`): what came
    to stand over or round it (a part that slid onto its place) holds it, whatever free space lies beyond."""
    if plan_start(grid, xy_m, max_snap_m, body_grid) is not None:
        return False
    return escape_path(grid, xy_m, body_grid) is None


def diagnose(
    grid: OccupancyGrid,
    robot_xy_m: ArrayLike,
    goal_xy_m: ArrayLike,
    *,
    robot_id: str,
    why: str,
    trapped_area_m2: float,
    tried: tuple[Recovery, ...],
    beside: Sequence[tuple[str, float]] = (),
    held: bool = False,
) -> Reason:
    """The reason a navigation failed (see the module doc): a sentence with positions and numbers, ending
    with the components ``beside`` the robot (name, distance), nearest first: what may hold it up.
    ``held``: the robot cannot leave where it stands (:func:`held_where_it_stands`), trapped whatever free
    space lies beyond."""
    here = np.asarray(robot_xy_m, float)
    goal = np.asarray(goal_xy_m, float)
    robot = robot_id or "the robot"
    beside_text = (
        "; beside it: " + ", ".join(f"{name} ({m:.1f} m)" for name, m in beside[:3]) if beside else ""
    )
    at = f"({here[0]:.2f}, {here[1]:.2f})"
    to = f"({goal[0]:.2f}, {goal[1]:.2f})"
    done = ", ".join(r.value for r in tried) or "none"
    if held:
        return Reason(
            code=ReasonCode.ROBOT_TRAPPED,
            robot_id=robot_id or None,
            message=(
                f"{robot} at {at} is held where it stands: what stands on its map covers its place and no "
                f"way its body fits leads out within {ESCAPE_MAX_M:.0f} m, after the recoveries ({done}); "
                f"it {why}{beside_text}"
            ),
        )
    region = reachable_region(grid, here)
    area_m2 = 0.0 if region is None else float(region.sum()) * grid.resolution_m**2
    if area_m2 < trapped_area_m2:
        return Reason(
            code=ReasonCode.ROBOT_TRAPPED,
            robot_id=robot_id or None,
            message=(
                f"{robot} at {at} is boxed in: {area_m2:.1f} m² of free space around it, less than "
                f"{trapped_area_m2:.1f} m², after the recoveries ({done}); it {why}{beside_text}"
            ),
        )
    assert region is not None
    cell = grid.world_to_cell(goal)
    inside = bool(grid.in_bounds(cell)) and bool(region[cell[0], cell[1]])
    if not inside:
        near = nearest_free_cell(grid, goal, max_distance_m=0.3)
        inside = near is not None and bool(region[near[0], near[1]])
    if not inside:
        return Reason(
            code=ReasonCode.UNREACHABLE,
            robot_id=robot_id or None,
            message=(
                f"the goal {to} is cut off from {robot} at {at} ({math.dist(here, goal):.1f} m apart): no "
                f"free way joins them on the planning grid (cells of {grid.resolution_m:.2f} m, the robot "
                f"inflated); it {why}{beside_text}"
            ),
        )
    return Reason(
        code=ReasonCode.NO_PROGRESS,
        robot_id=robot_id or None,
        message=(
            f"{robot} at {at} {why}, {math.dist(here, goal):.1f} m from its goal {to}, after the recoveries "
            f"({done}){beside_text}"
        ),
    )
