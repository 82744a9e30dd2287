"""report.png's time axis: a wait with no robot at work longer than a fifth of the span is drawn narrow, and
the busy stretches share the axis by their length and their tasks; else the axis stays linear."""

from __future__ import annotations

import numpy as np
import pytest

from bimbot.shared.report.time_breaks import BREAK_WIDTH, find_breaks


def test_work_that_fills_the_span_keeps_a_linear_axis() -> None:
    breaks = find_breaks([(0.0, 400.0), (500.0, 1000.0)], 1000.0)  # a 100 s wait: 10 % of the span
    assert breaks.breaks == ()
    np.testing.assert_allclose(breaks.forward([-5.0, 0.0, 700.0, 1010.0]), [-5.0, 0.0, 700.0, 1010.0])
    assert breaks.scale_at(300.0) == 1.0 and breaks.shown_s == 1000.0


def test_a_long_wait_takes_its_share_of_the_axis_and_the_work_after_it_the_rest() -> None:
    # one 10 h pour, a 120 h cure, then 60 lifts of a minute each within an hour
    lifts = [(468_000.0 + 60.0 * i, 468_030.0 + 60.0 * i) for i in range(60)]
    span_s = lifts[-1][1]
    breaks = find_breaks([(0.0, 36_000.0), *lifts], span_s)
    assert breaks.breaks == ((36_000.0, 468_000.0),)
    at = breaks.forward([0.0, 36_000.0, 468_000.0, span_s]) / breaks.shown_s  # fractions of the axis
    assert at[2] - at[1] == pytest.approx(BREAK_WIDTH)
    pour, lifted = at[1] - at[0], at[3] - at[2]
    assert lifted > 0.45 and pour > 0.4  # half by tasks: the hour of lifts is no sliver beside the pour
    times = np.array([10.0, 36_000.0, 200_000.0, 468_100.0, span_s + 50.0])
    np.testing.assert_allclose(breaks.inverse(breaks.forward(times)), times)
    assert breaks.scale_at(200_000.0) < 0.01 < breaks.scale_at(468_100.0)  # the wait drawn narrow
