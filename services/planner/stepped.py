"""The planner's loop in lock-step: it decides at clock steps, from the inputs of a defined step.

Why: released in the wall-time loop (:class:`.app._Loop`), a task went to whichever robot the planner had
heard say idle when its loop came round, and a component became released, done or failed when its message
happened to arrive: the bundled frame with three robots gave 20 of 28 components another robot from one
run to the next. Here the planner is a lock-step participant (physics waits for its
:class:`~bimbot.shared.messages.StepDoneMsg` as it waits for a robot's command): at each clock step ``k``
it takes the inputs stamped up to the time the clock says (the component states, poses and robot states
stamped at or before step ``k − 2``, in (stamp, sender) order: physics' clock vouches that they have all
come, :class:`~bimbot.shared.step_gate.StepGate`), steps the core at the sim time of ``k``, publishes what
it decided, then answers ``k``. A claim that a component is constructed, failed or blocked is still taken
from its twin, not from the message: the step that takes it waits for the twin's answer (at most
``HOLD_S`` wall seconds). Sim time comes from the clock only, and the skip requests are paced in steps and
stamped with the step that asks (physics acts on them at the next step). A clock step heard again (physics
says it again while it waits: an answer may have been lost with a router) is answered with the last
answer again.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import deque
from collections.abc import Callable

import zenoh

from bimbot.shared.bus import Answer, Inbox, LivelinessChange, Received, encode
from bimbot.shared.clock_guard import ClockGuard, Verdict
from bimbot.shared.messages import (
    PLANNER_PARTICIPANT,
    STEP_DONE,
    ClockMsg,
    ComponentPoseMsg,
    ComponentStateMsg,
    ProgressMsg,
    RobotStateMsg,
    StepDoneMsg,
    TaskMsg,
    TwinMsg,
    key,
)
from bimbot.shared.state_table import TERMINAL
from bimbot.shared.step_gate import HOLD_S, StepGate
from bimbot.shared.twin_claims import TwinClaims

from .scheduler import Outgoing, PlannerCore
from .skip_requests import SkipAnswer, Skipper

_log = logging.getLogger(__name__)

PARTICIPANT = PLANNER_PARTICIPANT
# A connection's hold (a column held 120 s for its bolts) is skipped from the first quiet step after the
# set-down: every period the site goes on stepping in between is stepped physics for nothing (5-25 periods
# a hold, 3 % of the demo's stepping, before these were 2 and 5 rather than 5 and 25)
SKIP_CHECK_STEPS = 2  # control periods between two looks at whether the site is quiet
SKIP_RETRY_STEPS = 5  # control periods between two skip requests
SKIP_ANSWER_STEPS = 100  # control periods a skip request's answer may take before it counts as lost
CONFIRM_STEPS = 50  # steps a done planner waits for the agents to confirm every terminal state, at most
PROGRESS_STEPS = 5  # the progress is published when it changed and at least every this many steps


def stepped_skipper(send: Callable) -> Skipper:
    """A :class:`.skip_requests.Skipper` paced in clock steps (its "wall time" is the step count)."""
    return Skipper(
        send,
        retry_s=SKIP_RETRY_STEPS,
        timeout_s=SKIP_ANSWER_STEPS,
        check_s=SKIP_CHECK_STEPS,
        participant=PARTICIPANT,
    )


class SteppedLoop:
    """Inbox → :class:`~bimbot.shared.step_gate.StepGate` → core at each clock step → bus, then the
    step's answer."""

    def __init__(  # noqa: PLR0917 - the loop's parts, named at the single call
        self,
        session: zenoh.Session,
        site: str,
        core: PlannerCore,
        inbox: Inbox,
        ask_twin: Callable[[str], None],
        publish: Callable[[Outgoing | ProgressMsg], None],
        *,
        skipper: Skipper | None = None,
        robot_liveliness: Callable[[str, bool], None],
    ) -> None:
        self.session, self.site, self.core, self.inbox = session, site, core, inbox
        self.ask_twin, self.publish, self.skipper = ask_twin, publish, skipper
        self.robot_liveliness = robot_liveliness
        self.gate: StepGate[object] = StepGate()
        self.clocks: deque[ClockMsg] = deque()
        self.clock_guard = ClockGuard("planner clock")
        self.claims = TwinClaims()  # terminal claims awaiting their twin's answer
        self._held_since: float | None = None
        self._answer_key = key(STEP_DONE.template, site=site, participant=PARTICIPANT)
        self._last_step = -1
        self._last_answer: StepDoneMsg | None = None
        self._done_step: int | None = None  # the step the planner was first done at
        self._progress = core.progress()
        self._progress_revision, self._progress_step = -1, -PROGRESS_STEPS

    # --- hearing -------------------------------------------------------------------------------------

    def hear(self, item: object) -> None:
        match item:
            case Received(message=ClockMsg() as clock):
                verdict = self.clock_guard.check(clock, time.monotonic())
                if verdict.accepted:
                    self.gate.clock(clock.step, clock.sim_time_s, clock.inputs_to_s)
                    self.clocks.append(clock)
                elif verdict is Verdict.OLD and self._last_answer is not None:
                    self.session.put(self._answer_key, encode(self._last_answer))
            case Received(message=ComponentStateMsg() as message) if message.state in TERMINAL:
                stamped = self._stamped(message.sim_time_s, message.guid, message, resolved=False)
                if stamped and self.claims.claim(message):
                    self.ask_twin(message.guid)
            case Received(message=ComponentStateMsg() as message):
                self._stamped(message.sim_time_s, message.guid, message)
            case Received(message=ComponentPoseMsg() as message):
                self._stamped(message.sim_time_s, message.guid, message)
            case Received(message=RobotStateMsg() as message):
                self._stamped(message.sim_time_s, message.robot_id, message, key=message.model_dump_json())
            case Answer(message=TwinMsg() as twin):
                settled, ask_again = self.claims.answer(twin)
                for claim in settled:  # taken as the twin says
                    self.gate.resolve(claim, twin)
                if ask_again:  # not (yet) what the message said
                    self.ask_twin(twin.guid)
            case LivelinessChange() if item.kind == "robot":
                self.robot_liveliness(item.id, item.alive)
            case SkipAnswer() if self.skipper is not None:
                self.skipper.answered(item)

    def _stamped(
        self, stamp_s: float, sender: str, message: object, *, resolved: bool = True, key: object = None
    ) -> bool:
        """Hold a message for its step (:meth:`StepGate.hold`); False for a repeated delivery."""
        return self.gate.hold(stamp_s, sender, message, self._last_step, resolved=resolved, key=key)

    # --- stepping ------------------------------------------------------------------------------------

    def run(self, stop: threading.Event, poll_s: float, exit_when_done: bool) -> ProgressMsg | None:
        """Step until ``stop``, or until done with ``exit_when_done`` (the last progress is returned)."""
        try:
            while not stop.is_set():
                for item in self.inbox.drain(first_timeout_s=poll_s if not self.clocks else 0.0):
                    self.hear(item)
                while self.clocks and not stop.is_set():
                    progress = self._step_if_ready(self.clocks[0])
                    if progress is None:
                        break
                    if progress.done and exit_when_done and self._confirmed():
                        return progress
        finally:
            self._answer(max(self._last_step, 0), 0.0, done=True)
            if self.gate.late or self.gate.forced:
                _log.warning(
                    "lock-step: %d input(s) came after their step and %d step(s) were taken without every "
                    "twin's answer: this run may not reproduce",
                    self.gate.late,
                    self.gate.forced,
                )
        return None

    def _confirmed(self) -> bool:
        """Done and the agents took it: every component terminal by its agent, or ``CONFIRM_STEPS`` steps
        since the planner was done (the run's report, made when the planner ends, reads their states)."""
        if self._done_step is None:
            self._done_step = self._last_step
        return self.core.confirmed() or self._last_step - self._done_step >= CONFIRM_STEPS

    def _step_if_ready(self, clock: ClockMsg) -> ProgressMsg | None:
        step = clock.step
        force = False
        if not self.gate.ready(step):
            now = time.monotonic()
            if self._held_since is None:
                self._held_since = now
            if now - self._held_since < HOLD_S:
                for guid in self.claims.ask_again(self._held_since, now):
                    self.ask_twin(guid)
                return None
            force = True
            _log.warning(
                "lock-step: step %d taken without the twins of %s after %.0f s",
                step,
                ", ".join(self.claims.guids()),
                HOLD_S,
            )
            for guid in self.claims.guids():
                self.ask_twin(guid)
        self._held_since = None
        self.clocks.popleft()
        self.core.observe_clock(clock.sim_time_s)  # first: what the inputs make it say is stamped with k
        for item in self.gate.take(step, force=force):
            self._feed(item)
        wakes = False  # a task message wakes the sleeping robots (bimbot.shared.step_gate)
        for message in self.core.step(clock.sim_time_s):
            self.publish(message)
            wakes = wakes or isinstance(message, TaskMsg)
        asked = None
        if self.skipper is not None:  # stamped with this step: physics acts on it at the next one
            asked = self.skipper.tick(self.core.quiet_until, float(step), step=step)
        if self.core.revision != self._progress_revision or step - self._progress_step >= PROGRESS_STEPS:
            self._progress = self.core.progress()
            self._progress_revision, self._progress_step = self.core.revision, step
            self.publish(self._progress)
        self._answer(step, clock.sim_time_s, requests=int(asked is not None), wakes=wakes)
        self._last_step = step
        return self._progress

    def _feed(self, item: object) -> None:
        core = self.core
        match item:
            case TwinMsg():
                core.observe_twin(item)
            case ComponentStateMsg():
                core.observe_component_state(item)
            case ComponentPoseMsg():
                core.observe_component_pose(item)
            case RobotStateMsg():
                core.observe_robot_state(item)

    def _answer(
        self, step: int, sim_time_s: float, *, done: bool = False, requests: int = 0, wakes: bool = False
    ) -> None:
        """Answer ``step``; ``requests``: the skip requests sent for it (physics waits for them). The answer
        says when the planner acts next of its own accord (a curing's end): the plan fidelity's physics
        does not jump its clock past that."""
        message = StepDoneMsg(
            participant=PARTICIPANT,
            step=step,
            sim_time_s=sim_time_s,
            done=done,
            requests=requests,
            next_event_s=None if done else self.core.next_own_event_s(),
            wakes=wakes,
        )
        self.session.put(self._answer_key, encode(message))
        # said again when the step is heard again, without its requests: those went with the first
        self._last_answer = None if done else message.model_copy(update={"requests": 0})
