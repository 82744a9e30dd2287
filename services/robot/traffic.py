"""Traffic rules between robots: who steps aside when two block each other.

Why apart from :mod:`.navigator`: a rule of its own, with no negotiation. A robot stuck facing another robot
(a laser mark where that robot's published pose estimate is, within ``traffic_range_m``): the one with
the greater id steps aside to a free spot (:func:`.motion.yield_point`) and waits there while the other
holds still for ``hold_s``, then both carry on; after ``max_give_ways`` per goal the navigator's
recovery chain takes over (:mod:`.recovery`).
"""

from __future__ import annotations

import logging
import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .motion import turn_command, yield_point
from .nav_types import Course, Goal, NavigatorConfig, NavStatus, new_goal
from .site_map import SiteMap
from .surroundings import Surroundings

_log = logging.getLogger(__name__)


class Traffic:
    """Stepping aside and holding, for :class:`.navigator.Navigator`.

    Owns the other robots' last published poses. Shares the navigator's ``course`` (it sets a step aside
    and comes back from it) and reads its ``surroundings`` (the laser marks)."""

    def __init__(
        self,
        config: NavigatorConfig,
        robot_id: str,
        site_map: SiteMap,
        course: Course,
        surroundings: Surroundings,
    ) -> None:
        self.config, self.robot_id, self.site_map = config, robot_id, site_map
        self.course, self.surroundings = course, surroundings
        self.others: dict[str, tuple[NDArray[np.float64], float]] = {}  # robot id → (xy, sim s)

    def observe_robot(self, robot_id: str, xy_m: ArrayLike, sim_s: float) -> None:
        """Another robot's pose estimate (its published state): who is who when robots block each other."""
        if robot_id != self.robot_id:
            self.others[robot_id] = (np.asarray(xy_m, float)[:2], sim_s)

    def _blocking_robot(
        self, pose: NDArray[np.float64], sim_s: float
    ) -> tuple[str, NDArray[np.float64]] | None:
        """The other robot standing at the nearest mark within ``traffic_range_m``, if one is known there."""
        mark = self.surroundings.nearest_mark(pose[:2], self.config.traffic_range_m)
        if mark is None:
            return None
        best: tuple[float, str, NDArray[np.float64]] | None = None
        for robot_id, (xy, seen_s) in self.others.items():
            gap = float(np.hypot(*(xy - mark)))
            if sim_s - seen_s < 5.0 and gap < 1.5 and (best is None or gap < best[0]):
                best = (gap, robot_id, xy)
        return None if best is None else (best[1], best[2])

    def give_way(
        self, goal: Goal, pose: NDArray[np.float64], sim_s: float, v_mps: float
    ) -> tuple[float, float] | None:
        """Stuck facing another robot: the one with the greater id steps aside (the course's goal becomes a
        free spot, the real goal waits in ``course.resume``), the other holds still. The command to send
        (``v_mps`` the robot's speed now, braked to a stop), or None when no known robot blocks it or
        ``max_give_ways`` are spent."""
        blocking = self._blocking_robot(pose, sim_s)
        if blocking is None or goal.give_ways >= self.config.max_give_ways:
            return None
        other_id, other_xy = blocking
        goal.give_ways += 1
        goal.trail.clear()
        goal.planned_s, goal.path = -math.inf, None
        if other_id < self.robot_id:
            spot = yield_point(self.site_map.inflated_grid(), pose[:2], other_xy)
            if spot is not None:
                _log.info(
                    "%s: stepping aside for %s to %s", self.robot_id, other_id, np.round(spot, 2).tolist()
                )
                course = self.course
                course.resume = goal
                aside_until_s = sim_s + self.config.aside_s
                course.goal = new_goal(self.config, spot, None, 0.3, sim_s, aside_until_s=aside_until_s)
                course.status = NavStatus.ACTIVE
                return (0.0, 0.0)
        _log.info("%s: holding for %s to step aside", self.robot_id, other_id)
        goal.hold_until_s = sim_s + self.config.hold_s
        return turn_command(0.0, v_mps, 0.0, self.config.dwa)

    def stepped_aside(self, sim_s: float) -> bool:
        """While stepping aside: once there (or out of time) wait for the other robot to pass, then go back to
        the real goal. True while the robot should stand still."""
        course = self.course
        aside = course.goal
        assert aside is not None and course.resume is not None
        done = course.status in (NavStatus.REACHED, NavStatus.FAILED) or sim_s >= aside.aside_until_s
        if not done:
            return False
        clear = self.surroundings.nearest_mark_m > self.config.traffic_range_m + 0.5
        if not clear and sim_s < aside.aside_until_s + self.config.hold_s:
            course.status = NavStatus.REACHED
            return True
        goal, course.resume = course.resume, None
        goal.trail.clear()
        assert goal.watchdog is not None
        goal.watchdog.reset(sim_s)
        goal.planned_s, goal.path = -math.inf, None
        course.goal, course.status = goal, NavStatus.ACTIVE
        return False
