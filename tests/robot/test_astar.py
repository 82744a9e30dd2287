"""A* global planner: optimal octile paths, no corner cutting, clear failures, path pruning."""

from __future__ import annotations

import heapq
import itertools
import math

import numpy as np
import pytest

from bimbot.services.robot import astar
from bimbot.services.robot.astar import (
    astar_cells,
    path_cost_cells,
    plan_path,
    segment_is_free,
    simplify_path,
)
from bimbot.shared.occupancy_grid import OccupancyGrid, from_footprints, inflate

SQRT2 = math.sqrt(2.0)


def reference_cost(free: np.ndarray, start: tuple[int, int], goal: tuple[int, int]) -> float:
    """Pure-Python Dijkstra: octile costs, 8-connected, diagonal only if both orthogonal cells are free."""
    rows, cols = free.shape
    best = {start: 0.0}
    queue = [(0.0, start)]
    while queue:
        cost, (r, c) = heapq.heappop(queue)
        if (r, c) == goal:
            return cost
        if cost > best[(r, c)]:
            continue
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                nr, nc = r + dr, c + dc
                if (dr, dc) == (0, 0) or not (0 <= nr < rows and 0 <= nc < cols) or not free[nr, nc]:
                    continue
                if dr and dc and not (free[r + dr, c] and free[r, c + dc]):
                    continue
                new = cost + (SQRT2 if dr and dc else 1.0)
                if new < best.get((nr, nc), math.inf):
                    best[(nr, nc)] = new
                    heapq.heappush(queue, (new, (nr, nc)))
    return math.inf


def assert_valid_cell_path(free: np.ndarray, path: np.ndarray, start: tuple, goal: tuple) -> None:
    assert tuple(path[0]) == start and tuple(path[-1]) == goal
    assert free[path[:, 0], path[:, 1]].all(), "path enters an occupied cell"
    steps = np.diff(path, axis=0)
    assert (np.abs(steps).max(axis=1) == 1).all(), "path jumps or repeats a cell"
    for (r, c), (dr, dc) in zip(path[:-1], steps, strict=False):
        if dr and dc:
            assert free[r + dr, c] and free[r, c + dc], f"corner cut at {(r, c)} → {(r + dr, c + dc)}"


def test_open_grid_paths_have_hand_checked_octile_costs() -> None:
    free = np.ones((5, 5), bool)
    assert path_cost_cells(astar_cells(free, (0, 0), (4, 4))) == pytest.approx(4 * SQRT2)
    assert path_cost_cells(astar_cells(free, (0, 0), (0, 4))) == pytest.approx(4.0)
    assert path_cost_cells(astar_cells(free, (0, 0), (2, 4))) == pytest.approx(2 * SQRT2 + 2)


def test_diagonal_move_past_an_occupied_corner_is_not_allowed() -> None:
    free = np.ones((3, 3), bool)
    free[0, 1] = False
    path = astar_cells(free, (0, 0), (1, 1))
    assert path_cost_cells(path) == pytest.approx(2.0)  # around via (1, 0), not the √2 diagonal
    assert_valid_cell_path(free, path, (0, 0), (1, 1))


def test_wall_with_gap_forces_hand_checked_detour() -> None:
    free = np.ones((7, 7), bool)
    free[0:6, 3] = False  # wall in column 3, gap at row 6
    path = astar_cells(free, (0, 0), (0, 6))
    # (0,0)→(6,2): 2 diagonals + 4 straight; (6,2)→(6,4): 2 straight; (6,4)→(0,6): 2 diagonals + 4 straight
    assert path_cost_cells(path) == pytest.approx(10 + 4 * SQRT2)
    assert reference_cost(free, (0, 0), (0, 6)) == pytest.approx(10 + 4 * SQRT2)
    assert_valid_cell_path(free, path, (0, 0), (0, 6))


def test_random_grids_give_the_reference_optimal_cost() -> None:
    rng = np.random.default_rng(42)
    n_found = 0
    for trial in range(40):
        shape = (int(rng.integers(8, 40)), int(rng.integers(8, 40)))
        free = rng.random(shape) > rng.uniform(0.1, 0.4)
        cells = np.argwhere(free)
        start, goal = (tuple(int(v) for v in cells[i]) for i in rng.choice(len(cells), 2, replace=False))
        expected = reference_cost(free, start, goal)
        path = astar_cells(free, start, goal)
        if math.isinf(expected):
            assert path is None, f"trial {trial}: path found where none exists"
            continue
        n_found += 1
        assert path is not None, f"trial {trial}: no path found where one exists"
        assert_valid_cell_path(free, path, start, goal)
        assert path_cost_cells(path) == pytest.approx(expected, abs=1e-9), f"trial {trial}"
    assert n_found >= 20


def test_large_random_grid_cost_is_exactly_optimal() -> None:
    rng = np.random.default_rng(7)
    free = rng.random((150, 150)) > 0.3
    free[0, 0] = free[-1, -1] = True
    path = astar_cells(free, (0, 0), (149, 149))
    assert path is not None
    assert path_cost_cells(path) == pytest.approx(reference_cost(free, (0, 0), (149, 149)), abs=1e-9)


def test_path_cost_overflow_retries_with_wider_integers(monkeypatch: pytest.MonkeyPatch) -> None:
    free = np.ones((60, 60), bool)
    free[10:50, 30] = False
    narrow = ((np.int32, 30_000), *astar.COST_TYPES[1:])  # a limit that overflows after ~30 moves
    monkeypatch.setattr(astar, "COST_TYPES", narrow)
    path = astar.astar_cells(free, (30, 0), (30, 59))
    assert path_cost_cells(path) == pytest.approx(reference_cost(free, (30, 0), (30, 59)), abs=1e-9)


@pytest.fixture
def yard() -> OccupancyGrid:
    """10 m × 6 m yard at 5 cm with a wall across x=5 m (gap near the top) and a stack of components."""
    boxes = [(4.9, 0.0, 5.1, 4.5), (2.0, 1.0, 3.0, 2.0)]
    return from_footprints((0.0, 0.0, 10.0, 6.0), 0.05, boxes_xy_m=boxes)


def test_world_plan_stays_out_of_inflated_cells_and_reports_metric_cost(yard: OccupancyGrid) -> None:
    inflated = inflate(yard, 0.4)
    result = plan_path(inflated, (1.0, 1.0), (9.0, 1.0))
    assert result.found and result.reason == "ok"
    assert not inflated.occupied[result.path_cells[:, 0], result.path_cells[:, 1]].any()
    np.testing.assert_allclose(result.path_xy_m[[0, -1]], [[1.0, 1.0], [9.0, 1.0]])
    assert result.path_xy_m[:, 1].max() > 4.9  # detours through the gap above the wall
    assert result.cost_m == pytest.approx(path_cost_cells(result.path_cells) * 0.05)


def test_walled_off_goal_gives_no_path_result(yard: OccupancyGrid) -> None:
    pen = from_footprints(
        (0.0, 0.0, 10.0, 6.0),
        0.05,
        boxes_xy_m=[(7.0, 2.0, 9.0, 2.2), (7.0, 3.8, 9.0, 4.0), (7.0, 2.0, 7.2, 4.0), (8.8, 2.0, 9.0, 4.0)],
    )
    result = plan_path(pen, (1.0, 1.0), (8.0, 3.0))
    assert not result.found
    assert "no path" in result.reason
    assert len(result.path_xy_m) == 0 and math.isinf(result.cost_m)


@pytest.mark.parametrize(
    ("start", "goal", "word"),
    [
        ((5.0, 1.0), (9.0, 1.0), "start"),  # start inside the wall
        ((1.0, 1.0), (2.5, 1.5), "goal"),  # goal inside the stack
        ((-1.0, 1.0), (9.0, 1.0), "outside"),
        ((1.0, 1.0), (9.0, 7.0), "outside"),
    ],
)
def test_start_or_goal_off_grid_or_in_obstacle_gives_clear_result(
    yard: OccupancyGrid, start: tuple, goal: tuple, word: str
) -> None:
    result = plan_path(yard, start, goal)
    assert not result.found
    assert word in result.reason


def test_goal_in_obstacle_can_be_snapped_to_nearest_free_cell(yard: OccupancyGrid) -> None:
    result = plan_path(yard, (1.0, 1.0), (2.1, 1.5), snap_goal_to_free=True, max_snap_m=0.5)
    assert result.found and result.goal_snapped
    assert result.path_xy_m[-1][0] < 2.0  # just left of the stack
    assert yard.is_free(*result.path_xy_m[-1])


def test_simplified_path_keeps_endpoints_and_only_free_segments(yard: OccupancyGrid) -> None:
    inflated = inflate(yard, 0.4)
    result = plan_path(inflated, (1.0, 1.0), (9.0, 1.0))
    pruned = simplify_path(inflated, result.path_xy_m)
    assert 3 <= len(pruned) < len(result.path_xy_m) // 10
    np.testing.assert_allclose(pruned[[0, -1]], result.path_xy_m[[0, -1]])
    for a, b in itertools.pairwise(pruned):
        assert segment_is_free(inflated, a, b)
        t = np.linspace(0, 1, 400)[:, None]
        assert inflated.is_free_xy(a + t * (b - a)).all()


def test_segment_cannot_slip_between_diagonally_touching_obstacles() -> None:
    cells = np.zeros((4, 4), bool)
    cells[1, 2] = cells[2, 1] = True
    grid = OccupancyGrid(cells, 1.0, (0.0, 0.0))
    assert not segment_is_free(grid, (1.5, 1.5), (2.5, 2.5))
    assert segment_is_free(grid, (0.5, 0.5), (3.5, 0.5))
