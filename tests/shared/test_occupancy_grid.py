"""Occupancy grid: frames, rasterisation, laser marking, inflation and free-pose queries."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bimbot.shared.occupancy_grid import (
    OccupancyGrid,
    distance_field_m,
    empty_grid,
    free_approach_pose,
    from_footprints,
    inflate,
    mark_scan,
    nearest_free_cell,
)


def test_world_to_cell_and_back_round_trips_cell_centres_and_points() -> None:
    grid = empty_grid((-2.0, 1.0, 3.0, 4.0), 0.1)
    assert grid.shape == (30, 50)
    rng = np.random.default_rng(0)
    rc = np.stack([rng.integers(0, 30, 200), rng.integers(0, 50, 200)], axis=1)
    np.testing.assert_array_equal(grid.world_to_cell(grid.cell_to_world(rc)), rc)
    xy = rng.uniform((-2.0, 1.0), (3.0, 4.0), (200, 2))
    back = grid.cell_to_world(grid.world_to_cell(xy))
    assert np.all(np.abs(back - xy) <= 0.05 + 1e-9)


def test_cell_indices_are_row_y_col_x_with_origin_at_cell_corner() -> None:
    grid = empty_grid((1.0, 2.0, 2.0, 3.0), 0.25)
    np.testing.assert_array_equal(grid.world_to_cell((1.0, 2.0)), [0, 0])
    np.testing.assert_array_equal(grid.world_to_cell((1.3, 2.6)), [2, 1])  # row from y, col from x
    np.testing.assert_allclose(grid.cell_to_world((2, 1)), [1.375, 2.625])
    assert not grid.is_free(0.99, 2.5)  # outside the grid is never free


def test_grid_cells_are_immutable() -> None:
    grid = empty_grid((0, 0, 1, 1), 0.1)
    with pytest.raises(ValueError):
        grid.occupied[0, 0] = True


def test_rasterised_box_covers_exactly_the_overlapped_cells() -> None:
    grid = from_footprints((0.0, 0.0, 2.0, 2.0), 0.1, boxes_xy_m=[(0.5, 0.3, 1.0, 0.75)])
    expected = np.zeros((20, 20), dtype=bool)
    expected[3:8, 5:10] = True  # rows y∈[0.3, 0.8), cols x∈[0.5, 1.0): the box edge at 1.0 is excluded
    np.testing.assert_array_equal(grid.occupied, expected)


def test_box_partly_outside_bounds_is_clipped() -> None:
    grid = from_footprints((0.0, 0.0, 1.0, 1.0), 0.1, boxes_xy_m=[(-1.0, -1.0, 0.25, 0.15)])
    assert grid.occupied.sum() == 3 * 2
    assert grid.occupied[:2, :3].all()


def test_rotated_polygon_footprint_marks_its_interior_and_outline_only() -> None:
    c, s = math.cos(math.radians(30)), math.sin(math.radians(30))
    half = np.array([[-0.6, -0.2], [0.6, -0.2], [0.6, 0.2], [-0.6, 0.2]])
    polygon = half @ np.array([[c, s], [-s, c]]) + (1.5, 1.5)
    grid = from_footprints((0.0, 0.0, 3.0, 3.0), 0.05, polygons_xy_m=[polygon])
    assert not grid.is_free(1.5, 1.5)
    assert not grid.is_free(*(polygon[0] * 0.999 + (1.5, 1.5) * np.array(0.001)))
    assert grid.is_free(1.5, 1.9) and grid.is_free(0.5, 0.5)
    area_m2 = grid.occupied.sum() * 0.05**2
    assert 0.48 <= area_m2 <= 0.48 + 0.05 * 3.2 + 0.01  # true area plus at most about one outline band


def test_mark_scan_occupies_the_cells_of_the_hits_and_ignores_max_range_beams() -> None:
    grid = empty_grid((0.0, 0.0, 4.0, 4.0), 0.1)
    marked = mark_scan(grid, (1.0, 1.0, math.pi / 2), [1.0, 5.0, np.inf], [0.0, 0.5, 1.0], max_range_m=5.0)
    assert marked.occupied.sum() == 1
    assert not marked.is_free(1.0, 2.0)  # 1 m along +y: yaw π/2 plus beam angle 0
    assert grid.occupied.sum() == 0  # the input grid is unchanged


def test_inflation_occupies_cells_within_radius_and_no_farther() -> None:
    grid = from_footprints((0.0, 0.0, 2.0, 2.0), 0.05, boxes_xy_m=[(1.0, 1.0, 1.05, 1.05)])
    inflated = inflate(grid, 0.25)
    centre = np.array([1.025, 1.025])
    xy = inflated.cell_to_world(np.argwhere(np.ones(grid.shape, bool)))
    d = np.hypot(*(xy - centre).T).reshape(grid.shape)
    np.testing.assert_array_equal(inflated.occupied, d <= 0.25 + 1e-9)
    assert inflated.occupied.sum() == 81  # lattice points of a disc of radius 5 cells


def test_inflation_keeps_original_obstacles_and_zero_radius_is_identity() -> None:
    grid = from_footprints((0, 0, 3, 3), 0.1, boxes_xy_m=[(1, 1, 2, 1.3)])
    assert np.all(inflate(grid, 0.3).occupied[grid.occupied])
    np.testing.assert_array_equal(inflate(grid, 0.0).occupied, grid.occupied)


def test_distance_field_is_metric_distance_to_nearest_obstacle_centre() -> None:
    grid = from_footprints((0.0, 0.0, 1.0, 1.0), 0.1, boxes_xy_m=[(0.0, 0.0, 0.1, 0.1)])
    field = distance_field_m(grid)
    assert field[0, 0] == 0.0
    assert field[3, 4] == pytest.approx(0.5)


def test_nearest_free_cell_finds_the_closest_free_cell_centre() -> None:
    grid = from_footprints((0.0, 0.0, 5.0, 5.0), 0.1, boxes_xy_m=[(1.0, 1.0, 3.0, 3.0)])
    rc = nearest_free_cell(grid, (1.25, 2.02))
    assert rc == (20, 9)  # left of the box, x centre 0.95
    assert not grid.occupied[rc]
    assert nearest_free_cell(grid, (4.02, 4.02)) == (40, 40)
    assert nearest_free_cell(grid, (2.0, 2.0), max_distance_m=0.5) is None


def test_nearest_free_cell_returns_none_on_a_full_grid() -> None:
    grid = OccupancyGrid(np.ones((10, 10), bool), 0.1, (0.0, 0.0))
    assert nearest_free_cell(grid, (0.5, 0.5)) is None


def test_free_approach_pose_is_free_at_standoff_and_faces_the_target() -> None:
    obstacles = [(2.0, 2.0, 2.4, 2.4), (2.6, 1.8, 3.5, 3.0)]  # component at (2.2, 2.2), a stack to its right
    grid = inflate(from_footprints((0.0, 0.0, 5.0, 5.0), 0.05, boxes_xy_m=obstacles), 0.3)
    target = np.array([2.2, 2.2])
    pose = free_approach_pose(grid, target, 1.0, preferred_xy_m=(4.5, 2.2))
    assert pose is not None
    x, y, yaw = pose
    assert grid.is_free(x, y)
    assert math.hypot(x - 2.2, y - 2.2) == pytest.approx(1.0)
    assert math.cos(yaw) == pytest.approx((2.2 - x) / 1.0)
    assert math.sin(yaw) == pytest.approx((2.2 - y) / 1.0)


def test_free_approach_pose_is_none_when_target_is_walled_in() -> None:
    grid = from_footprints((0.0, 0.0, 4.0, 4.0), 0.1, boxes_xy_m=[(0.5, 0.5, 3.5, 3.5)])
    assert free_approach_pose(grid, (2.0, 2.0), 1.0) is None
