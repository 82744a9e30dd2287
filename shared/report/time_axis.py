"""``report.png``'s time axis: the data in sim seconds, the ticks at round values of the unit a person
reads for the span shown (15 min, 6 h, 12 h, half a day …; :mod:`.durations`), labelled in it."""

from __future__ import annotations

from matplotlib.axes import Axes
from matplotlib.ticker import FuncFormatter, Locator, MaxNLocator

from .durations import TimeUnit, format_in, time_unit


class UnitLocator(Locator):
    """Ticks at round values of ``unit`` on an axis whose data are seconds."""

    def __init__(self, unit: TimeUnit, bins: int = 8) -> None:
        self.unit = unit
        self._inner = MaxNLocator(nbins=bins, steps=list(unit.steps))

    def __call__(self) -> list[float]:
        low, high = self.axis.get_view_interval() if self.axis is not None else (0.0, 1.0)
        return self.tick_values(low, high)

    def tick_values(self, vmin: float, vmax: float) -> list[float]:
        scale = self.unit.seconds
        return [float(tick) * scale for tick in self._inner.tick_values(vmin / scale, vmax / scale)]


def set_time_axis(ax: Axes, span_s: float) -> TimeUnit:
    """Ticks and label of ``ax``'s x axis (sim seconds) in the unit for ``span_s``; the unit."""
    unit = time_unit(span_s)
    ax.xaxis.set_major_locator(UnitLocator(unit))
    ax.xaxis.set_major_formatter(FuncFormatter(lambda value, _: format_in(unit, value)))
    ax.set_xlabel(f"sim time ({unit.name})")
    return unit
