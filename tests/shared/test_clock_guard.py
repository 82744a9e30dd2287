"""The clock guard believes steps that go forward, ignores late ones, rejects leaps and follows restarts."""

from __future__ import annotations

from bimbot.shared.clock_guard import ClockGuard, Verdict
from bimbot.shared.messages import ClockMsg


def clock(step: int, epoch: int = 0) -> ClockMsg:
    return ClockMsg(sim_time_s=step * 0.2, step=step, real_time_factor=0.0, epoch=epoch)


def test_steps_forward_are_accepted_and_late_ones_ignored() -> None:
    guard = ClockGuard()
    assert guard.check(clock(0), 0.0) is Verdict.ACCEPTED
    assert guard.check(clock(1), 0.1) is Verdict.ACCEPTED
    assert guard.check(clock(5), 0.2) is Verdict.ACCEPTED  # a few lost messages
    assert guard.check(clock(3), 0.3) is Verdict.OLD
    assert guard.check(clock(5), 0.3) is Verdict.OLD
    assert guard.last is not None and guard.last.step == 5


def test_a_leap_ahead_is_rejected_and_the_real_clock_goes_on() -> None:
    guard = ClockGuard(max_jump_steps=100)
    guard.check(clock(10), 0.0)
    for _ in range(3):  # forged: far ahead, yet within the message bounds (a step of 1e9 no longer decodes)
        assert guard.check(clock(40_000_000), 0.1) is Verdict.REJECTED
    assert guard.check(clock(11), 0.2) is Verdict.ACCEPTED
    assert guard.rejected == 3


def test_a_new_epoch_is_a_restart_and_an_old_epoch_is_stale() -> None:
    guard = ClockGuard()
    guard.check(clock(40, epoch=0), 0.0)
    verdict = guard.check(clock(41, epoch=1), 0.1)
    assert verdict is Verdict.RESTARTED and verdict.accepted
    assert guard.restarts == 1
    assert guard.check(clock(42, epoch=0), 0.2) is Verdict.REJECTED
    assert guard.check(clock(42, epoch=1), 0.3) is Verdict.ACCEPTED


def test_a_guard_that_rejects_everything_for_long_follows_what_it_hears() -> None:
    guard = ClockGuard(max_jump_steps=10, resync_after_s=5.0)
    guard.check(clock(1), 0.0)
    assert guard.check(clock(500), 1.0) is Verdict.REJECTED
    assert guard.check(clock(501), 3.0) is Verdict.REJECTED
    assert guard.check(clock(502), 6.0) is Verdict.RESTARTED  # never frozen for good
    assert guard.last is not None and guard.last.step == 502
