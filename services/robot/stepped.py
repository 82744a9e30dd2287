"""A robot in lock-step: every clock step ticked, in order, with the inputs of a defined step.

Why: the robot took whatever had arrived when its loop came round — a task, a verdict, another robot's
position — and, when it fell behind, answered only the newest of two clock steps; which step saw which
input then depended on the machine's load, and two runs of one seed drove apart. Here each step's
:class:`~bimbot.shared.messages.SensorsMsg` is queued; step ``k`` takes first the tasks, states, poses and
robot states stamped up to the time its clock says (physics' clock vouches that they have all come:
:class:`~bimbot.shared.step_gate.StepGate`, in (stamp, sender) order), then physics' replies that came
before its sensors, then its odometry, fix and scan. A claim that a component is constructed, failed or
blocked waits for its twin's answer (asked when the claim arrives), which is taken in its place. The
periodic state and the event resends run on sim time (the executor is ticked with the sim time as its
"wall" clock), and nothing is published between steps: every message is stamped with the step it answers.
A step's sensors heard again (physics says them again while it waits: an answer may have been lost with a
router) are answered with the last command again (:meth:`SteppedTicks.answer_again`).

An idle robot sleeps (:mod:`bimbot.shared.step_gate`): once its executor can (``can_sleep``: no task,
parked, nothing to say), its answer says so. Physics then sends it its sensors only every
``SLEEP_TAKE_STEPS``-th step, where it takes its inputs without a tick or an answer (other sensors that
still came are dropped whole), until the first clock that says a wake after its sleep: that step is ticked.
Only where the planner answers the steps: its answers carry the wakes. A kinematic robot sleeps through a
drive too (``sleeps_until_s``, plan fidelity): it also wakes at the first step whose clock reaches the
drive's end.
"""

from __future__ import annotations

import logging
import time
from collections import deque
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field

from bimbot.shared.bus import Answer, Received
from bimbot.shared.component_states import TwinQuestion
from bimbot.shared.messages import (
    PLANNER_PARTICIPANT,
    ClockMsg,
    CmdVelMsg,
    ComponentEventMsg,
    ComponentPoseMsg,
    ComponentStateMsg,
    PhysicsReply,
    PlanMsg,
    RobotStateMsg,
    SensorsMsg,
    TaskMsg,
    TwinMsg,
)
from bimbot.shared.state_table import TERMINAL
from bimbot.shared.step_gate import HOLD_S, SLEEP_TAKE_STEPS, StepGate, woken
from bimbot.shared.twin_claims import TwinClaims

from .protocol import Outgoing, PhysicsResult, RobotExecutor

_log = logging.getLogger(__name__)


@dataclass
class _Step:
    sensors: SensorsMsg
    before: list[object] = field(default_factory=list)  # replies and twin answers that came before it


class SteppedTicks:
    """The robot's inputs held for their step (see the module docstring)."""

    def __init__(
        self,
        executor: RobotExecutor,
        publish: Callable[[list[Outgoing]], None],
        on_answered: Callable[[], None],
        keys: Mapping[str, str],
        participants: Iterable[str] = (),
    ) -> None:
        """``keys``: component GUID → its bus key (the manifest's), for the twin questions;
        ``participants``: who answers the steps besides the robots (physics' site info)."""
        self.executor, self.publish, self.on_answered = executor, publish, on_answered
        self.keys = dict(keys)
        self.gate: StepGate[object] = StepGate()
        self.may_sleep = PLANNER_PARTICIPANT in participants  # the planner's answers carry the wakes
        self.asleep_since: int | None = None  # the step it fell asleep after (None: awake)
        self.wakes_at_s: float | None = None  # asleep while driving: it wakes at the step reaching this
        self.slept_steps = 0
        self.slept_on_own_clock = 0  # of those, until a time of its own (a drive's end, a parking time)
        self.steps: deque[_Step] = deque()
        self.claims = TwinClaims()  # terminal claims awaiting their twin's answer
        self._before: list[object] = []  # since the last sensors
        self._replies: list[PhysicsResult] = []  # physics' replies, each for the first step after its own
        self._held_since: float | None = None
        self._last_step = -1
        self._last_answer: CmdVelMsg | None = None

    def hear(self, item: object) -> bool:
        """Take one inbox item (False: not a stepped kind; the caller handles it at once)."""
        robot_id = self.executor.robot_id
        match item:
            case Received(message=SensorsMsg() as sensors):
                clock = sensors.clock
                self.gate.clock(clock.step, clock.sim_time_s, clock.inputs_to_s)
                self.steps.append(_Step(sensors, self._before))
                self._before = []
            case Received(message=ComponentStateMsg() as message) if message.state in TERMINAL:
                stamped = self._stamped(message.sim_time_s, message.guid, message, resolved=False)
                if stamped and self.claims.claim(message):
                    self._ask(message.guid)
            case Received(message=ComponentStateMsg() as message):
                self._stamped(message.sim_time_s, message.guid, message)
            case Received(message=ComponentPoseMsg() as message):
                self._stamped(message.sim_time_s, message.guid, message)
            case Received(message=TaskMsg() as message):
                self._stamped(message.sim_time_s, "planner", message, key=message.model_dump_json())
            case Received(message=RobotStateMsg() as message):
                if message.robot_id != robot_id:
                    self._stamped(message.sim_time_s, message.robot_id, message)
            case Answer(message=TwinMsg() as twin):
                settled, ask_again = self.claims.answer(twin)
                for claim in settled:  # taken as the twin says
                    self.gate.resolve(claim, twin)
                if ask_again:  # not (yet) what the message said
                    self._ask(twin.guid)
                if not settled:
                    self._before.append(twin)
            case PhysicsResult(reply=PhysicsReply() as reply):
                # taken by the first step after the one physics answered at: a reply travels another way
                # than the step's sensors and may come before them
                self._replies.append(item)
                if self._last_step >= 0 and reply.sim_time_s < self.gate.clock_s(
                    self._last_step, reply.sim_time_s
                ):
                    self.gate.late += 1
            case PhysicsResult():
                self._before.append(item)
            case _:
                return False
        return True

    def _stamped(
        self, stamp_s: float, sender: str, message: object, *, resolved: bool = True, key: object = None
    ) -> bool:
        """Hold a message for its step (:meth:`StepGate.hold`); False for a repeated delivery."""
        return self.gate.hold(stamp_s, sender, message, self._last_step, resolved=resolved, key=key)

    def _ask(self, guid: str) -> None:
        if guid in self.keys:
            self.publish([TwinQuestion(guid, self.keys[guid])])

    def tick_ready(self) -> None:
        """Tick every queued step that is ready, in order."""
        executor = self.executor
        while self.steps:
            entry = self.steps[0]
            clock = entry.sensors.clock
            asleep = self.asleep_since is not None and not self._woken(clock)
            if asleep and clock.step % SLEEP_TAKE_STEPS:
                # physics sent it before it heard the sleep: dropped whole, as if never sent (what came
                # before it goes with the next sensors)
                self.steps.popleft()
                (self.steps[0].before if self.steps else self._before)[:0] = entry.before
                continue
            force = False
            if not self.gate.ready(clock.step):
                now = time.monotonic()
                self._held_since = now if self._held_since is None else self._held_since
                if now - self._held_since < HOLD_S:
                    for guid in self.claims.ask_again(self._held_since, now):
                        self._ask(guid)
                    return
                force = True
                _log.warning(
                    "lock-step: step %d ticked without the twins of %s after %.0f s",
                    clock.step,
                    ", ".join(self.claims.guids()),
                    HOLD_S,
                )
            self._held_since = None
            self.steps.popleft()
            # what the step's inputs make the executor say is stamped with this step, sent before its answer
            executor.sim_s, executor.step = clock.sim_time_s, clock.step
            for message in self.gate.take(clock.step, force=force):
                executor.handle(message)
            due = [r for r in self._replies if r.reply is not None and r.reply.sim_time_s < clock.sim_time_s]
            self._replies = [r for r in self._replies if r not in due]
            for message in [*due, *entry.before]:
                executor.handle(message)
            if asleep:
                self._last_step = max(self._last_step, clock.step)
                continue  # no tick, no answer: nobody waits for it
            if self.asleep_since is not None:
                slept = clock.step - self.asleep_since - 1
                self.slept_steps += slept
                self.slept_on_own_clock += slept if self.wakes_at_s is not None else 0
                self.asleep_since, self.wakes_at_s = None, None
            sensors = entry.sensors
            executor.handle(sensors.odom)
            if sensors.fix is not None:
                executor.handle(sensors.fix)
            if sensors.scan is not None:
                executor.handle(sensors.scan)
            if clock.step > self._last_step:
                said = sent_now(executor.tick(clock, clock.sim_time_s), clock.sim_time_s)
                if self.may_sleep and (sleep := self._sleep(clock)) is not None:
                    said = [
                        message.model_copy(update=sleep) if isinstance(message, CmdVelMsg) else message
                        for message in said
                    ]
                    self.asleep_since, self.wakes_at_s = clock.step, sleep["wakes_at_s"]
                self.publish(said)
                answers = [message for message in said if isinstance(message, CmdVelMsg)]
                self._last_answer = answers[-1].model_copy(update={"requests": 0}) if answers else None
                self._last_step = clock.step
                self.on_answered()
                executor.after_tick()

    def _sleep(self, clock: ClockMsg) -> dict | None:
        """What its answer to ``clock`` says of a sleep: idle (until a task message wakes it), or driving
        along a known motion (until it ends, or a task message); None: it stays awake."""
        executor = self.executor
        if executor.can_sleep():
            return {"sleeps": True, "wakes_at_s": None}
        wakes_at_s = executor.sleeps_until_s()
        if wakes_at_s is None or wakes_at_s <= clock.sim_time_s:
            return None
        return {"sleeps": True, "wakes_at_s": wakes_at_s}

    def _woken(self, clock: ClockMsg) -> bool:
        """Whether a robot asleep is awake at ``clock``: a wake after its sleep, or its own wake reached."""
        assert self.asleep_since is not None
        if woken(self.asleep_since, clock.last_wake_step):
            return True
        return self.wakes_at_s is not None and clock.sim_time_s >= self.wakes_at_s

    def answer_again(self) -> None:
        """Send the last answer again (without its count of requests: those went with the first)."""
        if self._last_answer is not None:
            self.publish([self._last_answer])

    def finish(self) -> None:
        if self.slept_steps or self.asleep_since is not None:
            _log.info(
                "lock-step: slept %d step(s) (%d of them until a drive or a wait of its own ended)%s",
                self.slept_steps,
                self.slept_on_own_clock,
                "" if self.asleep_since is None else f", and asleep from step {self.asleep_since + 1} on",
            )
        if self.gate.late or self.gate.forced:
            _log.warning(
                "lock-step: %d input(s) came after their step and %d step(s) were ticked without every "
                "answer: this run may not reproduce",
                self.gate.late,
                self.gate.forced,
            )


def sent_now(messages: list[Outgoing], sim_time_s: float) -> list[Outgoing]:
    """``messages`` with every event, state and plan stamped with the step that sends it. An event queued
    behind another goes out only once that one is confirmed, steps after it was made (a repeat keeps its
    ``event_id``; the agents take the first that comes); a state made between two steps (a physics reply
    handled as it came) went out at the next step with the last one's stamp. Either was taken by the others
    at whichever step it arrived: a message stamped before the answer that follows it may come after."""
    stamped = ComponentEventMsg | RobotStateMsg | PlanMsg
    return [
        message.model_copy(update={"sim_time_s": sim_time_s})
        if isinstance(message, stamped) and message.sim_time_s != sim_time_s
        else message
        for message in messages
    ]
