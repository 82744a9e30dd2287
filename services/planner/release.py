"""Releasing the ready set (step 1 of the construction protocol), with the curing holds.

Every waiting task whose predecessors are all out of the way is released at once, in plan priority order:
task ``released``, and event ``release`` to its agent. A predecessor is out of the way when constructed,
or when it failed or was blocked and its own predecessors are out of the way (what only follows a failed
component in the schedule goes on; what rests on it was blocked by :mod:`.failures`). A predecessor cast
in place must also have cured: it holds what follows it for its ``cast.cure_s`` of sim time after it was
constructed (:mod:`.curing`).

With an :class:`.access_hold.AccessGuard`, a ready task also waits while placing its component now
(with what is constructed or released standing) would cut off a component still to be built (see that
module); when nothing else is in flight, the first such task goes anyway, so an access hold never stops
a run.

Why the pass is guarded: it reads every task, so it runs again only when the state's ``revision`` moved
or a curing hold has ended.
"""

from __future__ import annotations

import logging
from functools import partial
from typing import TYPE_CHECKING

from bimbot.shared.messages import ComponentEvent, ComponentState, TaskStatus

from .curing import CuringHolds, Hold
from .outbox import Outbox
from .planner_state import PlannerState
from .records import FINAL, Phase, left

if TYPE_CHECKING:
    from .access_hold import AccessGuard

_log = logging.getLogger(__name__)


class Release:
    """Releases what is ready (owns the holds of the last pass, the earliest end of one, and the revision
    the last pass saw); reads the constructed times of cast components from ``curing``."""

    def __init__(
        self, state: PlannerState, outbox: Outbox, curing: CuringHolds, access: AccessGuard | None = None
    ) -> None:
        self._state = state
        self._outbox = outbox
        self._curing = curing
        self._access = access
        self._access_waits: dict[str, tuple[str, ...]] = {}  # GUID → what it would cut off (held for)
        self._to_build: dict[str, None] | None = None  # this pass: the tasks not final (read when needed)
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
        self._to_build = None
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
                if self._held_for_access(guid):
                    continue
                self._release(guid)
                if self._access is not None and self._to_build is not None:
                    self._access.stand(guid)  # what is released next in this pass must not cut it off
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
        self._release_one_held_for_access_when_nothing_else_goes_on()

    def _release(self, guid: str) -> None:
        task, component = self._state.tasks[guid], self._state.components[guid]
        self._outbox.set_phase(task, Phase.RELEASED, TaskStatus.RELEASED)
        if component.state is ComponentState.PLANNED:
            is_released = partial(left, component, {ComponentState.PLANNED})
            self._outbox.send_event(guid, ComponentEvent.RELEASE, is_released)

    def _held_for_access(self, guid: str) -> bool:
        """Whether ``guid`` waits because placing it now would cut off work still to be built (logged once
        a hold begins); a hold is looked at again only when all it waited for is final."""
        if self._access is None:
            return False
        state = self._state
        waits = self._access_waits.get(guid)
        if waits is not None and any(state.tasks[other].phase not in FINAL for other in waits):
            return True
        if self._to_build is None:  # once a pass: the site as built now, and what is still to be built
            standing = [
                g
                for g, task in state.tasks.items()
                if task.phase in (Phase.RELEASED, Phase.ASSIGNED)
                or state.components[g].state is ComponentState.CONSTRUCTED
            ]
            failed = [g for g, task in state.tasks.items() if task.phase is Phase.FAILED]
            self._access.observe(standing, failed)
            self._to_build = dict.fromkeys(g for g, task in state.tasks.items() if task.phase not in FINAL)
        cut = tuple(self._access.cut_off(guid, self._to_build))
        if not cut:
            self._access_waits.pop(guid, None)
            return False
        if waits is None:
            named = ", ".join(state.describe(other) for other in cut[:3])
            more = f" and {len(cut) - 3} more" if len(cut) > 3 else ""
            _log.info(
                "%s waits: placing it now would cut off %s%s, still to be built (it goes once they are "
                "built, failed or blocked)",
                state.describe(guid),
                named,
                more,
            )
        self._access_waits[guid] = cut
        return True

    def _release_one_held_for_access_when_nothing_else_goes_on(self) -> None:
        """Nothing released or assigned and no curing hold: the first task held for access goes (else the
        run would wait for work that cannot start)."""
        tasks = self._state.tasks
        held = [guid for guid in self._access_waits if tasks[guid].phase is Phase.WAITING]
        if not held or self._held:
            return
        if any(task.phase in (Phase.RELEASED, Phase.ASSIGNED) for task in tasks.values()):
            return
        first = min(held, key=lambda guid: tasks[guid].priority)
        _log.warning(
            "%s goes though placing it cuts off %s: nothing else can go on",
            self._state.describe(first),
            ", ".join(self._state.describe(other) for other in self._access_waits[first][:3]),
        )
        del self._access_waits[first]
        self._release(first)

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
