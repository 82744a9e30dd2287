"""Shut-in holds: a released task is not given to a robot while placing its component would shut a
driving robot in.

Why: the access hold (:mod:`.access_hold`) keeps the way open to the work still to be built, not to the
robots. A carrier setting a partition from inside a room keeps its own way out (the robot's approach,
:func:`bimbot.services.robot.approach.way_out_after`), but the crane can set the room's last panel while
the carrier is still in it: the carrier is then walled in to the end of the run, and the floor above is
poured over it. A site does not close a room with a machine inside. So a released component waits while
a driving robot stands where, with what is built and released standing, it has no way out to its depot
and would have one without that component.

Bounds: the hold is asked again at every assignment pass (the robots move); a task held for
``HOLD_MAX_S`` of sim time goes anyway, logged, so a robot that does not move never stops the build.
Only one component is taken away at a time: a robot that two released components shut in together is
not seen.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

from bimbot.shared.robot_description import Capability

from .planner_state import PlannerState
from .records import TaskRecord

if TYPE_CHECKING:
    from .access_hold import AccessGuard

_log = logging.getLogger(__name__)

HOLD_MAX_S = 900.0  # sim s a task waits at most for a robot to leave the room it would close


class ShutInHolds:
    """Whether a released task waits for a robot to get out (owns when each hold began)."""

    def __init__(self, state: PlannerState, access: AccessGuard | None) -> None:
        self._state = state
        self._access = access
        self._since_s: dict[str, float] = {}  # GUID → sim time its hold began
        self._expired: set[str] = set()  # held for HOLD_MAX_S: not held again

    def holds(self, task: TaskRecord) -> bool:
        """``task`` waits: placing its component now would shut a driving robot in (see the module)."""
        state, guid = self._state, task.guid
        if self._access is None or state.site is None or guid in self._expired:
            return False
        driving = {
            robot.robot_id: (robot.pose_xy_yaw[0], robot.pose_xy_yaw[1])
            for robot in state.robots.values()
            if robot.alive
            and robot.pose_xy_yaw is not None
            and robot.robot_id in state.site
            and state.site[robot.robot_id].description.can(Capability.DRIVE)
        }
        shut = self._access.shuts_in(guid, driving) if driving else []
        if not shut:
            if self._since_s.pop(guid, None) is not None:
                _log.info("%s goes: no robot is shut in by it now", state.describe(guid))
            return False
        since = self._since_s.setdefault(guid, state.sim_time_s)
        if since == state.sim_time_s:
            where = ", ".join(
                f"{robot} at ({driving[robot][0]:.1f}, {driving[robot][1]:.1f})" for robot in shut
            )
            _log.info(
                "%s waits: placing it now would shut in %s (no way out to the depot); it goes once they are "
                "out, or after %.0f s of sim time",
                state.describe(guid),
                where,
                HOLD_MAX_S,
            )
        if state.sim_time_s - since < HOLD_MAX_S:
            return True
        _log.warning(
            "%s goes though it shuts in %s: held %.0f s of sim time and they did not get out",
            state.describe(guid),
            ", ".join(shut),
            state.sim_time_s - since,
        )
        self._since_s.pop(guid, None)
        self._expired.add(guid)
        return False
