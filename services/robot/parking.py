"""Where an idle robot goes: out of the structure's footprint at once, then back to its start pose.

Why: a robot that has finished a task must not wall itself in or stand where the next component goes, and
an idle one parked at the depot is out of the way of the structure and the yard. A parking drive that fails
(its recoveries spent) is tried again after ``park_retry_s``, and the robot's state says why meanwhile. A
robot walled in fails every try alike: the first failure is logged with why and where it stays, later ones
only at the 2nd, 4th, 8th, … in a row, with the count. A failed drive that leaves the robot cut off from its
depot on the static map says it is walled in (:meth:`.task_cycle.TaskCycle.walled_in`); a drive that gets
there says it is out again.
"""

from __future__ import annotations

import logging
import math

import numpy as np

from .approach import exit_point
from .nav_types import NavStatus
from .robot_context import RobotContext
from .task_cycle import TaskCycle

_log = logging.getLogger(__name__)

AT_DEPOT_M = 0.5  # a robot this near its start pose stands at its depot


class Parking:
    """Where an idle robot goes: first out of the structure's footprint (at once), then after a while back
    to its start pose, out of the way of the structure and the yard. Owns the idle bookkeeping; says what it
    is up to through the task cycle's ``activity``."""

    def __init__(self, context: RobotContext, cycle: TaskCycle) -> None:
        self.context, self.cycle = context, cycle
        self._idle_since_s: float | None = None
        self._left_structure = True  # after a task: out of the building footprint (or tried)
        self._parking = False  # the navigator's goal is the depot
        self._park_again_s = 0.0  # not before this sim time (a parking drive failed)
        self._park_failures = 0  # parking drives failed in a row (a robot walled in fails every one)

    def task_started(self) -> None:
        """A task took the robot on: once idle again it leaves the structure first, then parks."""
        self._idle_since_s = None
        self._parking, self._park_again_s, self.cycle.activity = False, 0.0, ""
        self._left_structure = False

    def step(self) -> None:
        """One control step of an idle robot."""
        context, cycle = self.context, self.cycle
        navigator, config, robot_id, sim_s = (
            context.navigator,
            context.config,
            context.robot_id,
            context.sim_s,
        )
        if self._idle_since_s is None:
            self._idle_since_s = sim_s
        if not self._left_structure and navigator.goal is None:
            self._left_structure = True
            building = context.site_map.layout.building.grown(config.leave_margin_m)
            grid = context.site_map.inflated_grid()
            spot = exit_point(grid, building, navigator.pose_xy_yaw[:2])
            if spot is not None:
                _log.info("%s: leaving the structure to %s", robot_id, np.round(spot, 2).tolist())
                navigator.set_goal(spot, None, sim_s, tolerance_m=0.4)
                return
        status = navigator.status
        if navigator.goal is not None and status in (NavStatus.REACHED, NavStatus.FAILED):
            # out of the structure, parked, or failed (its recoveries spent): idle until parking time. Not
            # while WAITING for a path: a robot parked in an inflated cell was sent to the depot, cancelled
            # while it waited, sent again, every period, so its recoveries never ran (14,000 log lines)
            if status is NavStatus.FAILED and self._parking:
                self._park_again_s = sim_s + config.park_retry_s
                self._park_failures += 1
                failure = navigator.failure
                why = failure.message if failure is not None else "no path"
                walled_in = context.cut_off_from_depot()
                self._say_cannot_park(why, walled_in)
                if walled_in:
                    cycle.walled_in(f"it cannot drive to its depot: {why}")
            elif status is NavStatus.REACHED and self._parking:
                cycle.activity, self._park_failures = "", 0
                cycle.moved_out("it drove to its depot")
            self._parking = False
            navigator.cancel()
        if (
            navigator.goal is not None
            or sim_s - self._idle_since_s < config.park_after_s
            or sim_s < self._park_again_s
        ):
            return
        x, y, yaw = context.home_xy_yaw
        if self._from_depot_m() <= AT_DEPOT_M:
            cycle.moved_out("it stands at its depot")
        else:
            retry = self._park_failures > 0  # a drive that failed alike: said by _say_cannot_park, not here
            _log.log(logging.DEBUG if retry else logging.INFO, "%s: idle, parking at the depot", robot_id)
            navigator.set_goal((x, y), yaw, sim_s, tolerance_m=0.3, quiet=retry)
            self._parking = True

    def next_act_s(self) -> float | None:
        """While it waits, standing, for its parking time: the sim time it acts of its own accord next
        (drives to its depot, or says it stands there); None when it may act at any step."""
        if not self._left_structure or self._parking or self._idle_since_s is None:
            return None
        if self.context.navigator.goal is not None:
            return None
        return max(self._idle_since_s + self.context.config.park_after_s, self._park_again_s)

    def settled(self) -> bool:
        """Nothing left to do of its own accord: out of the structure, no drive under way or tried again
        later, and standing at its depot once the parking time came."""
        context = self.context
        if not self._left_structure or self._parking or self._idle_since_s is None or self._park_failures:
            return False
        if context.sim_s - self._idle_since_s < context.config.park_after_s:
            return False
        return self._from_depot_m() <= AT_DEPOT_M

    def _from_depot_m(self) -> float:
        """How far the robot stands from its depot (its start pose), in metres."""
        x, y = self.context.navigator.pose_xy_yaw[:2]
        home_x, home_y, _ = self.context.home_xy_yaw
        return math.hypot(x - home_x, y - home_y)

    def _say_cannot_park(self, why: str, walled_in: bool) -> None:
        """The robot's state says where it stays and what that means (:func:`not_parked_activity`); the log
        says why at the first failure in a row, then at the 2nd, 4th, 8th, … with the count (a power of
        two: a handful of lines for a whole run)."""
        context, failures = self.context, self._park_failures
        x, y = context.navigator.pose_xy_yaw[:2]
        where = f"stays at ({x:.1f}, {y:.1f})"
        self.cycle.activity = not_parked_activity((x, y), walled_in, self._from_depot_m())  # why: its log
        if failures == 1:
            _log.warning(
                "%s: cannot drive to the depot, %s, idle, and tries again every %.0f s: %s",
                context.robot_id,
                where,
                context.config.park_retry_s,
                why,
            )
        elif failures & (failures - 1) == 0:
            _log.warning(
                "%s: still cannot drive to the depot (%d tries in a row), %s",
                context.robot_id,
                failures,
                where,
            )


def not_parked_activity(xy: tuple[float, float], walled_in: bool, off_m: float) -> str:
    """What a robot whose parking drive failed says in its state (the run's progress line shows it, up to
    60 characters): where it waits and what that means for the build. Not walled in, nothing changes: it
    waits there for its next task, ``off_m`` from its depot (``waits at (1.4, -6.3) for a task, 0.7 m
    from its depot``: a new user read "no way to its depot" in a run that built everything as an error,
    and a later one could not tell what "short of its depot" meant); walled in, it takes no task until it
    gets out, and the other robots take the work."""
    where = f"({xy[0]:.1f}, {xy[1]:.1f})"
    if walled_in:
        return f"walled in at {where}: no task until it gets out"
    return f"waits at {where} for a task, {off_m:.1f} m from its depot"
