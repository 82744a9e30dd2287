"""2D occupancy grid of the yard: rasterised footprints, laser marking, inflation and free-pose queries.

Why: the global planner (A*), the local planner and the localiser all work on one metric grid built from
the 2D footprints of what stands in the world (stacked components, the built structure, other robots), like
the costmap of ROS move_base. Everything here is pure: functions take a grid and return a new one.

Conventions: world frame Z-up, x right / y up, metres and radians. ``occupied`` is indexed
``[row, col]`` = ``[y, x]``; cell ``(0, 0)`` has its lower-left corner at ``origin_xy_m`` and covers
``[x0, x0 + resolution_m) × [y0, y0 + resolution_m)``. Cell centres are the world points of a cell.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage

logger = logging.getLogger(__name__)

BoundsXY = tuple[float, float, float, float]
"""Axis-aligned world bounds ``(x_min_m, y_min_m, x_max_m, y_max_m)``."""

_EPS_CELLS = 1e-9  # tolerance when a coordinate falls exactly on a cell border


@dataclass(frozen=True, eq=False)
class OccupancyGrid:
    """Immutable boolean occupancy grid (True = occupied), indexed ``[row=y, col=x]``."""

    occupied: NDArray[np.bool_]
    resolution_m: float
    origin_xy_m: tuple[float, float]

    def __post_init__(self) -> None:
        cells = np.array(self.occupied, dtype=bool, copy=True)
        if cells.ndim != 2:
            raise ValueError(f"occupied must be 2D, got shape {cells.shape}")
        if not self.resolution_m > 0:
            raise ValueError(f"resolution_m must be > 0, got {self.resolution_m}")
        cells.setflags(write=False)
        object.__setattr__(self, "occupied", cells)
        object.__setattr__(self, "resolution_m", float(self.resolution_m))
        object.__setattr__(self, "origin_xy_m", (float(self.origin_xy_m[0]), float(self.origin_xy_m[1])))

    @property
    def shape(self) -> tuple[int, int]:
        """``(rows, cols)`` = ``(height_cells, width_cells)``."""
        return self.occupied.shape

    @property
    def bounds_xy_m(self) -> BoundsXY:
        """World bounds covered by the grid."""
        rows, cols = self.shape
        x0, y0 = self.origin_xy_m
        return (x0, y0, x0 + cols * self.resolution_m, y0 + rows * self.resolution_m)

    def world_to_cell(self, xy_m: ArrayLike) -> NDArray[np.int64]:
        """World points ``(n, 2)`` or ``(2,)`` → cell indices ``[row, col]`` (may lie outside the grid)."""
        xy = np.asarray(xy_m, dtype=float)
        origin = np.asarray(self.origin_xy_m)
        col_row = np.floor((xy - origin) / self.resolution_m + _EPS_CELLS).astype(np.int64)
        return col_row[..., ::-1]

    def cell_to_world(self, rows_cols: ArrayLike) -> NDArray[np.float64]:
        """Cell indices ``[row, col]`` ``(n, 2)`` or ``(2,)`` → world xy of the cell centres."""
        rc = np.asarray(rows_cols, dtype=float)
        return np.asarray(self.origin_xy_m) + (rc[..., ::-1] + 0.5) * self.resolution_m

    def in_bounds(self, rows_cols: ArrayLike) -> NDArray[np.bool_]:
        """Whether cell indices ``[row, col]`` lie inside the grid."""
        rc = np.asarray(rows_cols)
        rows, cols = self.shape
        return (rc[..., 0] >= 0) & (rc[..., 0] < rows) & (rc[..., 1] >= 0) & (rc[..., 1] < cols)

    def is_free_xy(self, xy_m: ArrayLike) -> NDArray[np.bool_]:
        """Vectorised: True where a world point lies in a free cell (outside the grid counts as not free)."""
        rc = self.world_to_cell(xy_m)
        inside = self.in_bounds(rc)
        free = np.zeros(rc.shape[:-1], dtype=bool)
        rows = np.where(inside, rc[..., 0], 0)
        cols = np.where(inside, rc[..., 1], 0)
        free[...] = inside & ~self.occupied[rows, cols]
        return free

    def is_free(self, x_m: float, y_m: float) -> bool:
        """True when the world point lies inside the grid in a free cell."""
        return bool(self.is_free_xy((x_m, y_m)))

    def with_occupied(self, occupied: NDArray[np.bool_]) -> OccupancyGrid:
        """A grid with the same geometry and new cells."""
        return OccupancyGrid(occupied, self.resolution_m, self.origin_xy_m)


def empty_grid(bounds_xy_m: BoundsXY, resolution_m: float) -> OccupancyGrid:
    """An all-free grid covering ``bounds_xy_m`` (rounded up to whole cells)."""
    x_min, y_min, x_max, y_max = bounds_xy_m
    if x_max <= x_min or y_max <= y_min:
        raise ValueError(f"empty bounds {bounds_xy_m}")
    cols = math.ceil((x_max - x_min) / resolution_m - _EPS_CELLS)
    rows = math.ceil((y_max - y_min) / resolution_m - _EPS_CELLS)
    return OccupancyGrid(np.zeros((rows, cols), dtype=bool), resolution_m, (x_min, y_min))


def _box_cell_ranges(grid: OccupancyGrid, box_xy_m: Sequence[float]) -> tuple[int, int, int, int] | None:
    """Half-open ``(row0, row1, col0, col1)`` of cells overlapping the box with positive area, clipped."""
    x_min, y_min, x_max, y_max = (float(v) for v in box_xy_m)
    x0, y0 = grid.origin_xy_m
    res = grid.resolution_m
    col0 = math.floor((x_min - x0) / res + _EPS_CELLS)
    col1 = math.ceil((x_max - x0) / res - _EPS_CELLS)
    row0 = math.floor((y_min - y0) / res + _EPS_CELLS)
    row1 = math.ceil((y_max - y0) / res - _EPS_CELLS)
    rows, cols = grid.shape
    row0, row1 = max(row0, 0), min(row1, rows)
    col0, col1 = max(col0, 0), min(col1, cols)
    if row0 >= row1 or col0 >= col1:
        return None
    return row0, row1, col0, col1


def _points_in_polygon(points_xy: NDArray[np.float64], polygon_xy: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Even-odd rule point-in-polygon test, vectorised over points."""
    inside = np.zeros(len(points_xy), dtype=bool)
    px, py = points_xy[:, 0], points_xy[:, 1]
    for (ax, ay), (bx, by) in zip(polygon_xy, np.roll(polygon_xy, -1, axis=0), strict=True):
        crosses = (ay > py) != (by > py)
        with np.errstate(divide="ignore", invalid="ignore"):
            x_cross = ax + (py - ay) * (bx - ax) / (by - ay)
        inside ^= crosses & (px < x_cross)
    return inside


def _rasterise_polygon(
    grid: OccupancyGrid, cells: NDArray[np.bool_], polygon_xy: NDArray[np.float64]
) -> None:
    """Mark cells whose centre is inside the polygon, plus every cell its outline passes through."""
    x_min, y_min = polygon_xy.min(axis=0)
    x_max, y_max = polygon_xy.max(axis=0)
    ranges = _box_cell_ranges(grid, (x_min, y_min, x_max, y_max))
    if ranges is None:
        return
    row0, row1, col0, col1 = ranges
    rr, cc = np.mgrid[row0:row1, col0:col1]
    rc = np.stack([rr.ravel(), cc.ravel()], axis=1)
    inside = _points_in_polygon(grid.cell_to_world(rc), polygon_xy)
    cells[rc[inside, 0], rc[inside, 1]] = True
    # Outline sampled at a quarter cell so thin or small polygons are never lost (conservative).
    ends = np.roll(polygon_xy, -1, axis=0)
    for a, b in zip(polygon_xy, ends, strict=True):
        n = max(2, math.ceil(float(np.hypot(*(b - a))) / (grid.resolution_m / 4)) + 1)
        samples = a + np.linspace(0.0, 1.0, n)[:, None] * (b - a)
        src = grid.world_to_cell(samples)
        src = src[grid.in_bounds(src)]
        cells[src[:, 0], src[:, 1]] = True


def from_footprints(
    bounds_xy_m: BoundsXY,
    resolution_m: float,
    *,
    boxes_xy_m: Sequence[Sequence[float]] = (),
    polygons_xy_m: Sequence[ArrayLike] = (),
) -> OccupancyGrid:
    """Rasterise obstacle footprints onto a new grid.

    ``boxes_xy_m`` are axis-aligned ``(x_min, y_min, x_max, y_max)``: every cell they overlap with positive
    area is occupied. ``polygons_xy_m`` are ``(k, 2)`` outlines (any orientation, e.g. a rotated component
    footprint): cells whose centre lies inside, and cells crossed by the outline, are occupied.
    """
    grid = empty_grid(bounds_xy_m, resolution_m)
    cells = np.zeros(grid.shape, dtype=bool)
    for box in boxes_xy_m:
        ranges = _box_cell_ranges(grid, box)
        if ranges is not None:
            row0, row1, col0, col1 = ranges
            cells[row0:row1, col0:col1] = True
    for polygon in polygons_xy_m:
        poly = np.asarray(polygon, dtype=float)
        if poly.ndim != 2 or poly.shape[0] < 3 or poly.shape[1] != 2:
            raise ValueError(f"polygon must be (k>=3, 2), got {poly.shape}")
        _rasterise_polygon(grid, cells, poly)
    logger.debug("rasterised %d boxes, %d polygons", len(boxes_xy_m), len(polygons_xy_m))
    return grid.with_occupied(cells)


def covered_cells(grid: OccupancyGrid, polygons_xy_m: Sequence[NDArray[np.float64]]) -> NDArray[np.int64]:
    """Cells ``[row, col]`` ``(n, 2)`` of ``grid`` the polygons cover together (each cell once), rasterised
    on a window around them, not the whole grid (a component's outline, or its parts' outlines)."""
    if not polygons_xy_m:
        return np.zeros((0, 2), np.int64)
    points = np.concatenate(polygons_xy_m)
    low = grid.world_to_cell(points.min(axis=0)) - 1
    high = grid.world_to_cell(points.max(axis=0)) + 2
    rows, cols = grid.shape
    r0, c0 = max(0, int(low[0])), max(0, int(low[1]))
    r1, c1 = min(rows, int(high[0])), min(cols, int(high[1]))
    if r0 >= r1 or c0 >= c1:
        return np.zeros((0, 2), np.int64)
    res = grid.resolution_m
    x0, y0 = grid.origin_xy_m[0] + c0 * res, grid.origin_xy_m[1] + r0 * res
    window = from_footprints(
        (x0, y0, x0 + (c1 - c0) * res, y0 + (r1 - r0) * res), res, polygons_xy_m=polygons_xy_m
    )
    return np.argwhere(window.occupied[: r1 - r0, : c1 - c0]) + np.array([r0, c0])


def scan_endpoints_xy_m(
    pose_xy_yaw: ArrayLike, ranges_m: ArrayLike, angles_rad: ArrayLike, max_range_m: float
) -> NDArray[np.float64]:
    """World xy of the laser hits (beams with a finite range below ``max_range_m``), shape ``(k, 2)``."""
    x, y, yaw = (float(v) for v in np.asarray(pose_xy_yaw, dtype=float))
    ranges = np.asarray(ranges_m, dtype=float)
    angles = np.asarray(angles_rad, dtype=float)
    hit = np.isfinite(ranges) & (ranges < max_range_m) & (ranges > 0)
    r, a = ranges[hit], angles[hit] + yaw
    return np.stack([x + r * np.cos(a), y + r * np.sin(a)], axis=1)


def mark_scan(
    grid: OccupancyGrid,
    pose_xy_yaw: ArrayLike,
    ranges_m: ArrayLike,
    angles_rad: ArrayLike,
    max_range_m: float,
) -> OccupancyGrid:
    """A grid with the cells of the laser hits marked occupied (beam angles in the robot frame)."""
    hits = scan_endpoints_xy_m(pose_xy_yaw, ranges_m, angles_rad, max_range_m)
    rc = grid.world_to_cell(hits)
    rc = rc[grid.in_bounds(rc)]
    cells = grid.occupied.copy()
    cells[rc[:, 0], rc[:, 1]] = True
    return grid.with_occupied(cells)


def distance_field_m(grid: OccupancyGrid) -> NDArray[np.float64]:
    """Distance in metres from every cell centre to the nearest occupied cell centre (inf if none)."""
    if not grid.occupied.any():
        return np.full(grid.shape, np.inf)
    return ndimage.distance_transform_edt(~grid.occupied, sampling=grid.resolution_m)


def inflate(grid: OccupancyGrid, radius_m: float) -> OccupancyGrid:
    """Occupy every cell whose centre lies within ``radius_m`` of an occupied cell centre.

    Uses an exact Euclidean distance transform, so the inflated shape is the disc dilation of the obstacles.
    """
    if radius_m < 0:
        raise ValueError(f"radius_m must be >= 0, got {radius_m}")
    if radius_m == 0 or not grid.occupied.any():
        return grid
    inflated = distance_field_m(grid) <= radius_m + _EPS_CELLS * grid.resolution_m
    return grid.with_occupied(inflated)


def nearest_free_cell(
    grid: OccupancyGrid, point_xy_m: ArrayLike, max_distance_m: float | None = None
) -> tuple[int, int] | None:
    """``(row, col)`` of the free cell whose centre is nearest to a world point, or None.

    Searches growing square windows around the point, so the cost depends on how far the nearest free cell
    is, not on the grid size. Points outside the grid are handled (the nearest in-grid free cell is found).
    """
    rows, cols = grid.shape
    res = grid.resolution_m
    point = np.asarray(point_xy_m, dtype=float)
    row_c, col_c = (int(v) for v in grid.world_to_cell(point))
    limit_m = max_distance_m if max_distance_m is not None else math.inf
    whole_grid = (0, rows, 0, cols)
    half = 2
    while True:
        window = (
            max(row_c - half, 0),
            min(row_c + half + 1, rows),
            max(col_c - half, 0),
            min(col_c + half + 1, cols),
        )
        row0, row1, col0, col1 = window
        if row0 < row1 and col0 < col1:
            free_r, free_c = np.nonzero(~grid.occupied[row0:row1, col0:col1])
            if free_r.size:
                rc = np.stack([free_r + row0, free_c + col0], axis=1)
                d_m = np.hypot(*(grid.cell_to_world(rc) - point).T)
                best = int(np.argmin(d_m))
                # Every cell outside the window is more than (half + 0.5) cells from the point.
                if d_m[best] <= (half + 0.5) * res or window == whole_grid:
                    return (int(rc[best, 0]), int(rc[best, 1])) if d_m[best] <= limit_m else None
            elif window == whole_grid:
                return None
        if (half + 0.5) * res > limit_m:
            return None
        half *= 2


def free_approach_pose(
    grid: OccupancyGrid,
    target_xy_m: ArrayLike,
    standoff_m: float,
    *,
    preferred_xy_m: ArrayLike | None = None,
    n_candidates: int = 72,
) -> tuple[float, float, float] | None:
    """A free pose ``(x_m, y_m, yaw_rad)`` at ``standoff_m`` from the target, facing the target, or None.

    Candidates are spread on the circle of radius ``standoff_m`` around the target; among the free ones the
    one nearest ``preferred_xy_m`` (e.g. the robot's position) is returned, else the first free one
    counter-clockwise from +x. Use an inflated grid so the robot body fits at the pose.
    """
    if standoff_m <= 0:
        raise ValueError(f"standoff_m must be > 0, got {standoff_m}")
    target = np.asarray(target_xy_m, dtype=float)
    angles = np.linspace(0.0, 2 * math.pi, n_candidates, endpoint=False)
    candidates = target + standoff_m * np.stack([np.cos(angles), np.sin(angles)], axis=1)
    free = grid.is_free_xy(candidates)
    if not free.any():
        logger.info("no free approach pose at %.2f m around %s", standoff_m, target.tolist())
        return None
    options = candidates[free]
    if preferred_xy_m is None:
        best = options[0]
    else:
        best = options[int(np.argmin(np.hypot(*(options - np.asarray(preferred_xy_m, float)).T)))]
    yaw = math.atan2(target[1] - best[1], target[0] - best[0])
    return float(best[0]), float(best[1]), yaw
