"""While a build goes on the run writes report.json every time and redraws report.png only so often that
drawing takes at most a tenth of the run's wall time (a 12 s plot every 30 s held the run's loop still
for 40 % of a long build, on cores the services share)."""

from __future__ import annotations

import itertools
from pathlib import Path
from typing import Any

from bimbot.run.interim_reports import FIRST_PLOT_AFTER_S, PLOT_SHARE, InterimReports


def test_the_json_goes_out_every_time_the_plot_at_most_a_tenth_of_the_wall_time(tmp_path: Path) -> None:
    now = [0.0]
    written: list[tuple[str, float]] = []

    def write_json(report: dict[str, Any], folder: Path) -> None:
        assert folder == tmp_path
        written.append(("json", now[0]))

    def write_png(report: dict[str, Any], folder: Path) -> None:
        written.append(("png", now[0]))
        now[0] += 12.0  # a plot takes 12 s to draw

    reports = InterimReports(tmp_path, write_json, write_png, clock=lambda: now[0])
    for _ in range(40):  # an interim report every 30 s of wall time (the default --report-every-s)
        reports.write({"counts": {}})
        now[0] += 30.0
    jsons = [at for kind, at in written if kind == "json"]
    plots = [at for kind, at in written if kind == "png"]
    assert len(jsons) == 40
    # the first plot after FIRST_PLOT_AFTER_S: a short run pays for no plot before its last report
    assert plots[0] == min(at for at in jsons if at >= FIRST_PLOT_AFTER_S)
    assert reports.plots == len(plots) >= 3
    assert all(later - earlier >= 12.0 / PLOT_SHARE for earlier, later in itertools.pairwise(plots))
    assert 12.0 * len(plots) <= PLOT_SHARE * now[0] + 12.0  # at most a tenth of the wall time drawing
