"""Approach poses: where the robot stands to pick a component up or to assemble it (pure).

Why: the grasp and the joining stay abstract, as in the paper; what the robot must get right is *where it
stands*: on a free cell of the inflated grid (its body fits), in the free region it can drive to (never in
a pocket cut off by stacks, walls or behind the fence), within reach of the component, and facing it.

One rule serves both ends of a task. Candidates are the free cell centres in a window around the
component's footprint, on **every side** of it; a candidate is kept when

* it is free in the (inflated, laser-marked) planning grid and in the robot's connected free region
  (a flood fill of the grid from the robot, :func:`reachable_region`);
* it satisfies **the reach rule** of :mod:`bimbot.shared.robot_description` — the horizontal distance from
  it to the *nearest point* of the footprint is within ``reach_m`` (less ``reach_margin_m``), measured with
  the shared :func:`bimbot.shared.footprint.footprint_distance_m`, the code physics' check agrees with. A
  4 m slab or a 5 m wall is therefore reachable from anywhere along its edges;
* when the component occupies the robot's height band (a component lying in the yard, a column or wall
  being placed), the robot's body stays outside it: distance to the footprint ≥ ``body_clearance_m``. A
  component above the band (a beam at 3 m) may be approached from under its footprint.

A ground robot sets an **enclosing element** (a wall, a curtain wall and its panels, a window, a door, a
railing: :func:`sets_from_outside`) from **outside the structure's footprint** where it can, as machines do
on a site: a wall on the building's edge is set from outside, so the robot is not closed in by the walls and
the curtain wall that follow. A partition in the middle, with no free stand-point outside, is approached
from inside; so is every frame member (a column, a beam), which closes nothing in: its nearest side is the
short drive, and an outside stand-point across the frame was one the navigator could not reach (the demo's
edge columns went back twice so). After a failed drive the robot tries any side (the caller's choice).

A robot setting a component that blocks its band keeps **its way out**: among the stand-points, those from
which a way to its depot remains once the component stands (:func:`way_out_after`) come first: a partition
that closes a room is set from the side joined to the depot, not from inside the room it closes.

Among the candidates left, the best is the one nearest the footprint (most reach to spare), then nearest the
footprint's centre (the middle of a long side), then nearest the robot (a short drive): one weighted score.
Its yaw faces the footprint's centre (None when it stands on the centre). When there is none,
:func:`no_approach_reason` says why, with the numbers: ``unreachable`` when free stand-points exist but
the flood fill from the robot does not get there, else ``no_approach_pose``. Cost: one connected-component
labelling of the free grid and a vectorised filter of the window (~1–3 ms on a site grid at 0.1 m).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage

from bimbot.shared.footprint import Footprint
from bimbot.shared.occupancy_grid import OccupancyGrid, covered_cells, inflate, nearest_free_cell
from bimbot.shared.reasons import Reason, ReasonCode
from bimbot.shared.robot_description import DEFAULT_ROBOT
from bimbot.shared.site_plan import Rect

_log = logging.getLogger(__name__)

# the robots' A* steps diagonally only between two free orthogonal neighbours (it never cuts a corner), so
# the cells it can reach are those 4-connected: a gap two cells touch only at a corner is no way through
_FOUR = ndimage.generate_binary_structure(2, 1)


@dataclass(frozen=True)
class ApproachConfig:
    reach_m: float = DEFAULT_ROBOT.reach_m  # the robot type's reach (the executor passes its own type's)
    reach_margin_m: float = 0.1  # stay this much inside the reach (localisation error, goal tolerance)
    body_clearance_m: float = 0.7  # robot centre ↔ a band-blocking component's outline
    centre_weight: float = 0.1  # per metre from the footprint's centre, against 1 per metre from the outline
    robot_weight: float = 0.05  # per metre from the robot


@dataclass(frozen=True)
class Approach:
    """A pose to drive to: ``x_m, y_m, yaw_rad`` (yaw None: any heading will do)."""

    x_m: float
    y_m: float
    yaw_rad: float | None
    reach_distance_m: float  # horizontal distance to the nearest point of the footprint (the reach rule)

    @property
    def xy_m(self) -> tuple[float, float]:
        return (self.x_m, self.y_m)


def reachable_region(grid: OccupancyGrid, from_xy_m: ArrayLike) -> NDArray[np.bool_] | None:
    """Free cells 4-connected to ``from_xy_m`` (or to the free cell nearest it; the cells A* reaches from
    there), None if there are none."""
    free = ~grid.occupied
    labels, _ = ndimage.label(free, structure=_FOUR)
    rc = grid.world_to_cell(np.asarray(from_xy_m, float))
    if not (grid.in_bounds(rc) and free[rc[0], rc[1]]):
        near = nearest_free_cell(grid, from_xy_m, max_distance_m=3.0)
        if near is None:
            return None
        rc = np.array(near)
    return labels == labels[rc[0], rc[1]]


def cut_off(grid: OccupancyGrid, from_xy_m: ArrayLike, to_xy_m: ArrayLike) -> bool:
    """Whether no way on ``grid`` leads from ``from_xy_m`` to ``to_xy_m`` (each from the free cell nearest
    it, as :func:`reachable_region`): a robot walled in, when ``to_xy_m`` is its depot start."""
    region = reachable_region(grid, from_xy_m)
    goal = reachable_region(grid, to_xy_m)
    return region is None or goal is None or not (region & goal).any()


def stand_points(
    grid: OccupancyGrid, footprint: Footprint, *, blocks_band: bool, config: ApproachConfig
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Cells ``(n, 2)`` free in ``grid`` from which the robot reaches ``footprint`` with its body clear,
    and their distances to the footprint (m), whether or not the robot can drive there."""
    reach = config.reach_m - config.reach_margin_m
    poly = footprint.polygon_xy_m
    rc_low = grid.world_to_cell(poly.min(axis=0) - reach)
    rc_high = grid.world_to_cell(poly.max(axis=0) + reach)
    rows, cols = grid.shape
    r0, r1 = max(0, int(rc_low[0])), min(rows, int(rc_high[0]) + 1)
    c0, c1 = max(0, int(rc_low[1])), min(cols, int(rc_high[1]) + 1)
    if r0 >= r1 or c0 >= c1:
        return np.empty((0, 2), np.int64), np.empty(0)
    cells = np.argwhere(~grid.occupied[r0:r1, c0:c1]) + np.array([r0, c0])
    distance = footprint.distance_m(grid.cell_to_world(cells)) if len(cells) else np.empty(0)
    keep = distance <= reach + 1e-9
    if blocks_band:
        keep &= distance >= config.body_clearance_m
    return cells[keep], distance[keep]


def within_reach(
    footprint: Footprint, robot_xy_m: ArrayLike, *, blocks_band: bool, config: ApproachConfig
) -> bool:
    """Whether a robot standing at ``robot_xy_m`` may act on ``footprint`` from there: the reach rule
    (less the margin) and, for a component in the robot's height band, its body clear of it. A robot that
    could not get onto its chosen stand-point but stands within reach has arrived all the same."""
    distance = float(footprint.distance_m(np.asarray(robot_xy_m, float)[:2])[0])
    if distance > config.reach_m - config.reach_margin_m + 1e-9:
        return False
    return not blocks_band or distance >= config.body_clearance_m


ENCLOSING_CLASSES = frozenset(
    {
        "IfcWall",
        "IfcWallStandardCase",
        "IfcWallElementedCase",
        "IfcCurtainWall",
        "IfcPlate",
        "IfcWindow",
        "IfcDoor",
        "IfcRailing",
    }
)


def sets_from_outside(ifc_class: str) -> bool:
    """Whether a ground robot sets a component of ``ifc_class`` from outside the structure where it can:
    the elements that close the building in (see the module doc)."""
    return ifc_class in ENCLOSING_CLASSES


def approach_pose(
    grid: OccupancyGrid,
    footprint: Footprint,
    robot_xy_m: ArrayLike,
    *,
    blocks_band: bool,
    config: ApproachConfig = ApproachConfig(),
    region: NDArray[np.bool_] | None = None,
    avoid_xy_m: ArrayLike = (),
    avoid_radius_m: float = 1.0,
    outside_of: Rect | None = None,
    way_out: NDArray[np.bool_] | None = None,
) -> Approach | None:
    """The best approach pose beside ``footprint`` (see the module doc), or None when there is none.

    ``grid`` is the inflated planning grid; ``region`` the robot's reachable free cells (computed from
    ``robot_xy_m`` when not given). Candidates within ``avoid_radius_m`` of a point of ``avoid_xy_m``
    (stand-points that failed already) are left out, so a re-chosen approach tries another side. With
    ``outside_of`` (the structure's footprint), only the candidates outside it count while there are any;
    so with ``way_out`` (cells from which the robot can still leave, :func:`way_out_after`).
    """
    if region is None:
        region = reachable_region(grid, robot_xy_m)
        if region is None:
            _log.info("robot at %s has no free cell near it", np.asarray(robot_xy_m).tolist())
            return None
    cells, distance = stand_points(grid, footprint, blocks_band=blocks_band, config=config)
    inside = region[cells[:, 0], cells[:, 1]] if len(cells) else np.zeros(0, bool)
    cells, distance = cells[inside], distance[inside]
    if way_out is not None and len(cells):
        leaves = way_out[cells[:, 0], cells[:, 1]]
        if leaves.any():
            cells, distance = cells[leaves], distance[leaves]
    xy = grid.cell_to_world(cells) if len(cells) else np.empty((0, 2))
    avoid = np.asarray(avoid_xy_m, float).reshape(-1, 2)
    if len(avoid) and len(xy):
        far = np.hypot(xy[:, None, 0] - avoid[None, :, 0], xy[:, None, 1] - avoid[None, :, 1]).min(axis=1)
        xy, distance = xy[far > avoid_radius_m], distance[far > avoid_radius_m]
    if outside_of is not None and len(xy):
        (x0, y0), (x1, y1) = outside_of.min_xy, outside_of.max_xy
        out = (xy[:, 0] <= x0) | (xy[:, 0] >= x1) | (xy[:, 1] <= y0) | (xy[:, 1] >= y1)
        if out.any():
            xy, distance = xy[out], distance[out]
    if len(xy) == 0:
        _log.info("no free approach within %.2f m of %s", config.reach_m, _where(footprint))
        return None
    centre = footprint.centre_xy_m
    to_centre = np.hypot(*(xy - centre).T)
    score = (
        distance
        + config.centre_weight * to_centre
        + config.robot_weight * np.hypot(*(xy - np.asarray(robot_xy_m, float)).T)
    )
    best = int(np.argmin(score))
    x, y = float(xy[best, 0]), float(xy[best, 1])
    yaw = math.atan2(centre[1] - y, centre[0] - x) if to_centre[best] > 0.2 else None
    return Approach(x, y, yaw, float(distance[best]))


def way_out_after(
    grid: OccupancyGrid,
    outlines_xy_m: Sequence[NDArray[np.float64]],
    home_xy_m: ArrayLike,
    inflation_m: float,
) -> NDArray[np.bool_] | None:
    """The free cells of ``grid`` (the inflated planning grid) still joined to ``home_xy_m`` once a
    component of these outlines stands, as the robot's map will have it: the outlines rasterised on the
    same grid and inflated by the robot's ``inflation_m``, as the navigator plans. A stand-point in the
    component's inflation, or in a pocket whose way out it narrows below the robot's inflated width, keeps
    none. None when the home has no free cell."""
    cells = covered_cells(grid, list(outlines_xy_m))
    occupied = grid.occupied.copy()
    if len(cells):
        pad = math.ceil(inflation_m / grid.resolution_m) + 1
        r0, c0 = (max(0, int(v) - pad) for v in cells.min(axis=0))
        r1, c1 = (min(n, int(v) + pad + 1) for v, n in zip(cells.max(axis=0), grid.shape, strict=True))
        window = np.zeros((r1 - r0, c1 - c0), bool)
        window[cells[:, 0] - r0, cells[:, 1] - c0] = True
        grown = inflate(OccupancyGrid(window, grid.resolution_m, (0.0, 0.0)), inflation_m)
        occupied[r0:r1, c0:c1] |= grown.occupied
    return reachable_region(grid.with_occupied(occupied), home_xy_m)


def no_approach_reason(
    grid: OccupancyGrid,
    footprint: Footprint,
    robot_xy_m: ArrayLike,
    *,
    blocks_band: bool,
    config: ApproachConfig,
    what: str,
    robot: str = "the robot",
    radius_m: float | None = None,
    home_xy_m: ArrayLike | None = None,
) -> Reason:
    """Why :func:`approach_pose` found nothing beside ``footprint`` (``what``: "the target of Column R1"):
    ``unreachable`` when free stand-points exist but the flood fill of ``grid`` from the robot does not
    reach them — ``robot_trapped`` instead when the robot is cut off from its depot start ``home_xy_m``
    itself (walled in: the robot's problem, not the component's) — else ``no_approach_pose``; each a
    sentence with the numbers."""
    cells, _ = stand_points(grid, footprint, blocks_band=blocks_band, config=config)
    x, y = (float(v) for v in np.asarray(robot_xy_m, float)[:2])
    here = f"({x:.2f}, {y:.2f})"
    reach = config.reach_m - config.reach_margin_m
    if len(cells):
        region = reachable_region(grid, robot_xy_m)
        cut_off = region is None or not region[cells[:, 0], cells[:, 1]].any()
        home = reachable_region(grid, home_xy_m) if home_xy_m is not None and region is not None else None
        if cut_off and home is not None and region is not None and not (home & region).any():
            hx, hy = (float(v) for v in np.asarray(home_xy_m, float)[:2])
            return Reason(
                code=ReasonCode.ROBOT_TRAPPED,
                message=(
                    f"{robot} at {here} is walled in: no way on the planning grid (cells of "
                    f"{grid.resolution_m:.2f} m) leads from it to its depot start ({hx:.2f}, {hy:.2f}), "
                    f"nor to a stand-point of {what} ({_where(footprint)})"
                ),
            )
        if cut_off:
            return Reason(
                code=ReasonCode.UNREACHABLE,
                message=(
                    f"{what} ({_where(footprint)}) is cut off from {robot} at {here}: none of its "
                    f"{len(cells)} free stand-points within {reach:.2f} m is connected to the robot on the "
                    f"planning grid (cells of {grid.resolution_m:.2f} m)"
                ),
            )
    body = f"{radius_m:.2f} m" if radius_m is not None else "its"
    clear = f", {config.body_clearance_m:.2f} m clear of it," if blocks_band else ""
    return Reason(
        code=ReasonCode.NO_APPROACH_POSE,
        message=(
            f"no free cell within {reach:.2f} m of {what} ({_where(footprint)}){clear} holds {robot} "
            f"(footprint radius {body}, reach {config.reach_m:.2f} m)"
        ),
    )


def _where(footprint: Footprint) -> str:
    """``4.00 m × 3.00 m at (1.20, -3.40)``: a footprint's size and centre for a log line or a reason."""
    poly = footprint.polygon_xy_m
    if len(poly) == 4:
        sides = np.hypot(*(np.roll(poly, -1, axis=0) - poly).T)
        length, width = max(sides[0], sides[1]), min(sides[0], sides[1])
    else:
        length, width = sorted(poly.max(axis=0) - poly.min(axis=0), reverse=True)
    x, y = footprint.centre_xy_m
    return f"{length:.2f} m × {width:.2f} m at ({x:.2f}, {y:.2f})"


def exit_point(grid: OccupancyGrid, area: Rect, robot_xy_m: ArrayLike) -> tuple[float, float] | None:
    """The nearest free cell outside ``area`` (the structure's footprint, grown) the robot can drive to,
    or None when it stands outside already (or nothing outside is reachable)."""
    here = np.asarray(robot_xy_m, float)
    (x0, y0), (x1, y1) = area.min_xy, area.max_xy
    if not (x0 < here[0] < x1 and y0 < here[1] < y1):
        return None
    region = reachable_region(grid, here)
    if region is None:
        return None
    return _nearest_outside(grid, region, area, here)


def _nearest_outside(
    grid: OccupancyGrid, region: NDArray[np.bool_], area: Rect, here: NDArray[np.float64]
) -> tuple[float, float] | None:
    """The cell of ``region`` outside ``area`` nearest ``here``, the first in row-major order among equals:
    searched in squares of cells round ``here``, doubled until the best in the square lies nearer than
    anything beyond it can (on a site of a thousand components, a pass over every reachable cell took a
    tenth of a second after every task)."""
    (x0, y0), (x1, y1) = area.min_xy, area.max_xy
    rows, cols = region.shape
    row, col = (int(index) for index in grid.world_to_cell(here))
    half = max(8, int(min(here[0] - x0, x1 - here[0], here[1] - y0, y1 - here[1]) / grid.resolution_m) + 2)
    while True:
        r0, r1 = max(0, row - half), min(rows, row + half + 1)
        c0, c1 = max(0, col - half), min(cols, col + half + 1)
        whole = r0 == 0 and c0 == 0 and r1 == rows and c1 == cols
        cells = np.argwhere(region[r0:r1, c0:c1]) + np.array([r0, c0])
        xy = grid.cell_to_world(cells)
        outside = (xy[:, 0] <= x0) | (xy[:, 0] >= x1) | (xy[:, 1] <= y0) | (xy[:, 1] >= y1)
        if outside.any():
            xy = xy[outside]
            distances = np.hypot(*(xy - here).T)
            best = int(np.argmin(distances))
            # a cell beyond the square is more than `half` cells away along a row or a column
            if whole or distances[best] < half * grid.resolution_m:
                return float(xy[best][0]), float(xy[best][1])
        if whole:
            return None
        half *= 2
