"""Inputs taken at a defined clock step, in a defined order, whoever's message came first (pure).

Why: every service runs in its own process; when a message arrives depends on the machine's load, so a
service that acts on what it has heard *so far* acts at a step that differs from run to run (a robot idle
at step 500 in one run and at step 503 in the next gets another task). In lock-step, each participant (a
robot by its ``cmd_vel``, the planner and the agents by :class:`~bimbot.shared.messages.StepDoneMsg`)
publishes its output for clock step ``j``, stamped with the sim time of ``j``, *before* it answers ``j``,
and physics publishes step ``k`` only after every answer to ``k − 2`` (``k − 1 − latency``, latency ≤ 1)
was in. So at step ``k`` a consumer takes exactly the inputs stamped at or before step ``k − DELAY_STEPS``:
all of them have been sent, and once the consumer has heard each participant's own answer to that step
(which travels the same way, after them) all of them have arrived. Inputs are taken in the order
(stamp, sender, arrival): arrival order is kept only within one sender, whose messages keep their order.

An input may need an answer before it can be taken (a claim that a component is constructed is checked
against its twin): :meth:`StepGate.put` it unresolved and :meth:`StepGate.resolve` it when the answer
comes; a step whose inputs are not all resolved waits. Every wait is bounded by the caller, which may
:meth:`StepGate.force` the step (and the late ones are counted: a run that forced steps may not reproduce).

A participant (re)started mid-run joins at the first clock step it hears, ``j``: the answers the others
gave before it listened can never reach it, so their answers up to ``j − DELAY_STEPS`` count as heard
(physics published ``j`` only after them). Waiting for them would hold every restart for the whole bound.

**An idle robot sleeps.** A robot with nothing to do (no task, parked, nothing asked) still costs every
step: its answer, and everyone's wait for it. It may say in its answer to step ``s`` that it sleeps
(``CmdVelMsg.sleeps``): from ``s + 1`` on it answers nothing and nobody waits for it, until the planner
sends a task message (a release wakes the idle, an assignment starts one). The planner's answer to the
step ``j`` it sent one at says so (``StepDoneMsg.wakes``), and every sleeper wakes at ``j + DELAY_STEPS``,
the step that takes that message: from there its answers are waited for again. Everyone reckons both by
step numbers, so the order in which a sleep and a wake arrive changes nothing (:meth:`StepGate.answered`,
:meth:`StepGate.wake_sleepers`).
"""

from __future__ import annotations

import logging
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Generic, TypeVar

T = TypeVar("T")

DELAY_STEPS = 2  # inputs stamped at step k - 2 or before are taken at step k (command latency 0 or 1)
# wall seconds a step waits for a participant's answer (or a twin's) before it goes on without: a hang,
# not a loaded machine (under a load of 36 on two cores a robot's answer took seconds)
_log = logging.getLogger(__name__)

HOLD_S = 60.0
LATE_LOGGED = 20  # late inputs a participant logs one by one; a flood of them is counted in its closing line


@dataclass
class _Input(Generic[T]):
    stamp_s: float
    sender: str
    seq: int
    item: T
    resolved: bool = True


@dataclass
class Sleepers:
    """Who sleeps (participant → the step it fell asleep after) and the steps the sleepers wake at; the
    answers are the caller's (participant → the last step it answered), moved on at a wake."""

    asleep: dict[str, int] = field(default_factory=dict)
    wakes: set[int] = field(default_factory=set)

    def answered(self, answered: dict[str, int], participant: str, step: int, *, sleeps: bool) -> None:
        """``participant`` answered ``step``, asleep after it or not."""
        if sleeps:
            self.asleep[participant] = max(step, self.asleep.get(participant, step))
            self._settle(answered, participant)
        elif step > self.asleep.get(participant, step):
            del self.asleep[participant]  # awake again (it restarted, say): its answers count as they come

    def wake(self, answered: dict[str, int], step: int) -> None:
        """Every participant asleep before ``step`` answers again from ``step`` on."""
        self.wakes.add(step)
        for participant in list(self.asleep):
            self._settle(answered, participant)

    def woken(self, since_step: int, step: int) -> bool:
        """Whether a sleeper that fell asleep after ``since_step`` is awake at ``step``."""
        return any(since_step < wake <= step for wake in self.wakes)

    def forget_before(self, step: int) -> None:
        """Wakes before ``step`` are for sleeps long said (a sleep said from now on is later)."""
        self.wakes = {wake for wake in self.wakes if wake >= step}

    def _settle(self, answered: dict[str, int], participant: str) -> None:
        """A sleeper with a wake after its sleep: awake from that wake, its answers waited for from there."""
        since = self.asleep[participant]
        wake = min((w for w in self.wakes if w > since), default=None)
        if wake is not None:
            del self.asleep[participant]
            answered[participant] = max(answered.get(participant, -1), wake - 1)


@dataclass
class StepGate(Generic[T]):
    """Stamped inputs held until the step that takes them (see the module docstring)."""

    delay_steps: int = DELAY_STEPS
    _inputs: list[_Input[T]] = field(default_factory=list)
    _times: dict[int, float] = field(default_factory=dict)  # clock step → its sim time (recent ones)
    _answered: dict[str, int] = field(default_factory=dict)  # participant → last step it answered
    _absent: set[str] = field(default_factory=set)  # participants not waited for until heard again
    sleepers: Sleepers = field(default_factory=Sleepers)
    _joined_at: int | None = None  # the first clock step heard (see the module docstring)
    _seq: int = 0
    _seen: set[object] = field(default_factory=set)  # keys of inputs put (a repeated delivery is dropped)
    late: int = 0  # inputs that came after the step that should have taken them (taken at the next)
    forced: int = 0  # steps taken without every participant's answer or resolution (bounded waits)

    # --- what is heard ---------------------------------------------------------------------------------

    def clock(self, step: int, sim_time_s: float) -> None:
        """Clock step ``step`` is at ``sim_time_s`` (kept until the steps that need it were taken: a
        participant that fell behind hears many clocks before it takes their steps). The first one heard
        is where this participant joined: the others' answers before it count as heard."""
        if self._joined_at is None:
            self._joined_at = step
            for participant, answered in self._answered.items():
                self._answered[participant] = max(answered, self._heard_floor())
        self._times[step] = sim_time_s

    def _heard_floor(self) -> int:
        """The step every participant counts as answered: the one before the first this gate takes."""
        return -1 if self._joined_at is None else max(-1, self._joined_at - self.delay_steps)

    def answered(self, participant: str, step: int, *, sleeps: bool = False) -> None:
        """``participant`` answered clock step ``step`` (its own output up to there has been sent);
        ``sleeps``: and answers nothing more until the next wake after ``step``."""
        if step > self._answered.get(participant, -1):
            self._answered[participant] = step
        self._absent.discard(participant)
        self.sleepers.answered(self._answered, participant, step, sleeps=sleeps)

    def wake_sleepers(self, step: int) -> None:
        """Every participant asleep before ``step`` answers again from ``step`` on."""
        self.sleepers.wake(self._answered, step)

    def woken(self, since_step: int, step: int) -> bool:
        """Whether a sleeper that fell asleep after ``since_step`` is awake at ``step``."""
        return self.sleepers.woken(since_step, step)

    def expect(self, participants: Iterable[str]) -> None:
        """Wait for these participants' answers from the start (one not heard yet is waited for too: a
        participant first heard late would otherwise have been skipped at the steps before; but not for
        the answers before the first clock this gate heard)."""
        for participant in participants:
            self._answered.setdefault(participant, self._heard_floor())

    def leave(self, participant: str) -> None:
        """``participant`` is gone (or stopped answering): not waited for until it answers again."""
        self._absent.add(participant)

    def put(self, stamp_s: float, sender: str, item: T, *, resolved: bool = True, key: object = None) -> bool:
        """An input stamped ``stamp_s`` by ``sender`` (taken by the first step whose gate reaches it).
        ``key``: what makes it the same input (an event id): a repeated delivery is dropped (False)."""
        if key is not None:
            if key in self._seen:
                return False
            self._seen.add(key)
        self._seq += 1
        self._inputs.append(_Input(stamp_s, sender, self._seq, item, resolved))
        return True

    def hold(
        self,
        stamp_s: float,
        sender: str,
        item: T,
        last_step: int,
        *,
        resolved: bool = True,
        key: object = None,
        kind: str = "",
    ) -> bool:
        """:meth:`put`, and a late input (one ``last_step`` should have taken) counted and logged, one by one
        up to ``LATE_LOGGED`` (a flood: counted in the participant's closing line); False for a repeated
        delivery. ``kind``: what the input is, for the log (default: its type's name)."""
        if not self.put(stamp_s, sender, item, resolved=resolved, key=key):
            return False
        if last_step >= 0 and self.note_late(stamp_s, last_step):
            _log.log(
                logging.INFO if self.late <= LATE_LOGGED else logging.DEBUG,
                "%s from %s stamped %.1f s came after step %d",
                kind or type(item).__name__,
                sender,
                stamp_s,
                last_step,
            )
        return True

    def resolve(self, item: T, replacement: T | None = None) -> bool:
        """The answer an unresolved input waited for came (``replacement``: take that in its place)."""
        for entry in self._inputs:
            if entry.item is item and not entry.resolved:
                entry.resolved = True
                if replacement is not None:
                    entry.item = replacement
                return True
        return False

    # --- what a step takes -----------------------------------------------------------------------------

    def clock_s(self, step: int, default: float) -> float:
        """The sim time of clock step ``step`` (``default`` when it is not known)."""
        return self._times.get(step, default)

    def gate_s(self, step: int) -> float | None:
        """The latest stamp step ``step`` takes (None: the clock of ``step - delay`` is not known)."""
        return self._times.get(step - self.delay_steps)

    def waiting_for(self, step: int) -> list[str]:
        """The participants whose answer to ``step - delay`` has not been heard (sorted)."""
        need = step - self.delay_steps
        return sorted(
            p
            for p, s in self._answered.items()
            if s < need and p not in self._absent and p not in self.sleepers.asleep
        )

    def ready(self, step: int) -> bool:
        """Whether step ``step`` can take its inputs now (every answer heard, every due input resolved)."""
        if self.waiting_for(step):
            return False
        gate = self.gate_s(step)
        return all(entry.resolved for entry in self._inputs if gate is not None and entry.stamp_s <= gate)

    def take(self, step: int, *, force: bool = False) -> list[T]:
        """The inputs step ``step`` takes, in (stamp, sender, arrival) order, and forgets them. Without
        ``force`` the step must be :meth:`ready`; with it, unresolved inputs stay for a later step and
        the participants not heard from are not waited for again until they answer."""
        if not self.ready(step):
            if not force:
                raise RuntimeError(f"step {step} is not ready")
            self.forced += 1
            for participant in self.waiting_for(step):
                self.leave(participant)
        gate = self.gate_s(step)
        for old in [s for s in self._times if s < step - 2 * self.delay_steps]:
            del self._times[old]
        self.sleepers.forget_before(step - 2 * self.delay_steps)
        if gate is None:  # the first steps heard: nothing is known to have arrived yet (taken later)
            return []
        due = [e for e in self._inputs if e.stamp_s <= gate and e.resolved]
        if not due:
            return []
        taken = {id(e) for e in due}
        self._inputs = [e for e in self._inputs if id(e) not in taken]
        due.sort(key=lambda e: (e.stamp_s, e.sender, e.seq))
        return [e.item for e in due]

    def note_late(self, stamp_s: float, step: int) -> bool:
        """Whether an input stamped ``stamp_s`` that arrives while step ``step`` is the latest taken
        should have been taken already (counted in :attr:`late`)."""
        gate = self.gate_s(step)
        if gate is not None and stamp_s <= gate:
            self.late += 1
            return True
        return False

    def pending(self) -> int:
        return len(self._inputs)

    def participants(self) -> Iterable[str]:
        return sorted(self._answered)
