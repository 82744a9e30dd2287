"""Which idle robots sleep at a clock step, and the latest wake a clock says (pure; physics' bookkeeping).

Why: a robot with nothing to do (no task, parked, nothing asked) still cost every step: its answer, and
physics' wait for it. It says in its answer to step ``s`` that it sleeps (``CmdVelMsg.sleeps``): from
``s + 1`` on physics neither waits for it nor sends it its sensors, until the planner's answer to a step
``j`` says it sent a task message (``StepDoneMsg.wakes``); every sleeper wakes at ``j + DELAY_STEPS``,
the step that takes that message, and is waited for again from there. Reckoned by step numbers, so the
order in which a sleep and a wake arrive changes nothing. Each clock says the latest wake at or before its
step (:meth:`Sleepers.latest_wake`): physics sends clock ``k`` only after the planner's answer to
``k − DELAY_STEPS``, so it knows every wake up to ``k`` by then, and a robot tells from the clock alone
whether it woke (:func:`bimbot.shared.step_gate.woken`). A kinematic robot that drives may sleep too
(``CmdVelMsg.wakes_at_s``, plan fidelity): it also wakes at the first step whose sim time reaches the end
of its drive, which physics and the robot both tell from that step's clock (:meth:`Sleepers.published`),
or at a step physics wakes it alone (:meth:`Sleepers.wake_one`: a part came to rest across its way,
:mod:`.crossed_drives`); the clock in that robot's sensors then names that step as its latest wake
(:meth:`Sleepers.latest_wake_for`). See :mod:`bimbot.shared.step_gate`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from bimbot.shared.step_gate import DELAY_STEPS, SLEEP_TAKE_STEPS


@dataclass
class Sleepers:
    """Who sleeps (participant → the step it fell asleep after) and the steps the sleepers wake at; the
    answers are the caller's (participant → the last step it answered), moved on at a wake."""

    asleep: dict[str, int] = field(default_factory=dict)
    wakes: set[int] = field(default_factory=set)
    wakes_at_s: dict[str, float] = field(default_factory=dict)  # a sleeper's own wake, in sim time
    # the sim time of the latest published clock steps: a step published before a sleep was heard may be
    # the one it wakes at (physics publishes step k once it heard the answers to k - 2)
    _published: dict[int, float] = field(default_factory=dict)
    _forgotten: int | None = None  # the latest wake no longer kept (a clock may still name it)
    woken_alone: dict[str, int] = field(default_factory=dict)  # participant → the step it last woke alone

    def answered(
        self,
        answered: dict[str, int],
        participant: str,
        step: int,
        *,
        sleeps: bool,
        wakes_at_s: float | None = None,
    ) -> None:
        """``participant`` answered ``step``, asleep after it or not; ``wakes_at_s``: asleep until the first
        step whose sim time reaches it at the latest."""
        if sleeps:
            self.asleep[participant] = max(step, self.asleep.get(participant, step))
            if wakes_at_s is None:
                self.wakes_at_s.pop(participant, None)
            else:
                self.wakes_at_s[participant] = wakes_at_s
            self._settle(answered, participant)
        elif step > self.asleep.get(participant, step):
            del self.asleep[participant]  # awake again (it restarted, say): its answers count as they come
            self.wakes_at_s.pop(participant, None)

    def published(self, answered: dict[str, int], step: int, sim_time_s: float) -> None:
        """Clock ``step`` (at ``sim_time_s``) is being published: a sleeper whose own wake it reaches is
        awake from it (sent its sensors, waited for)."""
        self._published[step] = sim_time_s
        for old in [known for known in self._published if known < step - 2 * DELAY_STEPS]:
            del self._published[old]
        for participant in [p for p, at_s in self.wakes_at_s.items() if at_s <= sim_time_s]:
            if participant in self.asleep:
                self._settle(answered, participant)

    def wake(self, answered: dict[str, int], step: int) -> None:
        """Every participant asleep before ``step`` answers again from ``step`` on."""
        self.wakes.add(step)
        for participant in list(self.asleep):
            self._settle(answered, participant)

    def wake_one(self, answered: dict[str, int], participant: str, step: int) -> None:
        """``participant``, asleep before ``step``, answers again from ``step`` on (the others sleep on)."""
        since = self.asleep.get(participant)
        if since is None or since >= step:
            return
        del self.asleep[participant]
        self.wakes_at_s.pop(participant, None)
        self.woken_alone[participant] = step
        answered[participant] = max(answered.get(participant, -1), step - 1)

    def latest_wake_for(self, participant: str, step: int) -> int | None:
        """The latest wake at or before ``step`` that woke ``participant``: every sleeper's, or its own
        (what the clock in its sensors at ``step`` says)."""
        alone = self.woken_alone.get(participant)
        common = self.latest_wake(step)
        if alone is None or alone > step:
            return common
        return alone if common is None else max(alone, common)

    def asleep_driving(self) -> dict[str, int]:
        """The sleepers with a wake of their own ahead (robots asleep through a drive, or a wait of their
        own) → the step they fell asleep after."""
        asleep = self.asleep
        return {participant: asleep[participant] for participant in self.wakes_at_s if participant in asleep}

    def latest_wake(self, step: int) -> int | None:
        """The latest wake at or before ``step`` (what clock ``step`` says), None before the first."""
        return max((wake for wake in self.wakes if wake <= step), default=self._forgotten)

    def forget_before(self, step: int) -> None:
        """Wakes before ``step`` are for sleeps long said (a sleep said from now on is later)."""
        old = [wake for wake in self.wakes if wake < step]
        if old:
            self._forgotten = max(old)
            self.wakes.difference_update(old)

    def sends_sensors(self, robot_id: str, step: int) -> bool:
        """Whether physics sends ``robot_id`` its sensors at ``step``: not to one asleep with no wake ahead
        that it knows of, but every ``SLEEP_TAKE_STEPS``-th step all the same (it takes its inputs there)."""
        return robot_id not in self.asleep or step % SLEEP_TAKE_STEPS == 0

    def _settle(self, answered: dict[str, int], participant: str) -> None:
        """A sleeper with a wake after its sleep: awake from that wake, its answers waited for from there."""
        since = self.asleep[participant]
        wake = min((w for w in self.wakes if w > since), default=None)
        if (at_s := self.wakes_at_s.get(participant)) is not None:
            reached = [step for step, sim_s in self._published.items() if step > since and sim_s >= at_s]
            wake = min([*reached, *([] if wake is None else [wake])], default=None)
        if wake is not None:
            del self.asleep[participant]
            self.wakes_at_s.pop(participant, None)
            answered[participant] = max(answered.get(participant, -1), wake - 1)
