"""Traffic rules between robots: who steps aside when two block each other (a mixin of the navigator).

Why apart from :mod:`.navigator`: a rule of its own, with no negotiation. A robot stuck facing another robot
(a laser mark where that robot's published pose estimate is, within ``traffic_range_m``): the one with
the greater id steps aside to a free spot (:func:`.motion.yield_point`) and waits there while the other
holds still for ``hold_s``, then both carry on; after ``max_give_ways`` per goal the navigator's
recovery chain takes over (:mod:`.recovery`).
"""

from __future__ import annotations

import logging
import math
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from .motion import turn_command, yield_point
from .nav_types import Goal, NavCommand, NavigatorConfig, NavStatus

if TYPE_CHECKING:
    from scipy.spatial import cKDTree

    from .site_map import SiteMap

_log = logging.getLogger(__name__)


class Traffic:
    """Stepping aside and holding, for :class:`.navigator.Navigator`."""

    config: NavigatorConfig
    robot_id: str
    site_map: SiteMap
    goal: Goal | None
    marks: NDArray[np.float64]
    nearest_mark_m: float
    v_mps: float
    _status: NavStatus
    _resume: Goal | None
    _mark_tree: cKDTree | None
    _others: dict[str, tuple[NDArray[np.float64], float]]

    if TYPE_CHECKING:  # defined by the navigator this is a mixin of (no runtime definition to shadow it)

        def _new_goal(
            self, xy: NDArray[np.float64], yaw: float | None, tolerance_m: float, sim_s: float, **more: float
        ) -> Goal: ...

        def _command(self, v: float, w: float, new_path: NDArray[np.float64] | None = None) -> NavCommand: ...

    def _blocking_robot(
        self, pose: NDArray[np.float64], sim_s: float
    ) -> tuple[str, NDArray[np.float64]] | None:
        """The other robot standing at the nearest mark within ``traffic_range_m``, if one is known there."""
        if self._mark_tree is None or self.nearest_mark_m > self.config.traffic_range_m:
            return None
        _, index = self._mark_tree.query(pose[:2])
        mark = self.marks[index]
        best: tuple[float, str, NDArray[np.float64]] | None = None
        for robot_id, (xy, seen_s) in self._others.items():
            gap = float(np.hypot(*(xy - mark)))
            if sim_s - seen_s < 5.0 and gap < 1.5 and (best is None or gap < best[0]):
                best = (gap, robot_id, xy)
        return None if best is None else (best[1], best[2])

    def _traffic(self, goal: Goal, pose: NDArray[np.float64], sim_s: float) -> NavCommand | None:
        """Stuck facing another robot: the one with the greater id steps aside, the other holds still."""
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
                self._resume = goal
                self.goal = self._new_goal(spot, None, 0.3, sim_s, aside_until_s=sim_s + self.config.aside_s)
                self._status = NavStatus.ACTIVE
                return self._command(0.0, 0.0)
        _log.info("%s: holding for %s to step aside", self.robot_id, other_id)
        goal.hold_until_s = sim_s + self.config.hold_s
        return self._command(*turn_command(0.0, self.v_mps, 0.0, self.config.dwa))

    def _stepped_aside(self, sim_s: float) -> bool:
        """While stepping aside: once there (or out of time) wait for the other robot to pass, then go back to
        the real goal. True while the robot should stand still."""
        aside = self.goal
        assert aside is not None and self._resume is not None
        done = self._status in (NavStatus.REACHED, NavStatus.FAILED) or sim_s >= aside.aside_until_s
        if not done:
            return False
        clear = self.nearest_mark_m > self.config.traffic_range_m + 0.5
        if not clear and sim_s < aside.aside_until_s + self.config.hold_s:
            self._status = NavStatus.REACHED
            return True
        goal, self._resume = self._resume, None
        goal.trail.clear()
        assert goal.watchdog is not None
        goal.watchdog.reset(sim_s)
        goal.planned_s, goal.path = -math.inf, None
        self.goal, self._status = goal, NavStatus.ACTIVE
        return False
