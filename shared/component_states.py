"""What a service outside the agents believes of each component's state: state messages judged, twins asked
when one does not fit. Used by every robot and by physics.

Why: a robot acts on component states — it starts a task only once its component is ``released``, it takes
an event as confirmed when the state shows it applied, a verdict ends its task — and physics joins a
component to the structure when it is ``constructed``. Taken at face value, one forged ``constructed`` on an
open bus for the component a robot was about to pick kept it waiting for a release it already had, until
the planner's no-progress bound (1,200 s of sim time); and a forged verdict made physics join a footing
still settling 300 mm off its target, so the retry's pick-up was refused ("joined to the structure"). So
every state message goes through the agents' :class:`~.trusted_states.TrustedStates`, as in ``bimbot
run``: a transition the agents' table forbids is dropped, a terminal claim or a message that does not
follow from what is known makes the listener ask that component's twin (``components/<key>/twin``), and
the twin's answer is taken as the truth.

Pure: the questions come out as :class:`TwinQuestion` for the adapter to send; the answers come back
through :meth:`ComponentStates.take_twin`. A question not answered is asked again after ``retry_s`` wall
seconds; an answered one does not hold back the next question about that component: the robot learnt a
component's twin at start-up and then heard its ``constructed`` verdict within the second, and waited
out the rest of that second for its answer — 0.5 s of wall time in which an idle site's clock ran 137 s.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from bimbot.shared.messages import ComponentState, ComponentStateMsg, TwinMsg

from .trusted_states import Judgement, TrustedStates

TWIN_RETRY_S = 1.0  # wall seconds: one component's twin is asked at most this often


@dataclass(frozen=True)
class TwinQuestion:
    """Ask the twin of the component with ``key`` (the adapter sends ``get components/<key>/twin``)."""

    guid: str
    key: str


class ComponentStates:
    """Each component's state as far as the listener trusts it; None for one it has heard nothing of."""

    def __init__(self, keys: Mapping[str, str], retry_s: float = TWIN_RETRY_S) -> None:
        """``keys``: component GUID → its key in the key space (the manifest's)."""
        self._keys = dict(keys)
        self._trusted = TrustedStates(self._keys)
        self._heard: set[str] = set()
        self._to_ask: set[str] = set()
        self._asked_at: dict[str, float] = {}
        self.retry_s = retry_s

    def state(self, guid: str) -> ComponentState | None:
        """The trusted state of ``guid``, or None before anything was taken for it."""
        return self._trusted.states[guid] if guid in self._heard else None

    @property
    def rejected(self) -> int:
        """State messages dropped (not a transition of the agents' table, or about a finished component)."""
        return self._trusted.rejected

    def hear(self, message: ComponentStateMsg) -> ComponentState | None:
        """A state message from the bus: the state to act on when it is taken, None when it is dropped or
        its twin is to be asked first."""
        judgement = self._trusted.judge(message)
        if judgement is Judgement.APPLY:
            self._trusted.apply(message)
            self._heard.add(message.guid)
            return message.state
        if judgement is Judgement.ASK:
            self._to_ask.add(message.guid)
        return None

    def take_twin(self, twin: TwinMsg) -> ComponentState | None:
        """A twin's answer (the truth): the state to act on, or None for a twin of a component not in the
        manifest or one answering under another component's key."""
        if self._keys.get(twin.guid) != twin.key:
            return None
        self._trusted.take_twin(twin)
        self._heard.add(twin.guid)
        self._to_ask.discard(twin.guid)
        self._asked_at.pop(twin.guid, None)  # answered: the next question about it goes out at once
        return twin.state

    @property
    def asking(self) -> bool:
        """Whether a twin is wanted and has not answered yet."""
        return bool(self._to_ask)

    def ask(self, guid: str) -> None:
        """Want ``guid``'s twin (what the listener heard may be out of date: a message lost on the way)."""
        if guid in self._keys:
            self._to_ask.add(guid)

    def questions(self, wall_s: float) -> list[TwinQuestion]:
        """The twins to ask now: each wanted one not asked within ``retry_s``. A component stays wanted
        until its twin answers (a lost question is asked again)."""
        due = sorted(g for g in self._to_ask if wall_s - self._asked_at.get(g, -math.inf) >= self.retry_s)
        for guid in due:
            self._asked_at[guid] = wall_s
        return [TwinQuestion(guid, self._keys[guid]) for guid in due]
