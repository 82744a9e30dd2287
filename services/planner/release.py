"""Releasing the ready set (step 1 of the construction protocol), with the curing holds.

Every waiting task whose predecessors are all out of the way is released at once, in plan priority order:
task ``released``, and event ``release`` to its agent. A predecessor is out of the way when constructed,
or when it failed or was blocked and its own predecessors are out of the way (what only follows a failed
component in the schedule goes on; what rests on it was blocked by :mod:`.failures`). A predecessor cast
in place must also have cured: it holds what follows it for its ``cast.cure_s`` of sim time after it was
constructed (:mod:`.curing`).

Why the pass is guarded: it reads every task, so it runs again only when the state's ``revision`` moved
or a curing hold has ended.
"""

from __future__ import annotations

import logging
from functools import partial

from bimbot.shared.messages import ComponentEvent, ComponentState, TaskStatus

from .curing import CuringHolds, Hold
from .outbox import Outbox
from .planner_state import PlannerState
from .records import Phase, left

_log = logging.getLogger(__name__)


class Release:
    """Releases what is ready (owns the holds of the last pass, the earliest end of one, and the revision
    the last pass saw); reads the constructed times of cast components from ``curing``."""

    def __init__(self, state: PlannerState, outbox: Outbox, curing: CuringHolds) -> None:
        self._state = state
        self._outbox = outbox
        self._curing = curing
        self._held: dict[str, Hold] = {}  # GUID → the curing that holds its release (the last release pass)
        self._next_cure_s: float | None = None  # the earliest end of a hold: the release pass runs again then
        self._released_revision = 0

    def release_ready(self) -> None:
        """Release every waiting task whose predecessors are out of the way and cured."""
        state = self._state
        cured = self._next_cure_s is not None and state.sim_time_s >= self._next_cure_s
        if self._released_revision == state.revision and not cured:
            return  # nothing changed that could make a task ready
        self._released_revision = state.revision
        settled: dict[str, bool] = {}
        held: dict[str, Hold] = {}
        for guid in state.plan.order:
            task = state.tasks[guid]
            if task.phase is not Phase.WAITING:
                continue
            preds = state.plan.predecessors.get(guid, frozenset())
            if all(self._settled_for_release(pred, settled) for pred in preds):
                hold = self._curing.holding(guid, preds, state.sim_time_s)
                if hold is not None:
                    held[guid] = hold
                    continue
                if guid in self._held:
                    _log.info("%s released: %s has cured", guid, state.describe(self._held[guid].cast_guid))
                component = state.components[guid]
                self._outbox.set_phase(task, Phase.RELEASED, TaskStatus.RELEASED)
                if component.state is ComponentState.PLANNED:
                    is_released = partial(left, component, {ComponentState.PLANNED})
                    self._outbox.send_event(guid, ComponentEvent.RELEASE, is_released)
        for guid, hold in held.items():
            if guid not in self._held:
                _log.info(
                    "%s waits for the curing of %s until %.0f s of sim time (now %.0f s)",
                    state.describe(guid),
                    state.describe(hold.cast_guid),
                    hold.until_s,
                    state.sim_time_s,
                )
        self._held = held
        self._next_cure_s = min((hold.until_s for hold in held.values()), default=None)

    def curing_holds(self) -> list[Hold]:
        """What is ready but for the curing of a cast predecessor, soonest first."""
        tasks = self._state.tasks
        holds = [hold for guid, hold in self._held.items() if tasks[guid].phase is Phase.WAITING]
        return sorted(holds, key=lambda hold: (hold.until_s, tasks[hold.guid].priority))

    def _settled_for_release(self, pred: str, memo: dict[str, bool]) -> bool:
        """A predecessor is out of the way: constructed, or not built at all and its own predecessors out
        of the way (in a schedule that is one chain, what follows a failed component waits for what came
        before it, not for nothing)."""
        known = memo.get(pred)
        if known is not None:
            return known
        memo[pred] = False  # a cycle (there is none in a plan) stays unsettled
        if self._state.components[pred].state is ComponentState.CONSTRUCTED:
            memo[pred] = True
        elif self._state.tasks[pred].phase in (Phase.FAILED, Phase.BLOCKED):
            before = self._state.plan.predecessors.get(pred, frozenset())
            memo[pred] = all(self._settled_for_release(item, memo) for item in before)
        return memo[pred]
