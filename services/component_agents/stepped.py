"""The agents of a shard in lock-step: events and poses taken at clock steps, in a defined order.

Why: an agent stamps a state change with the sim time it has heard, and changes state when an event or a
pose arrives; both depend on the machine's load, so a component became constructed a few steps earlier or
later from run to run, and what rests on it was released then. Here the shard is a lock-step participant
(``agents-<i>of<n>``; physics waits for its :class:`~bimbot.shared.messages.StepDoneMsg`): at each clock
step ``k`` it takes the events and poses stamped up to the time the clock says (those of step ``k − 2``
and before: physics' clock vouches that they have all come, :class:`~bimbot.shared.step_gate.StepGate`),
in (stamp, sender) order, at the sim time of ``k``; checks the verification timeouts in sim time; then
answers ``k``. It steps once physics' site info has come (the tolerances in force). A clock step heard
again (physics says it again while it waits: an answer may have been lost with a router) is answered with
the last answer again. Twin queries are answered at once, as before.
"""

from __future__ import annotations

import logging
import time
from collections import deque
from collections.abc import Callable, Iterable

from bimbot.shared.bus import Received
from bimbot.shared.clock_guard import ClockGuard, Verdict
from bimbot.shared.messages import ClockMsg, ComponentEventMsg, ComponentPoseMsg, StepDoneMsg
from bimbot.shared.step_gate import StepGate

from .host import AgentHost, Outgoing

_log = logging.getLogger(__name__)

VERIFY_TIMEOUT_SIM_S = 30.0  # lock-step: sim seconds a placement waits for a fresh pose (repeats: 20 s)


def participant_name(shard: int, n_shards: int) -> str:
    """The shard's name as a lock-step participant (``physics --step-with``)."""
    return f"agents-{shard}of{n_shards}"


class SteppedAgents:
    """Inbox items → :class:`~bimbot.shared.step_gate.StepGate` → the host at each clock step."""

    def __init__(
        self,
        host: AgentHost,
        publish: Callable[[Iterable[Outgoing]], None],
        answer: Callable[[StepDoneMsg], None],
    ) -> None:
        self.host, self.publish, self.answer = host, publish, answer
        self.name = participant_name(host.shard, host.n_shards)
        self.gate: StepGate[Received] = StepGate()
        self.clocks: deque[ClockMsg] = deque()
        self.clock_guard = ClockGuard(f"{self.name} clock")
        self._last_step = -1
        self._last_answer: StepDoneMsg | None = None
        self._restate = False  # say every agent's state again at the next step (:mod:`.reconnect`)
        self.started = False  # until physics' site info came (the tolerances in force)

    def start(self) -> None:
        """Physics' site info came: the steps are taken from now on."""
        self.started = True

    def hear(self, item: object) -> bool:
        """Take one inbox item (False: not one of the stepped kinds, the caller handles it)."""
        match item:
            case Received(message=ClockMsg() as clock):
                verdict = self.clock_guard.check(clock, time.monotonic())
                if verdict.accepted:
                    self.gate.clock(clock.step, clock.sim_time_s, clock.inputs_to_s)
                    self.clocks.append(clock)
                elif verdict is Verdict.OLD and self._last_answer is not None:
                    self.answer(self._last_answer)
            case Received(message=ComponentEventMsg() as event):
                sender = f"{event.source}/{event.robot_id or ''}"
                self._stamped(event.sim_time_s, sender, item, key=("event", event.event_id))
            case Received(message=ComponentPoseMsg() as pose):
                self._stamped(pose.sim_time_s, pose.guid, item)
            case _:
                return False
        return True

    def _stamped(self, stamp_s: float, sender: str, item: Received, key: object = None) -> None:
        """Hold an input for its step (:meth:`StepGate.hold`; an event sent again is dropped)."""
        self.gate.hold(stamp_s, sender, item, self._last_step, key=key, kind=type(item.message).__name__)

    def restate(self) -> None:
        """Say every agent's state again at the next step taken (stamped with it, like all it says)."""
        self._restate = True

    def step_ready(self) -> None:
        """Take every clock step that is ready, in order."""
        while self.clocks and self.started:
            clock = self.clocks[0]
            self.clocks.popleft()
            host = self.host
            host.clock.observe(clock.sim_time_s)
            for item in self.gate.take(clock.step):
                self.publish(host.handle(item))
            self.publish(host.tick())
            if self._restate:
                self._restate = False
                self.publish(host.restate())
            answer = StepDoneMsg(participant=self.name, step=clock.step, sim_time_s=clock.sim_time_s)
            self.answer(answer)
            self._last_answer = answer
            self._last_step = clock.step

    def finish(self) -> None:
        """Say this participant stops (physics no longer waits for it); the late inputs, if any."""
        self.answer(
            StepDoneMsg(participant=self.name, step=max(self._last_step, 0), sim_time_s=0.0, done=True)
        )
        if self.gate.late:
            _log.warning(
                "lock-step: %d input(s) came after their step: this run may not reproduce", self.gate.late
            )
