"""Which clock messages a consumer believes: a step never goes back, never leaps, and a restart is an epoch.

Physics publishes ``ClockMsg(step, epoch)`` once per control period. A consumer (robot, planner, agents,
the run monitor) feeds every clock message it receives to a :class:`ClockGuard` and acts only on those
it accepts:

* the first message is accepted;
* same epoch: a step above the last accepted one and at most ``max_jump_steps`` above it is accepted; an
  older or repeated step is ignored quietly (late delivery), a leap further ahead is rejected (a forged or
  corrupt clock must not freeze a robot that answers only steps above its last);
* a higher epoch is a physics restart: accepted, and the consumer resets what it keeps per step
  (:attr:`Verdict.restarted`); a lower epoch is a stale or forged message: rejected;
* if nothing was accepted for ``resync_after_s`` wall seconds while messages kept being rejected, the
  guard follows the clock it hears (logged as a warning): a guard never freezes a consumer for good.

Pure: wall time is passed in.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from enum import StrEnum

from .messages import ClockMsg

_log = logging.getLogger(__name__)

MAX_JUMP_STEPS = 3000  # 5 min of sim time at a 0.1 s control period: far beyond any lost messages
RESYNC_AFTER_S = 10.0


class Verdict(StrEnum):
    ACCEPTED = "accepted"
    RESTARTED = "restarted"  # a new epoch (physics restarted): accepted, per-step state must be reset
    OLD = "old"  # an older or repeated step of the current epoch: ignored
    REJECTED = "rejected"  # a leap ahead or a stale epoch: not believed

    @property
    def accepted(self) -> bool:
        return self in (Verdict.ACCEPTED, Verdict.RESTARTED)


@dataclass
class ClockGuard:
    """The last believed clock (``last``) and the rules above; ``name`` says whose guard it is in logs."""

    name: str = "clock"
    max_jump_steps: int = MAX_JUMP_STEPS
    resync_after_s: float = RESYNC_AFTER_S
    last: ClockMsg | None = None
    rejected: int = 0
    restarts: int = 0
    _last_accept_wall_s: float = 0.0
    _rejecting_since_s: float | None = None

    def check(self, clock: ClockMsg, now_wall_s: float) -> Verdict:
        """Judge ``clock``; on acceptance it becomes :attr:`last`."""
        verdict = self._judge(clock)
        if verdict is Verdict.REJECTED:
            if self._rejecting_since_s is None:
                self._rejecting_since_s = now_wall_s
            if now_wall_s - max(self._rejecting_since_s, self._last_accept_wall_s) >= self.resync_after_s:
                _log.warning(
                    "%s: no believable clock for %.0f s; following step %d of epoch %d",
                    self.name,
                    self.resync_after_s,
                    clock.step,
                    clock.epoch,
                )
                verdict = Verdict.RESTARTED
            else:
                self.rejected += 1
                if self.rejected <= 3 or self.rejected % 100 == 0:
                    _log.warning(
                        "%s: rejected clock step %d epoch %d (believed: step %d epoch %d; #%d)",
                        self.name,
                        clock.step,
                        clock.epoch,
                        self.last.step if self.last else -1,
                        self.last.epoch if self.last else -1,
                        self.rejected,
                    )
                return verdict
        if verdict.accepted:
            if verdict is Verdict.RESTARTED:
                self.restarts += 1
                _log.info("%s: physics epoch %d from step %d", self.name, clock.epoch, clock.step)
            self.last = clock
            self._last_accept_wall_s = now_wall_s
            self._rejecting_since_s = None
        return verdict

    def _judge(self, clock: ClockMsg) -> Verdict:
        last = self.last
        if last is None:
            return Verdict.ACCEPTED
        if clock.epoch > last.epoch:
            return Verdict.RESTARTED
        if clock.epoch < last.epoch:
            return Verdict.REJECTED
        if clock.step <= last.step:
            return Verdict.OLD
        if clock.step - last.step > self.max_jump_steps:
            return Verdict.REJECTED
        return Verdict.ACCEPTED
