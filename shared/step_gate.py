"""Inputs taken at a defined clock step, in a defined order, whoever's message came first (pure).

Why: every service runs in its own process; when a message arrives depends on the machine's load, so a
service that acts on what it has heard *so far* acts at a step that differs from run to run (a robot idle
at step 500 in one run and at step 503 in the next gets another task). In lock-step, each participant (a
robot by its ``cmd_vel``, the planner and the agents by :class:`~bimbot.shared.messages.StepDoneMsg`)
publishes its output for clock step ``j``, stamped with the sim time of ``j``, *before* it answers ``j``,
and physics publishes step ``k`` only after it heard every answer to ``k − 2`` (``k − 1 − latency``,
latency ≤ 1). So at step ``k`` a consumer takes exactly the inputs stamped at or before step
``k − DELAY_STEPS``, in the order (stamp, sender, arrival): arrival order is kept only within one sender,
whose messages keep their order.

**Physics' clock vouches for them.** Every service is a client of the run's router (or of one of two linked
routers). A router's links keep order, and it passes a message on before it passes on anything sent after
that message arrived: a participant's output before its answer, that answer before the clock physics sent
once it had it. So when a consumer hears clock step ``k``, every input stamped at or before step
``k − DELAY_STEPS`` has reached it already (``bench/bus_vouching.py`` counts the inputs not there yet when
a clock that vouches for them came: none). The clock says up to which sim time that holds
(:attr:`~bimbot.shared.messages.ClockMsg.inputs_to_s`), and nobody needs to hear anyone else's answer: only
physics hears them all. A clock physics sent after its bound ran out without an answer (a hang, not a
loaded machine) vouches for less; physics warns, and an input that comes after its step is counted late.

An input may need an answer before it can be taken (a claim that a component is constructed is checked
against its twin): :meth:`StepGate.put` it unresolved and :meth:`StepGate.resolve` it when the answer
comes; a step whose inputs are not all resolved waits. Every wait is bounded by the caller, which may
take the step with ``force`` (and the late ones are counted: a run that forced steps may not reproduce).

**An idle robot sleeps** (physics' ``sleepers.py``). A robot with nothing to do says so in its answer
to step ``s``; from ``s + 1`` physics neither waits for it nor sends it its sensors, until the planner's
answer to a step ``j`` says it sent a task message (a release wakes the idle, an assignment starts one):
every sleeper wakes at ``j + DELAY_STEPS``, the step that takes that message. Each clock says the latest
wake at or before its step (:attr:`~bimbot.shared.messages.ClockMsg.last_wake_step`), so a robot knows
from its sensors alone whether it woke (:func:`woken`). Every ``SLEEP_TAKE_STEPS``-th step physics sends
a sleeper its sensors all the same, and it takes its inputs there without a tick (they stay few). Both are
reckoned by step numbers, so which of a sleep and a wake arrives first changes nothing. A kinematic robot
that drives may sleep until its drive ends (``CmdVelMsg.wakes_at_s``): it is awake again at the first step
whose clock reaches that sim time, which physics and the robot both read from the clock.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Generic, TypeVar

T = TypeVar("T")

DELAY_STEPS = 2  # inputs stamped at step k - 2 or before are taken at step k (command latency 0 or 1)
SLEEP_TAKE_STEPS = 50  # a sleeping robot hears its sensors at every step divisible by this (and at its wake)
# wall seconds a step waits for a participant's answer (or a twin's) before it goes on without: a hang,
# not a loaded machine (under a load of 36 on two cores a robot's answer took seconds)
HOLD_S = 60.0
LATE_LOGGED = 20  # late inputs a participant logs one by one; a flood of them is counted in its closing line

_log = logging.getLogger(__name__)


def woken(asleep_since: int, last_wake_step: int | None) -> bool:
    """Whether a robot asleep after step ``asleep_since`` is awake at a clock that says ``last_wake_step``
    (the latest wake at or before its step)."""
    return last_wake_step is not None and last_wake_step > asleep_since


@dataclass
class _Input(Generic[T]):
    stamp_s: float
    sender: str
    seq: int
    item: T
    resolved: bool = True


@dataclass
class StepGate(Generic[T]):
    """Stamped inputs held until the step that takes them (see the module docstring)."""

    delay_steps: int = DELAY_STEPS
    _inputs: list[_Input[T]] = field(default_factory=list)
    _times: dict[int, float] = field(default_factory=dict)  # clock step → its sim time (recent ones)
    _gates: dict[int, float] = field(default_factory=dict)  # clock step → the latest stamp it takes
    _seq: int = 0
    _seen: set[object] = field(default_factory=set)  # keys of inputs put (a repeated delivery is dropped)
    late: int = 0  # inputs that came after the step that should have taken them (taken at the next)
    forced: int = 0  # steps taken without every input resolved (bounded waits)

    # --- what is heard ---------------------------------------------------------------------------------

    def clock(self, step: int, sim_time_s: float, inputs_to_s: float | None = None) -> None:
        """Clock step ``step`` is at ``sim_time_s`` and takes the inputs stamped up to ``inputs_to_s``
        (physics' clock says so: the sim time of step ``step − delay``; without it, that step's own clock
        when it was heard). Kept until the steps that need it were taken: a participant that fell behind
        hears many clocks before it takes their steps."""
        self._times[step] = sim_time_s
        if inputs_to_s is not None:
            self._gates[step] = inputs_to_s

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
        """The latest stamp step ``step`` takes (None: not known, neither said nor heard)."""
        gate = self._gates.get(step)
        return gate if gate is not None else self._times.get(step - self.delay_steps)

    def ready(self, step: int) -> bool:
        """Whether step ``step`` can take its inputs now (every due input resolved)."""
        gate = self.gate_s(step)
        return gate is None or all(entry.resolved for entry in self._inputs if entry.stamp_s <= gate)

    def take(self, step: int, *, force: bool = False) -> list[T]:
        """The inputs step ``step`` takes, in (stamp, sender, arrival) order, and forgets them. Without
        ``force`` the step must be :meth:`ready`; with it, unresolved inputs stay for a later step."""
        if not self.ready(step):
            if not force:
                raise RuntimeError(f"step {step} is not ready")
            self.forced += 1
        gate = self.gate_s(step)
        oldest = step - 2 * self.delay_steps
        for old in [s for s in self._times if s < oldest]:
            del self._times[old]
        for old in [s for s in self._gates if s < oldest]:
            del self._gates[old]
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
