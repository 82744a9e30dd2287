"""Failing a component and blocking what rests on it (step 3 and the bounds of the construction protocol).

Why apart: a component fails for many reasons (no robot on site can build it, give-backs exhausted,
hand-offs exhausted, its agent said so) and each ends the same way: event ``fail`` with the reason, and
what rests on it (transitively, in the support graph) ``blocked`` with a ``blocked_by`` reason naming it.
A component that only follows it in the schedule is not blocked (:mod:`.release` lets it go on).
"""

from __future__ import annotations

import logging
from functools import partial

from bimbot.shared.messages import ComponentEvent, ComponentState, TaskStatus
from bimbot.shared.reasons import CANNOT_GET_THERE, MESSAGE_MAX, Reason, blocked_by

from .outbox import Outbox
from .planner_state import PlannerState
from .records import FINAL, TERMINAL, Phase, reached

_log = logging.getLogger(__name__)


class Failures:
    """Fails components and blocks their dependents (owns the plan's dependents: GUID → what rests on it)."""

    def __init__(self, state: PlannerState, outbox: Outbox) -> None:
        self._state = state
        self._outbox = outbox
        self._dependents = state.plan.dependents()

    def fail(self, guid: str, reason: Reason, *, block: bool = True) -> None:
        """The component cannot be built: event ``fail`` with ``reason``; its dependents are blocked."""
        task, component = self._state.tasks[guid], self._state.components[guid]
        if task.phase in FINAL:
            return
        self._state.free_robot(task)
        reason = self._with_cut_off_advice(guid, reason)
        task.reason = reason
        self._outbox.set_phase(task, Phase.FAILED, TaskStatus.FAILED)
        _log.error("%s failed: %s", guid, reason.line())
        is_terminal = partial(reached, component, TERMINAL)
        self._outbox.send_event(guid, ComponentEvent.FAIL, is_terminal, reason=reason)
        if block:
            self.block_dependents(guid)

    def _with_cut_off_advice(self, guid: str, reason: Reason) -> Reason:
        """A robot could not get to ``guid`` that the access check found a placement cuts off: the reason
        names that placement and what a user can do about it (the plan's warning said it at the start)."""
        placed = self._state.plan.cut_off_by.get(guid)
        if placed is None or reason.code not in CANNOT_GET_THERE:
            return reason
        advice = (
            f"; the plan's access check found that placing {self._state.describe(placed)} cuts it off: "
            "build it before that (a sequence with that order: bimbot run BUILD --sequence FILE), or bring "
            "a machine that reaches it from outside (a crane whose hook covers it: bimbot fleet check BUILD)"
        )
        return reason.model_copy(update={"message": (reason.message + advice)[:MESSAGE_MAX]})

    def block_dependents(self, guid: str) -> None:
        """Block what rests on ``guid`` (transitively); each reason names the failed component and, when
        it rests on it only through others, the one it stands on directly."""
        state = self._state
        root_reason = state.tasks[guid].reason
        stack = [(item, guid) for item in self._dependents.get(guid, ())]
        while stack:
            item, parent = stack.pop()
            task = state.tasks[item]
            if task.phase in (Phase.BLOCKED, Phase.DONE, Phase.FAILED):
                continue
            state.free_robot(task)
            via = None if parent == guid else state.describe(parent)
            reason = blocked_by(state.describe(guid), root_reason, via=via).model_copy(update={"guid": guid})
            task.reason = reason
            self._outbox.set_phase(task, Phase.BLOCKED, TaskStatus.BLOCKED)
            self._outbox.withdraw(item, "task")
            component = state.components[item]
            if component.state in (ComponentState.PLANNED, ComponentState.RELEASED):
                self._outbox.send_event(
                    item, ComponentEvent.BLOCK, partial(reached, component, TERMINAL), reason=reason
                )
            else:
                self._outbox.withdraw(item, "event")
            stack.extend((successor, item) for successor in self._dependents.get(item, ()))
