"""Per-period wall-time sums for status lines: means per period, reset on every report."""

from __future__ import annotations

from bimbot.shared.period_times import PeriodTimes


def test_the_line_gives_each_kind_s_mean_per_period_and_starts_again() -> None:
    times = PeriodTimes()
    for advance_s, wait_s in ((0.004, 0.001), (0.006, 0.003)):
        times.add("advance", advance_s)
        times.add("wait", wait_s)
        times.period()
    assert times.take() == "advance 5.00 ms, wait 2.00 ms per period (2 periods)"
    assert times.take() == "nothing per period (0 periods)"
