"""A plan-fidelity robot keeps watching the site map while it drives: what comes onto the map across the rest
of its path (a part that slid or fell) makes it plan again from where it is, and a goal covered so makes it
stop and ask for another stand-point, instead of driving into what lies there and being shut in by it."""

from __future__ import annotations

import itertools
import math

import numpy as np

from bimbot.services.robot.nav_types import NavStatus
from bimbot.services.robot.plan_executor import PlanNavigator
from bimbot.shared.occupancy_grid import OccupancyGrid, from_footprints, inflate

INFLATION_M = 0.75
BOUNDS = (-12.0, -12.0, 12.0, 12.0)
START = (-8.0, 0.0, 0.0)
GOAL = (8.0, 0.0)


class _Site:
    """What a plan-fidelity navigator asks of its site map, with boxes that come onto it (each a new
    version of the map)."""

    def __init__(self) -> None:
        self.boxes: list[tuple[float, float, float, float]] = []
        self.version = 0

    def add(self, box: tuple[float, float, float, float]) -> None:
        self.boxes.append(box)
        self.version += 1

    def inflated_grid(self, radius_m: float | None = None) -> OccupancyGrid:
        walls = from_footprints(BOUNDS, 0.1, boxes_xy_m=self.boxes)
        return inflate(walls, INFLATION_M if radius_m is None else radius_m)

    def free_at(self, xy_m: np.ndarray) -> np.ndarray:
        return self.inflated_grid().is_free_xy(xy_m)

    def components_near(self, xy_m: object, within_m: float) -> list[tuple[str, float]]:
        return [("Roof panel", 0.0)] if self.boxes else []


def _driving() -> tuple[_Site, PlanNavigator]:
    site = _Site()
    navigator = PlanNavigator(site, START, speed_mps=1.0, turn_radps=1.5)  # type: ignore[arg-type]
    navigator.set_goal(GOAL, None, 0.0)
    assert navigator.status is NavStatus.ACTIVE, navigator.failure
    return site, navigator


def test_a_part_fallen_onto_its_goal_stops_the_robot_short_of_it() -> None:
    site, navigator = _driving()
    site.add((6.5, -1.5, 9.5, 1.5))  # a panel came to rest over the goal while the robot drove
    navigator.watch(5.0)
    assert navigator.goal_blocked and navigator.status is NavStatus.FAILED
    assert navigator.failure is not None and "covered" in navigator.failure.message
    navigator.watch(60.0)  # long after the motion planned at first would have ended
    x, y, _ = navigator.pose_xy_yaw
    assert x < 0.0 and site.inflated_grid().is_free(x, y), "it stopped where it was, clear of the panel"
    navigator.cancel()
    assert not navigator.goal_blocked


def test_a_part_fallen_across_its_way_makes_it_plan_round_it_from_where_it_is() -> None:
    site, navigator = _driving()
    first_end_s = navigator.motion.end_s
    site.add((-1.0, -3.0, 1.0, 3.0))  # across the straight way, the goal still free
    navigator.watch(4.0)
    assert navigator.status is NavStatus.ACTIVE and not navigator.goal_blocked, navigator.failure
    path = np.asarray(navigator.path_xy_m)
    assert math.dist(path[0], navigator.motion.pose_at(4.0)[:2]) < 1e-9
    assert np.allclose(path[-1], GOAL, atol=0.1)
    grid = site.inflated_grid()
    along = [a + t * (b - a) for a, b in itertools.pairwise(path) for t in np.linspace(0.0, 1.0, 20)]
    assert all(grid.is_free(x, y) for x, y in along), "round the part, not through it"
    assert navigator.motion.end_s > first_end_s


def test_a_map_change_away_from_its_way_leaves_the_motion_as_it_was() -> None:
    site, navigator = _driving()
    motion = navigator.motion
    site.add((-1.0, 6.0, 1.0, 8.0))
    navigator.watch(4.0)
    assert navigator.motion is motion and navigator.status is NavStatus.ACTIVE
