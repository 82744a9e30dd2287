"""A robot done inside the structure leaves it for the nearest free cell outside that it can drive to. The
search looks round the robot in growing squares instead of over every reachable cell of the site; it must
give exactly the cell a pass over the whole region gives, the first in row-major order among equals."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.typing import NDArray

from bimbot.services.robot.approach import exit_point, reachable_region
from bimbot.shared.occupancy_grid import OccupancyGrid
from bimbot.shared.site_plan import Rect


def _whole_region_answer(
    grid: OccupancyGrid, area: Rect, here: NDArray[np.float64]
) -> tuple[float, float] | None:
    """The reference: every reachable cell outside ``area``, the nearest (first among equals)."""
    region = reachable_region(grid, here)
    if region is None:
        return None
    (x0, y0), (x1, y1) = area.min_xy, area.max_xy
    xy = grid.cell_to_world(np.argwhere(region))
    outside = (xy[:, 0] <= x0) | (xy[:, 0] >= x1) | (xy[:, 1] <= y0) | (xy[:, 1] >= y1)
    if not outside.any():
        return None
    xy = xy[outside]
    best = xy[int(np.argmin(np.hypot(*(xy - here).T)))]
    return float(best[0]), float(best[1])


def test_the_nearest_exit_is_the_one_a_search_of_the_whole_site_finds() -> None:
    rng = np.random.default_rng(7)
    found = 0
    for case in range(300):
        rows, cols = rng.integers(20, 160, size=2)
        occupied = rng.random((rows, cols)) < rng.uniform(0.0, 0.45)
        grid = OccupancyGrid(occupied, 0.1, (-3.0, 2.0))
        x_min, y_min, x_max, y_max = grid.bounds_xy_m
        xs = np.sort(rng.uniform(x_min, x_max, size=2))
        ys = np.sort(rng.uniform(y_min, y_max, size=2))
        area = Rect((float(xs[0]), float(ys[0])), (float(xs[1]), float(ys[1])))
        if case % 3 == 0:  # cell borders and centres: ties between equally near cells
            here = np.array([xs.mean(), ys.mean()]).round(1)
        else:
            here = np.array([rng.uniform(xs[0], xs[1]), rng.uniform(ys[0], ys[1])])
        expected = (
            _whole_region_answer(grid, area, here) if area.min_xy[0] < here[0] < area.max_xy[0] else None
        )
        answer = exit_point(grid, area, here)
        if not (area.min_xy[0] < here[0] < area.max_xy[0] and area.min_xy[1] < here[1] < area.max_xy[1]):
            expected = None
        assert answer == expected, (case, answer, expected)
        found += answer is not None
    assert found > 150  # most cases have an exit: the comparison is not of Nones


def test_a_robot_outside_the_area_or_walled_in_has_no_exit() -> None:
    occupied = np.zeros((50, 50), dtype=bool)
    occupied[20:31, 20] = occupied[20:31, 30] = occupied[20, 20:31] = occupied[30, 20:31] = True
    grid = OccupancyGrid(occupied, 0.1, (0.0, 0.0))
    area = Rect((1.0, 1.0), (4.0, 4.0))
    assert exit_point(grid, area, (0.5, 0.5)) is None  # outside already
    assert exit_point(grid, area, (2.55, 2.55)) is None  # walled in: nothing outside reachable
    assert exit_point(grid, Rect((1.8, 1.8), (3.4, 3.4)), (2.55, 2.55)) is None
    assert exit_point(grid, Rect((2.2, 2.2), (2.8, 2.8)), (2.55, 2.55)) == pytest.approx((2.85, 2.55))
