"""Approach poses: where the robot stands to pick a component up or to assemble it (pure).

Why: the grasp and the joining stay abstract, as in the paper; what the robot must get right is *where it
stands*: on a free cell of the inflated grid (its body fits), in the free region it can drive to (never in
a pocket cut off by stacks or behind the fence), within reach of the component, and facing it.

One rule serves both ends of a task. Candidates are the free cell centres in a window around the
component's footprint; a candidate is kept when

* it is free in the (inflated, laser-marked) planning grid and in the robot's connected free region;
* the horizontal distance from it to the footprint's centre is within ``reach_m`` (physics checks reach);
* when the component occupies the robot's height band (a component lying in the yard, a column being
  placed), the robot's body stays outside it: distance to the footprint ≥ ``body_clearance_m``. A component
  above the band (a beam at 3 m) may be approached from under its footprint.

The best candidate is the one nearest the footprint's centre (best reach, the middle of a long side), ties
broken by the distance from the robot. Its yaw faces the footprint's centre (unchanged when it stands on
the centre). Cost: one connected-component labelling of the free grid and a vectorised filter of the
window (~1–3 ms on a site grid at 0.1 m).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage

from bimbot.shared.footprint import Footprint
from bimbot.shared.occupancy_grid import OccupancyGrid, nearest_free_cell

_log = logging.getLogger(__name__)

_EIGHT = np.ones((3, 3), bool)


@dataclass(frozen=True)
class ApproachConfig:
    reach_m: float = 1.5  # horizontal distance from the robot's centre to the component's centre
    reach_margin_m: float = 0.1  # stay this much inside the reach
    body_clearance_m: float = 0.7  # robot centre ↔ a band-blocking component's outline
    robot_weight: float = 0.05  # per metre from the robot, against 1 per metre from the component centre


@dataclass(frozen=True)
class Approach:
    """A pose to drive to: ``x_m, y_m, yaw_rad`` (yaw None: any heading will do)."""

    x_m: float
    y_m: float
    yaw_rad: float | None
    reach_distance_m: float  # horizontal distance to the footprint's centre

    @property
    def xy_m(self) -> tuple[float, float]:
        return (self.x_m, self.y_m)


def reachable_region(grid: OccupancyGrid, from_xy_m: ArrayLike) -> NDArray[np.bool_] | None:
    """Free cells 8-connected to ``from_xy_m`` (or to the free cell nearest it), None if there are none."""
    free = ~grid.occupied
    labels, _ = ndimage.label(free, structure=_EIGHT)
    rc = grid.world_to_cell(np.asarray(from_xy_m, float))
    if not (grid.in_bounds(rc) and free[rc[0], rc[1]]):
        near = nearest_free_cell(grid, from_xy_m, max_distance_m=3.0)
        if near is None:
            return None
        rc = np.array(near)
    return labels == labels[rc[0], rc[1]]


def approach_pose(
    grid: OccupancyGrid,
    footprint: Footprint,
    robot_xy_m: ArrayLike,
    *,
    blocks_band: bool,
    config: ApproachConfig = ApproachConfig(),
    region: NDArray[np.bool_] | None = None,
) -> Approach | None:
    """The best approach pose beside ``footprint`` (see the module doc), or None when there is none.

    ``grid`` is the inflated planning grid; ``region`` the robot's reachable free cells (computed from
    ``robot_xy_m`` when not given).
    """
    if region is None:
        region = reachable_region(grid, robot_xy_m)
        if region is None:
            _log.info("robot at %s has no free cell near it", np.asarray(robot_xy_m).tolist())
            return None
    centre = footprint.centre_xy_m
    reach = config.reach_m - config.reach_margin_m
    poly = footprint.polygon_xy_m
    low = np.minimum(poly.min(axis=0), centre - reach)
    high = np.maximum(poly.max(axis=0), centre + reach)
    rc_low = grid.world_to_cell(low)
    rc_high = grid.world_to_cell(high)
    rows, cols = grid.shape
    r0, r1 = max(0, int(rc_low[0])), min(rows, int(rc_high[0]) + 1)
    c0, c1 = max(0, int(rc_low[1])), min(cols, int(rc_high[1]) + 1)
    if r0 >= r1 or c0 >= c1:
        return None
    window = region[r0:r1, c0:c1] & ~grid.occupied[r0:r1, c0:c1]
    cells = np.argwhere(window) + np.array([r0, c0])
    if len(cells) == 0:
        return None
    xy = grid.cell_to_world(cells)
    to_centre = np.hypot(*(xy - centre).T)
    keep = to_centre <= reach
    if blocks_band:
        keep &= footprint.distance_m(xy) >= config.body_clearance_m
    if not keep.any():
        _log.info("no free approach within %.2f m of %s", reach, np.round(centre, 2).tolist())
        return None
    xy, to_centre = xy[keep], to_centre[keep]
    score = to_centre + config.robot_weight * np.hypot(*(xy - np.asarray(robot_xy_m, float)).T)
    best = int(np.argmin(score))
    x, y = float(xy[best, 0]), float(xy[best, 1])
    yaw = math.atan2(centre[1] - y, centre[0] - x) if to_centre[best] > 0.2 else None
    return Approach(x, y, yaw, float(to_centre[best]))
