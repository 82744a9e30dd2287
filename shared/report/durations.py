"""Sim time in units a person reads: seconds, minutes, hours or days by the span it covers.

A run of lifted components lasts minutes; one with cast footings lasts days (formwork, pour, three days
of curing), and "291652 s" says neither. The report's data stay in sim seconds; the chart's axis
(:mod:`.time_axis`), its title and the run's summary say them in the unit chosen here. No
matplotlib: the run's summary imports it.
"""

from __future__ import annotations

from dataclasses import dataclass

ROUND_THE_CLOCK = " round the clock"  # what a time in days says (a builder reads "days" as working days)


@dataclass(frozen=True)
class TimeUnit:
    """A unit of the time axis: its name, its length in seconds, the spans it is used up to, and the tick
    steps (multiples within a decade, as :class:`~matplotlib.ticker.MaxNLocator` takes them) that fall on
    round values of it."""

    name: str
    seconds: float
    up_to_s: float
    steps: tuple[float, ...]


TIME_UNITS = (
    TimeUnit("s", 1.0, 600.0, (1.0, 2.0, 2.5, 5.0, 10.0)),
    TimeUnit("min", 60.0, 3.0 * 3600.0, (1.0, 1.5, 2.0, 3.0, 5.0, 6.0, 10.0)),  # 15, 30, 60 min
    TimeUnit("h", 3600.0, 4.0 * 86400.0, (1.0, 1.2, 2.0, 2.4, 3.0, 6.0, 10.0)),  # 6, 12, 24 h
    TimeUnit("days", 86400.0, float("inf"), (1.0, 2.0, 2.5, 5.0, 10.0)),
)


def time_unit(span_s: float) -> TimeUnit:
    """The unit for an axis spanning ``span_s``: seconds up to 10 min, minutes up to 3 h, hours up to 4
    days, days beyond."""
    return next(unit for unit in TIME_UNITS if span_s <= unit.up_to_s)


def format_in(unit: TimeUnit, seconds: float) -> str:
    """``seconds`` in ``unit``, without trailing zeros (``12``, ``1.5``)."""
    return f"{seconds / unit.seconds:.6g}"


def spoken_unit(seconds: float) -> TimeUnit:
    """The unit a person says ``seconds`` in: the axis's (:func:`time_unit`), with minutes only up to an
    hour."""
    unit = time_unit(seconds)
    return next(u for u in TIME_UNITS if u.name == "h") if unit.name == "min" and seconds > 3600.0 else unit


def duration_text(seconds: float) -> str:
    """A duration in the unit a person would say it in: ``45.0 s``, ``12.5 min``, ``2.0 h``, ``81.0 h``,
    ``5.2 days round the clock`` (minutes only up to an hour; the seconds too when the unit is not
    seconds: ``81.0 h (291,652 s)``). The one format of every duration in the run's summary. Sim time
    runs day and night (robots, crews and curing alike), and a trial builder read "6.6 days" as six
    working days: days are said "round the clock"."""
    return in_unit_text(seconds, spoken_unit(seconds))


def in_unit_text(seconds: float, unit: TimeUnit) -> str:
    """``seconds`` in ``unit`` as :func:`duration_text` says it: ``6.6 min (396 s)``, ``45.0 s``. A time
    shorter than one ``unit`` is said in its own when that is a smaller one (``15.6 min (935 s)``, not
    ``0.0 days (935 s)``; ``3.1 h (11,062 s)``, not ``0.1 days``: a tenth of a day hides hours); no time
    at all is ``0 s`` whatever the unit (a trial user met "busy 0.0 days (0 s)" beside "0.0 h (0 s)")."""
    if seconds == 0.0:
        return "0 s"
    own = spoken_unit(seconds)
    if 0.0 < seconds < unit.seconds and own.seconds < unit.seconds:
        unit = own
    text = f"{seconds / unit.seconds:.1f} {unit.name}"
    if unit.name == "days":  # sim time runs day and night; a builder reads "days" as working days
        text += ROUND_THE_CLOCK
    return text if unit.seconds == 1.0 else f"{text} ({seconds:,.0f} s)"


def short_duration_text(seconds: float) -> str:
    """:func:`duration_text` without the seconds in brackets, for a line redrawn while a run goes on:
    ``412 s``, ``43.8 min``, ``13.1 h``, ``5.2 days`` (whole seconds from 10 s: ``7.5 s``, ``51 s``)."""
    unit = spoken_unit(seconds)
    if unit.seconds == 1.0:
        return f"{seconds:.0f} s" if seconds >= 10.0 else f"{seconds:.1f} s"
    return f"{seconds / unit.seconds:.1f} {unit.name}"
