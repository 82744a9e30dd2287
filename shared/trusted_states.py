"""What a listener believes of each component's state: a state message is a hint, the twin is the truth.

Used by ``bimbot run`` (:mod:`bimbot.run.monitor`) and by every robot (:mod:`bimbot.services.robot.executor`).

Anyone on the bus can put a :class:`~bimbot.shared.messages.ComponentStateMsg` on
``components/<key>/state``; only the component's agent keeps its twin (``components/<key>/twin``), the
one truth of what is constructed (DESIGN.md, "one truth per fact"). A probe that forged ``constructed``
for every component once made ``bimbot run`` print ``constructed 12/12`` and exit 0 with one built. So
:class:`TrustedStates` judges each state message (:meth:`TrustedStates.judge`):

* ``REJECT`` — a component not in the manifest; a component already terminal (``constructed``, ``failed``,
  ``blocked`` are only ever set from its twin, and nothing leaves them; a message that repeats the
  terminal state, as a restarted agent's announcement does, is dropped without a warning); a transition
  the agents' own state table (:mod:`bimbot.shared.state_table`) does not allow:
  ``previous --event--> state`` must be one of its rows. A cheap first filter: a forgery that does not
  know the table ends here.
* ``ASK`` — a claim of a terminal state, or a message that does not follow from what is known (its
  ``previous``, or an announcement's state, differs from the known state: a forgery, or a missed message).
  The run asks that component's twin and takes the twin's answer (:meth:`TrustedStates.take_twin`).
* ``APPLY`` — any other, an ordinary step of the protocol: taken as it is, for the live progress and the
  stall report; the twins have the last word at the end (a sweep of ``components/*/twin``).

So ``constructed`` is only ever counted from a twin. A robot judges the same way: a forged ``constructed``
for the component it is about to pick would otherwise keep it waiting for a release it already had. Pure:
no bus; :class:`bimbot.run.monitor.RunMonitor` and the robot's adapter ask the twins and feed the answers
back.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable
from enum import Enum

from bimbot.shared.messages import ComponentState, ComponentStateMsg, TwinMsg
from bimbot.shared.state_table import TERMINAL, next_state

_log = logging.getLogger(__name__)


class Judgement(Enum):
    APPLY = "apply"  # an ordinary step: take it as a hint
    ASK = "ask"  # ask the component's twin, take its answer
    REJECT = "reject"  # drop it


class TrustedStates:
    """Each component's state as far as the run trusts it (every component starts ``planned``: a run's
    agents start with a fresh journal)."""

    def __init__(self, guids: Iterable[str]) -> None:
        self.states: dict[str, ComponentState] = dict.fromkeys(guids, ComponentState.PLANNED)
        self.from_twin: set[str] = set()  # components whose state came from their twin last
        self.rejected = 0

    def judge(self, message: ComponentStateMsg) -> Judgement:
        """What to do with a state message (see the module); counts the rejected ones."""
        known = self.states.get(message.guid)
        if known is not None and known in TERMINAL and message.state == known:
            return Judgement.REJECT  # says what is known already (an agent resuming after a restart)
        if known is None or known in TERMINAL:
            return self._reject(message, "unknown component" if known is None else f"already {known.value}")
        if message.previous is not None and next_state(message.previous, message.event) != message.state:
            return self._reject(message, "not a transition of the agents' state table")
        if message.state in TERMINAL:
            return Judgement.ASK
        follows = message.previous if message.previous is not None else message.state
        return Judgement.APPLY if follows == known else Judgement.ASK

    def apply(self, message: ComponentStateMsg) -> bool:
        """Take an ``APPLY``-judged message; True when the state changed."""
        changed = self.states[message.guid] != message.state
        self.states[message.guid] = message.state
        self.from_twin.discard(message.guid)
        return changed

    def take_twin(self, twin: TwinMsg) -> bool:
        """Take a twin's state (the truth); True when the state changed. A twin of a component not in
        the manifest is ignored."""
        if twin.guid not in self.states:
            return False
        changed = self.states[twin.guid] != twin.state
        self.states[twin.guid] = twin.state
        self.from_twin.add(twin.guid)
        return changed

    def constructed(self) -> set[str]:
        """The components whose twins said ``constructed`` (the only way a component gets there)."""
        return {guid for guid, state in self.states.items() if state == ComponentState.CONSTRUCTED}

    def _reject(self, message: ComponentStateMsg, why: str) -> Judgement:
        self.rejected += 1
        if self.rejected <= 3 or self.rejected % 100 == 0:
            _log.warning(
                "state message #%d not taken (%s): %s %s → %s (%s)",
                self.rejected,
                why,
                message.guid,
                message.previous.value if message.previous else "announced",
                message.state.value,
                message.event,
            )
        return Judgement.REJECT
