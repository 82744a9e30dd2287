"""The reports ``bimbot run`` writes while a build goes on (every ``--report-every-s``): a run killed
without warning still leaves one.

``report.json`` is written every time (milliseconds). ``report.png`` takes seconds to draw (12 s for the
bundled frame on a loaded 2-core machine), and the run's waiting loop stands still meanwhile while the
services share the same cores; so the plot is redrawn at most so often that drawing it takes no more than
``PLOT_SHARE`` of the run's wall time: after a draw of ``d`` seconds the next one is due ``d / PLOT_SHARE
- d`` seconds later at the earliest; the first one ``FIRST_PLOT_AFTER_S`` after the first report. The
report at the end is always drawn whole (:mod:`.build`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

PLOT_SHARE = 0.1  # the most of the run's wall time the interim plots may take
# the first interim plot comes no sooner (wall s from the first interim report): a short run (the plan
# fidelity of a small building) ends before it, and pays neither matplotlib's import nor a draw meanwhile
FIRST_PLOT_AFTER_S = 120.0

Writer = Callable[[dict[str, Any], Path], None]


@dataclass
class InterimReports:
    """Writes each interim report's JSON, and its plot when one is due (see the module docstring)."""

    report_dir: Path
    write_json: Writer
    write_png: Writer
    clock: Callable[[], float] = time.monotonic
    plots: int = 0  # plots drawn so far
    _plot_due_s: float | None = field(default=None)

    def write(self, report: dict[str, Any]) -> None:
        self.write_json(report, self.report_dir)
        started = self.clock()
        if self._plot_due_s is None:
            self._plot_due_s = started + FIRST_PLOT_AFTER_S
        if started < self._plot_due_s:
            return
        self.write_png(report, self.report_dir)
        ended = self.clock()
        self.plots += 1
        self._plot_due_s = ended + (ended - started) * (1.0 / PLOT_SHARE - 1.0)
