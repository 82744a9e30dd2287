"""Which robots a placement would shut in, checked by the robot about to place it (pure).

Why: the planner holds a part back at its release while placing it would shut a robot into a room
(:mod:`bimbot.services.planner.shut_in`), but robots move after a release. On the Revit house with three
carriers, r2 drove into a room to set a partition panel; another panel that closed the same room had
been released while r2 was outside, and r2 stood walled in for the rest of the run (80 h of sim time). A
site sets no wall that closes a room with a machine in it. So the robot that is about to place a
component that blocks the robots' height band asks, with its own map, which of the other robots that
drive are joined to their depot now and would not be once the component stands (on the map inflated by
each one's own radius); it waits while there is one (:mod:`.executor`).

A robot stands on a free cell of its own inflated grid or, held close to a wall, in its inflation: it
counts as joined when a joined cell lies within its inflation radius (one cell more) of where it said it
stood (:func:`joined_near`). What lies across the component it sets is farther than that.

Cost: two labellings of the free grid for each size of robot on site (the depots lie in one depot area,
joined to each other, so one depot stands for all robots of a size), once a placement and then every
few seconds of sim time while one is held.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from bimbot.shared.occupancy_grid import OccupancyGrid

from .approach import reachable_region, way_out_after
from .robot_context import RobotContext
from .site_map import STATIC_DISTANCE_MAX_M, SiteMap
from .task_state import ExecutorConfig, Task, component_name

_log = logging.getLogger(__name__)


def joined_near(
    grid: OccupancyGrid, joined: NDArray[np.bool_] | None, xy_m: Sequence[float], radius_m: float
) -> bool:
    """Whether a cell of ``joined`` (cells of ``grid`` that reach a depot; None: none) lies within
    ``radius_m`` of ``xy_m``."""
    if joined is None:
        return False
    cells = math.ceil(radius_m / grid.resolution_m) + 1
    row, col = (int(v) for v in grid.world_to_cell(np.asarray(xy_m, float)))
    rows, cols = joined.shape
    r0, r1 = max(0, row - cells), min(rows, row + cells + 1)
    c0, c1 = max(0, col - cells), min(cols, col + cells + 1)
    if r0 >= r1 or c0 >= c1:
        return False
    near = np.hypot(*np.ogrid[r0 - row : r1 - row, c0 - col : c1 - col]) <= cells
    return bool((joined[r0:r1, c0:c1] & near).any())


def shut_in_by(
    site_map: SiteMap,
    outlines_xy_m: Sequence[NDArray[np.float64]],
    drivers: Mapping[str, tuple[float, tuple[float, float]]],
    others_xy: Mapping[str, tuple[float, float]],
) -> list[str]:
    """The robots of ``drivers`` (id → its inflation radius and depot start) that, where ``others_xy`` says
    they stand, reach their depot on ``site_map`` now and would not once a component of these band outlines
    stands; sorted."""
    if not outlines_xy_m:
        return []
    shut = []
    regions: dict[float, tuple[OccupancyGrid, NDArray[np.bool_] | None, NDArray[np.bool_] | None]] = {}
    for robot_id in sorted(others_xy):
        if robot_id not in drivers:
            continue
        radius_m, depot_xy = drivers[robot_id]
        if radius_m >= STATIC_DISTANCE_MAX_M:
            continue  # wider than the map's distance field goes: not checked (none of bimbot's types)
        if radius_m not in regions:  # once per robot size: the depots lie in one yard, joined to each other
            grid = site_map.inflated_grid(radius_m)
            before = reachable_region(grid, depot_xy)
            regions[radius_m] = (grid, before, way_out_after(grid, outlines_xy_m, depot_xy, radius_m))
        grid, before, after = regions[radius_m]
        xy = others_xy[robot_id]
        if joined_near(grid, before, xy, radius_m) and not joined_near(grid, after, xy, radius_m):
            shut.append(robot_id)  # joined now (else walled in already: not this placement's doing)
    return shut


def held(context: RobotContext, task: Task, config: ExecutorConfig) -> bool:
    """Whether the robot holds the task's placement now: placing it would shut another robot in
    (:func:`shut_in_by`). It asks again in ``shut_in_recheck_s`` (``task.retry_at_s``), for
    ``shut_in_wait_s`` at most; then it places (the planner's bound: the robot inside may be held there by
    its own work), and says so."""
    band = context.site_map.config
    outlines = task.target.outlines_meeting(band.band_min_z_m, band.band_max_z_m) if task.target else []
    shut = shut_in_by(context.site_map, outlines, context.drivers, context.others_xy) if outlines else []
    name, now = component_name(task), context.sim_s
    if not shut:
        if task.shut_in_since_s is not None:
            _log.info("%s: %s goes: it shuts nobody in now", context.robot_id, name)
            task.shut_in_since_s = None
        return False
    if task.shut_in_since_s is None:
        task.shut_in_since_s = now
        _log.info(
            "%s: %s waits: placing it now would shut in %s (no way out to the depot)",
            context.robot_id,
            name,
            ", ".join(shut),
        )
    if now - task.shut_in_since_s >= config.shut_in_wait_s:
        _log.warning(
            "%s: %s placed after %.0f s: it still shuts in %s",
            context.robot_id,
            name,
            now - task.shut_in_since_s,
            ", ".join(shut),
        )
        return False
    task.retry_at_s = now + config.shut_in_recheck_s
    return True
