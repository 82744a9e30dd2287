"""Taking tasks back from robots and counting it (steps 4 and 5 of the construction protocol).

Why apart: a task comes back for several reasons (its robot is lost, came back without it, made no
progress, or gave it back itself) and each is counted the same way. A component given back
``max_give_backs`` times, by any robots, fails with the last give-back's reason; a robot that gave back
``hold_after_give_backs`` tasks in a row gets no new task for a while (:class:`.records.PlannerLimits`),
so what it gave back goes to the others.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from functools import partial

from bimbot.shared.messages import ComponentEvent, ComponentState, TaskStatus
from bimbot.shared.reasons import Reason

from .failures import Failures
from .outbox import Outbox
from .planner_state import PlannerState
from .records import CARRYING, Phase, TaskKind, TaskRecord, left

_log = logging.getLogger(__name__)


class GiveBacks:
    """Gives tasks back and counts give-backs per component and per robot (in the records of ``state``)."""

    def __init__(
        self,
        state: PlannerState,
        outbox: Outbox,
        failures: Failures,
        *,
        holds: Callable[[TaskRecord], bool] = lambda _task: False,
    ) -> None:
        """``holds``: whether a task waits for a failed body to be cleared out of the way
        (:meth:`.clear_away.ClearAways.holds`): it does not fail at the bound meanwhile."""
        self._state = state
        self._outbox = outbox
        self._failures = failures
        self._holds = holds

    def give_back(self, guid: str, why: str, reason: Reason | None = None) -> None:
        """Take a task back from its robot (lost, or no progress); ``reason`` counts it as a give-back."""
        state = self._state
        task, component = state.tasks[guid], state.components[guid]
        if task.phase is not Phase.ASSIGNED:
            return
        robot_id = task.robot_id
        state.free_robot(task)
        if component.state is ComponentState.VERIFYING:
            return  # placed already: verification decides
        _log.warning("%s (%s) given back: %s", task.active_id, guid, why)
        self._outbox.set_phase(task, Phase.RELEASED, TaskStatus.RELEASED)
        task.changed_sim_s = state.sim_time_s
        if component.state in CARRYING:
            # counted when the agent reports the abandon (released, event abandon)
            self._outbox.send_event(
                guid, ComponentEvent.ABANDON, partial(left, component, CARRYING), robot_id, reason=reason
            )
        elif reason is not None:
            self.count(task, reason)

    def robot_gave_back(self, robot_id: str) -> None:
        """One more task given back by ``robot_id`` in a row; from ``hold_after_give_backs`` on it gets no
        new task for a while (:class:`.records.PlannerLimits`), and what it gave back goes to the others."""
        robot = self._state.robots.get(robot_id)
        if robot is None:
            return
        limits = self._state.limits
        robot.give_backs_in_row += 1
        beyond = robot.give_backs_in_row - limits.hold_after_give_backs
        if beyond < 0:
            return
        hold_s = min(limits.hold_s * 2.0**beyond, limits.hold_max_s)
        robot.held_until_s = self._state.sim_time_s + hold_s
        _log.warning(
            "%s gave back %d tasks in a row: no new task for it for %.0f s of sim time",
            robot_id,
            robot.give_backs_in_row,
            hold_s,
        )

    def count(self, task: TaskRecord, reason: Reason) -> None:
        """One more give-back of ``task``'s component; at the bound it fails with the last reason."""
        task.give_backs += 1
        task.last_give_back = reason
        if task.kind is TaskKind.HAND_OFF:
            task.hand_offs_given_back += 1
        limit = self._state.limits.max_give_backs
        _log.warning("%s given back (%d of %d): %s", task.guid, task.give_backs, limit, reason.line())
        if task.give_backs >= limit and self._holds(task):
            _log.warning("%s waits for a failed body to be cleared out of the way before it fails", task.guid)
        elif task.give_backs >= limit:
            message = f"given back {task.give_backs} times; last: {reason.message}"
            self._failures.fail(task.guid, reason.model_copy(update={"message": message[:2000]}))

    def give_back_lost(self) -> None:
        """The tasks of robots gone for ``lost_grace_wall_s`` are given back."""
        state = self._state
        for robot in state.robots.values():
            lost = robot.lost_wall_s
            if lost is None or robot.alive or state.wall_s - lost < state.limits.lost_grace_wall_s:
                continue
            robot.lost_wall_s = None
            if robot.task_guid is not None:
                self.give_back(robot.task_guid, f"robot {robot.robot_id} lost")
