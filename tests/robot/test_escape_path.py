"""A robot whose space was narrowed by what was built beside it drives out along the cells its body fits,
instead of staying walled in: the restaurant's Husky (0.67 m wide, inflated to a 1.5 m disc) stood 7 m deep
in a 1.4 m lane between new walls, and no free cell lay within a straight drive of it."""

from __future__ import annotations

import itertools
import math

import numpy as np

from bimbot.services.robot.nav_types import NavStatus
from bimbot.services.robot.plan_executor import PlanNavigator
from bimbot.services.robot.recovery import escape_path, held_where_it_stands, plan_start
from bimbot.shared.occupancy_grid import OccupancyGrid, from_footprints, inflate
from bimbot.shared.reasons import ReasonCode

INFLATION_M, HALF_WIDTH_M = 0.75, 0.35
BOUNDS = (-12.0, -12.0, 12.0, 12.0)
ROBOT_XY = (0.0, -7.0)  # 7 m deep in the lane, which opens to the north at y = 0


def _lane() -> OccupancyGrid:
    """Two 8 m walls 1.4 m apart (their inner faces at x = ±0.7), closed at the south end."""
    return from_footprints(BOUNDS, 0.1, boxes_xy_m=_lane_boxes())


def test_a_robot_deep_in_a_lane_narrower_than_its_inflation_finds_the_way_out_its_body_fits() -> None:
    walls = _lane()
    grid, body = inflate(walls, INFLATION_M), inflate(walls, HALF_WIDTH_M)
    assert not grid.is_free(*ROBOT_XY) and body.is_free(*ROBOT_XY)
    assert plan_start(grid, ROBOT_XY, 4.0, body) is None  # no free cell within a straight drive
    way = escape_path(grid, ROBOT_XY, body)
    assert way is not None and way[0] == ROBOT_XY
    assert grid.is_free(*way[-1]) and way[-1][1] > -0.5  # out at the lane's open end
    assert all(body.is_free(x, y) for x, y in way)
    assert sum(math.dist(a, b) for a, b in itertools.pairwise(way)) < 8.5


def test_a_robot_walled_in_on_every_side_has_no_way_out() -> None:
    walls = from_footprints(BOUNDS, 0.1, boxes_xy_m=[*_lane_boxes(), (-0.9, 0.0, 0.9, 0.2)])
    grid, body = inflate(walls, INFLATION_M), inflate(walls, HALF_WIDTH_M)
    assert escape_path(grid, ROBOT_XY, body) is None


def _lane_boxes() -> list[tuple[float, float, float, float]]:
    return [(-0.9, -8.0, -0.7, 0.0), (0.7, -8.0, 0.9, 0.0), (-0.9, -8.2, 0.9, -8.0)]


class _Grids:
    """The two grids a plan-fidelity navigator asks its site map for: the robot's inflation and its body."""

    version = 0  # the map never changes here

    def __init__(self, walls: OccupancyGrid) -> None:
        self.walls = walls

    def inflated_grid(self, radius_m: float | None = None) -> OccupancyGrid:
        return inflate(self.walls, INFLATION_M if radius_m is None else radius_m)

    def components_near(self, xy_m: object, within_m: float) -> list[tuple[str, float]]:
        return []


def test_a_plan_fidelity_robot_in_the_lane_drives_out_and_on_to_its_goal() -> None:
    navigator = PlanNavigator(_Grids(_lane()), (*ROBOT_XY, math.pi / 2), speed_mps=1.0, turn_radps=1.5)
    navigator.set_goal((6.0, 5.0), None, 0.0)
    assert navigator.status is NavStatus.ACTIVE, navigator.failure
    path = np.asarray(navigator.path_xy_m)
    assert tuple(path[0]) == ROBOT_XY and np.allclose(path[-1], (6.0, 5.0), atol=0.1)
    inside = path[path[:, 1] < -0.5]
    assert np.all(np.abs(inside[:, 0]) < 0.7 - HALF_WIDTH_M + 0.05)  # along the lane, clear of its walls


def test_a_robot_a_part_came_to_lie_over_is_trapped_whatever_free_space_lies_beyond() -> None:
    """A roof panel slid off its target and came to rest over a plan-fidelity robot (collisions off): its
    own cell is occupied even for its body, though open ground lies 2 m away. Every drive fails; the
    reason says it is trapped (so its task goes to another robot and it is held as walled in), not that it
    made no progress (which failed 20 components in turn on it)."""
    panel = from_footprints(BOUNDS, 0.1, boxes_xy_m=[(-1.2, -1.5, 1.2, 1.5)])
    grid, body = inflate(panel, INFLATION_M), inflate(panel, HALF_WIDTH_M)
    assert held_where_it_stands(grid, body, (0.0, 0.0), 2.0)
    assert not held_where_it_stands(grid, body, (0.0, 2.0), 2.0)  # beside it, not under it: drives out
    navigator = PlanNavigator(_Grids(panel), (0.0, 0.0, 0.0), speed_mps=1.0, turn_radps=1.5)
    navigator.set_goal((8.0, 8.0), None, 0.0)
    assert navigator.status is NavStatus.FAILED
    assert navigator.failure is not None and navigator.failure.code is ReasonCode.ROBOT_TRAPPED
    assert "held where it stands" in navigator.failure.message
