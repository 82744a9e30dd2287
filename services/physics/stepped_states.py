"""Component states taken by physics at a defined step (lock-step runs with ``--step-with``; pure).

Why: physics joins a component to the structure when its twin says constructed, and refuses to attach a
constructed one. Taken when its message (and the twin's answer) happened to arrive, the join fell on
another step from run to run; a body joined a step earlier or later settles by a few micrometres more
or less, the lasers see that, and two runs of one seed drove apart. Here a state message stamped at
step ``j`` is taken before physics advances from step ``j + 1`` (the agents answered ``j`` by then, and
their messages came before their answer); a claim that a component is constructed, failed or blocked is
taken from its twin's answer, which the advance waits for (:class:`~bimbot.shared.step_gate.StepGate`).
"""

from __future__ import annotations

from bimbot.shared.component_states import ComponentStates
from bimbot.shared.messages import ComponentState, ComponentStateMsg, TwinMsg
from bimbot.shared.state_table import TERMINAL
from bimbot.shared.step_gate import StepGate
from bimbot.shared.twin_claims import TwinClaims

DELAY_STEPS = 1  # before advancing from k: the states stamped at k - 1 or before (agents answered k - 1)


class SteppedStates:
    """State messages and twin answers held for their step; what to act on comes out of :meth:`take`."""

    def __init__(self, states: ComponentStates) -> None:
        self.states = states
        self.gate: StepGate[ComponentStateMsg | TwinMsg] = StepGate(delay_steps=DELAY_STEPS)
        self.claims = TwinClaims()  # terminal claims awaiting their twin's answer
        self.to_ask: list[str] = []  # GUIDs whose twin the adapter asks now

    def clock(self, step: int, sim_time_s: float) -> None:
        self.gate.clock(step, sim_time_s)

    def hear(self, message: ComponentStateMsg) -> None:
        """A state message as it arrives (a terminal claim: its twin is asked at once)."""
        terminal = message.state in TERMINAL
        put = self.gate.put(message.sim_time_s, message.guid, message, resolved=not terminal)
        if put and terminal and self.claims.claim(message):
            self.to_ask.append(message.guid)

    def answer(self, twin: TwinMsg) -> bool:
        """A twin's answer: True when it settled a claim (taken, as the twin says, at the claim's step)."""
        settled, ask_again = self.claims.answer(twin)
        if ask_again:
            self.to_ask.append(twin.guid)  # not (yet) what the message said
        return any([self.gate.resolve(claim, twin) for claim in settled])

    def ready(self, step: int) -> bool:
        return self.gate.ready(step)

    def take(self, step: int, *, force: bool = False) -> list[tuple[str, ComponentState]]:
        """Before advancing from ``step``: (GUID, state) of every component whose state is taken now."""
        out: list[tuple[str, ComponentState]] = []
        for item in self.gate.take(step, force=force):
            state = self.states.take_twin(item) if isinstance(item, TwinMsg) else self.states.hear(item)
            if state is not None:
                out.append((item.guid, state))
        if force:
            self.to_ask.extend(self.claims.guids())
        return out
