"""Pacing and lock-step bookkeeping for the sim clock: pure, wall time passed in, nothing sleeps here.

* :class:`Pacer` — how long to wait before the next control period so that sim time runs at ``rtf`` × wall
  time (``rtf`` 0: never wait). When the simulation falls behind by more than ``max_lag_s`` it rebases
  instead of bursting to catch up.
* :class:`RtfMeter` — the real-time factor actually achieved over the last periods (for ``ClockMsg``).
* :class:`LockStepBarrier` — after clock step ``k`` is published, physics waits until every robot it waits
  for has answered step ``k`` (a ``CmdVelMsg`` with ``step >= k``), or until ``timeout_s`` wall seconds
  have passed (then it warns and goes on with the last commands).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable

from bimbot.shared.step_gate import DELAY_STEPS

from .sleepers import Sleepers


class Pacer:
    def __init__(self, rtf: float, max_lag_s: float = 1.0) -> None:
        if rtf < 0.0:
            raise ValueError("real-time factor must be >= 0 (0: as fast as possible)")
        self.rtf = rtf
        self.max_lag_s = max_lag_s
        self._wall0: float | None = None
        self._sim0 = 0.0

    def rebase(self) -> None:
        """Pace on from the next period as if it were the first (the clock jumped over a quiet site)."""
        self._wall0 = None

    def delay_s(self, sim_time_s: float, now_wall_s: float) -> float:
        """Wall seconds to wait before simulating past ``sim_time_s`` (0 when due or unpaced)."""
        if self.rtf == 0.0:
            return 0.0
        if self._wall0 is None:
            self._wall0, self._sim0 = now_wall_s, sim_time_s
            return 0.0
        due = self._wall0 + (sim_time_s - self._sim0) / self.rtf
        if now_wall_s - due > self.max_lag_s:  # far behind: do not burst, pace on from here
            self._wall0, self._sim0 = now_wall_s, sim_time_s
            return 0.0
        return max(0.0, due - now_wall_s)


class RtfMeter:
    """Sim seconds per wall second over the last ``window`` periods."""

    def __init__(self, initial: float, window: int = 20) -> None:
        self._samples: deque[tuple[float, float]] = deque(maxlen=window + 1)
        self.value = initial

    def record(self, sim_time_s: float, wall_s: float) -> float:
        self._samples.append((sim_time_s, wall_s))
        if len(self._samples) >= 2:
            (sim0, wall0), (sim1, wall1) = self._samples[0], self._samples[-1]
            if wall1 > wall0:
                self.value = (sim1 - sim0) / (wall1 - wall0)
        return self.value


class LockStepBarrier:
    def __init__(self, timeout_s: float = 2.0) -> None:
        self.timeout_s = timeout_s
        self.step = 0
        self._opened_wall_s: float | None = None
        self._answered: dict[str, int] = {}
        self.sleepers = Sleepers()  # idle robots not waited for (.sleepers)

    def record(
        self, robot_id: str, step: int | None, *, sleeps: bool = False, wakes_at_s: float | None = None
    ) -> None:
        """A command from ``robot_id`` answering clock step ``step`` (None: not a lock-step command);
        ``sleeps``: it answers no step after it until a wake (or the first step at ``wakes_at_s``)."""
        if step is None:
            return
        if step > self._answered.get(robot_id, -1):
            self._answered[robot_id] = step
        self.sleepers.answered(self._answered, robot_id, step, sleeps=sleeps, wakes_at_s=wakes_at_s)

    def publishing(self, step: int, sim_time_s: float) -> None:
        """Clock step ``step`` is about to be published: the sleepers whose own wake it reaches wake."""
        self.sleepers.published(self._answered, step, sim_time_s)

    def wake_sleepers(self, step: int) -> None:
        """The sleepers answer again from clock step ``step`` on (a task message is taken there)."""
        self.sleepers.wake(self._answered, step)
        self.sleepers.forget_before(self.step - 2 * DELAY_STEPS)  # a sleep said from now on is later

    def wake_one(self, robot_id: str, step: int) -> None:
        """``robot_id``, asleep, answers again from clock step ``step`` on (the one being published)."""
        self.sleepers.wake_one(self._answered, robot_id, step)

    def open(self, step: int, now_wall_s: float) -> None:
        """Clock step ``step`` was just published; start waiting for its answers."""
        self.step = step
        self._opened_wall_s = now_wall_s

    def missing(self, waited_for: Iterable[str]) -> list[str]:
        """The robots in ``waited_for`` that have not answered the open step yet (sorted)."""
        asleep = self.sleepers.asleep
        return sorted(r for r in waited_for if self._answered.get(r, -1) < self.step and r not in asleep)

    def timed_out(self, now_wall_s: float) -> bool:
        return self._opened_wall_s is not None and now_wall_s - self._opened_wall_s >= self.timeout_s

    def waited_s(self, now_wall_s: float) -> float:
        """Wall seconds since the open step was published (0 before the first)."""
        return 0.0 if self._opened_wall_s is None else max(0.0, now_wall_s - self._opened_wall_s)

    def remaining_s(self, now_wall_s: float) -> float:
        if self._opened_wall_s is None:
            return self.timeout_s
        return max(0.0, self._opened_wall_s + self.timeout_s - now_wall_s)
