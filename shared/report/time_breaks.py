"""``report.png``'s time axis with long waits drawn narrow, so the work before and after days of curing
still reads.

A *break* is a stretch of the chart's span in which no robot has a task, longer than ``BREAK_MIN_FRACTION``
of the span (a cure, a run that waited for something). On the axis each break takes ``BREAK_WIDTH`` of
the axis' width whatever its length, drawn as a grey band labelled with how long it lasts; the busy
stretches share the rest, half by their length and half by their tasks. The scale differs between
stretches, so bar widths and labels are sized in axis units (:meth:`TimeBreaks.scale_at`). Ticks fall
within the busy stretches on round values of the unit of the longest one. With no break the axis is the
linear one of :mod:`.time_axis`.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.ticker import FixedLocator, FuncFormatter, MaxNLocator
from numpy.typing import ArrayLike, NDArray

from .durations import duration_text, format_in, time_unit
from .time_axis import set_time_axis

BREAK_MIN_FRACTION = 0.2  # a wait longer than this share of the span is drawn narrow
BREAK_WIDTH = 0.06  # of the axis' width, per break
BREAK_COLOR = "0.85"
TICKS_PER_AXIS = 8


@dataclass(frozen=True)
class TimeBreaks:
    """The breaks ``(start_s, end_s)`` of a span ``[0, span_s]``, in order, and the axis widths of the busy
    stretches between them (axis units; none: a linear axis); maps sim s ↔ axis units."""

    span_s: float
    breaks: tuple[tuple[float, float], ...] = ()
    busy_widths: tuple[float, ...] = ()

    @property
    def break_width(self) -> float:
        """How wide one break is drawn (axis units)."""
        return BREAK_WIDTH * sum(self.busy_widths) / (1.0 - BREAK_WIDTH * len(self.breaks))

    @property
    def shown_s(self) -> float:
        """The axis' length in its own units (the span on a linear axis)."""
        if not self.breaks:
            return self.span_s
        return sum(self.busy_widths) + len(self.breaks) * self.break_width

    def busy(self) -> list[tuple[float, float]]:
        """The stretches between the breaks (the whole span without one)."""
        edges = [0.0, *(t for pair in self.breaks for t in pair), self.span_s]
        return [(edges[i], edges[i + 1]) for i in range(0, len(edges), 2) if edges[i + 1] > edges[i]]

    def _knots(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Sim times and axis positions where the scale changes, with a slope of 1 beyond the span."""
        if not self.breaks:
            return np.array([0.0, 1.0]), np.array([0.0, 1.0])
        sim, shown = [0.0], [0.0]
        widths = iter(self.busy_widths)
        for start, end in self.busy():
            if start > sim[-1]:  # a break before this stretch
                sim.append(start)
                shown.append(shown[-1] + self.break_width)
            sim.append(end)
            shown.append(shown[-1] + next(widths))
        if self.span_s > sim[-1]:  # a break at the end
            sim.append(self.span_s)
            shown.append(shown[-1] + self.break_width)
        return np.asarray(sim), np.asarray(shown)

    def forward(self, sim_s: ArrayLike) -> NDArray[np.float64]:
        sim, shown = self._knots()
        return _interp(np.asarray(sim_s, float), sim, shown)

    def inverse(self, shown_s: ArrayLike) -> NDArray[np.float64]:
        sim, shown = self._knots()
        return _interp(np.asarray(shown_s, float), shown, sim)

    def scale_at(self, sim_s: float) -> float:
        """Axis units per sim second at ``sim_s`` (1 on a linear axis)."""
        sim, shown = self._knots()
        index = int(np.clip(np.searchsorted(sim, sim_s, side="right") - 1, 0, len(sim) - 2))
        return float((shown[index + 1] - shown[index]) / (sim[index + 1] - sim[index]))


def _interp(x: NDArray[np.float64], xp: NDArray[np.float64], fp: NDArray[np.float64]) -> NDArray[np.float64]:
    """Piecewise linear through (xp, fp), extended beyond both ends with the end segments' slopes (the
    axis' margins lie outside the span)."""
    inside = np.interp(x, xp, fp)
    low = fp[0] + (x - xp[0]) * (fp[1] - fp[0]) / (xp[1] - xp[0])
    high = fp[-1] + (x - xp[-1]) * (fp[-1] - fp[-2]) / (xp[-1] - xp[-2])
    return np.where(x < xp[0], low, np.where(x > xp[-1], high, inside))


def task_intervals(report: dict[str, Any]) -> list[tuple[float, float]]:
    """Every robot task of ``report`` as ``(start_s, end_s)``."""
    return [
        (float(task["start_s"]), float(task["end_s"]))
        for robot in report["robots"].values()
        for task in robot["tasks"]
    ]


def find_breaks(intervals: Iterable[tuple[float, float]], span_s: float) -> TimeBreaks:
    """The waits of ``[0, span_s]`` outside every interval (robots' tasks) longer than
    ``BREAK_MIN_FRACTION`` of the span. The busy stretches between them share the axis half by their
    length and half by their tasks: an hour of 66 lifts after ten hours of one pour gets half the axis,
    not a tenth."""
    tasks = sorted(intervals)
    breaks: list[tuple[float, float]] = []
    reached_s = 0.0
    for start, end in [*tasks, (span_s, span_s)]:
        if start - reached_s > BREAK_MIN_FRACTION * span_s:
            breaks.append((reached_s, start))
        reached_s = max(reached_s, end)
    stretches = TimeBreaks(span_s, tuple(breaks)).busy()
    if not breaks or not stretches:  # nothing narrowed, or no robot worked at all: a linear axis
        return TimeBreaks(span_s)
    lengths = [end - start for start, end in stretches]
    counts = [sum(start <= t[0] <= end for t in tasks) for start, end in stretches]
    busy_s = sum(lengths)
    total = sum(counts)
    widths = tuple(
        busy_s * (length / busy_s + (count / total if total else length / busy_s)) / 2
        for length, count in zip(lengths, counts, strict=True)
    )
    return TimeBreaks(span_s, tuple(breaks), widths)


def set_broken_time_axis(ax: Axes, breaks: TimeBreaks) -> None:
    """``ax``'s x axis (sim seconds) with ``breaks`` drawn narrow: ticks within the busy stretches, a grey
    band labelled with its length over each break. Linear (:func:`.time_axis.set_time_axis`) without one."""
    if not breaks.breaks:
        set_time_axis(ax, breaks.span_s)
        return
    ax.set_xscale("function", functions=(breaks.forward, breaks.inverse))
    busy = breaks.busy()
    unit = time_unit(max(end - start for start, end in busy))
    ticks: list[float] = []
    for (start, end), width in zip(busy, breaks.busy_widths, strict=True):
        bins = max(1, round(TICKS_PER_AXIS * width / breaks.shown_s))
        inner = MaxNLocator(nbins=bins, steps=list(unit.steps))
        ticks += [
            float(t) * unit.seconds
            for t in inner.tick_values(start / unit.seconds, end / unit.seconds)
            if start <= t * unit.seconds <= end
        ]
    ax.xaxis.set_major_locator(FixedLocator(ticks))
    ax.xaxis.set_major_formatter(FuncFormatter(lambda value, _: format_in(unit, value)))
    ax.xaxis.set_minor_locator(FixedLocator([]))
    ax.set_xlabel(f"sim time ({unit.name}); grey: long waits, narrowed")
    for start, end in breaks.breaks:
        ax.axvspan(start, end, color=BREAK_COLOR, alpha=0.6, linewidth=0, zorder=0)
        middle = float(breaks.inverse(breaks.forward([start, end]).mean()))
        ax.text(
            middle,
            0.5,
            f"{duration_text(end - start).split(' (')[0]} wait",
            transform=ax.get_xaxis_transform(),
            rotation=90,
            ha="center",
            va="center",
            fontsize=8,
            color="0.3",
            bbox={"facecolor": BREAK_COLOR, "edgecolor": "none", "pad": 1.0},
        )
