"""The study's CSV, markdown table and plot over its rows (pure, files in a temporary folder)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from bimbot.study.summary import by_scenario, markdown_table, read_csv, write_csv, write_plot


def _row(fleet: str, seed: int, makespan: float | None, status: str = "built", **more: Any) -> dict[str, Any]:
    return {
        "fleet": fleet,
        "sequence": "build",
        "seed": seed,
        "fidelity": "physics",
        "status": status,
        "reason": "" if status == "built" else "no report (exit 2): broken",
        "makespan_s": makespan,
        "distance_m": None if makespan is None else 100.0 * seed,
        "cost": None,
        **more,
    }


ROWS = [
    _row("carriers", 1, 1000.0, utilisation_carrier=0.5),
    _row("carriers", 2, 1100.0, utilisation_carrier=0.7),
    _row("carriers", 3, 1200.0, utilisation_carrier=0.6),
    _row("mixed", 1, 900.0, utilisation_carrier=0.4, utilisation_tower_crane=0.1),
    _row("mixed", 2, None, status="failed"),
]


def test_the_table_has_a_line_per_scenario_with_the_makespan_spread_and_utilisation_per_type() -> None:
    table = markdown_table(ROWS)
    lines = table.splitlines()
    assert lines[0].startswith("| scenario | runs built | makespan s")
    assert "util. carrier" in lines[0] and "util. tower_crane" in lines[0]
    carriers = next(line for line in lines if line.startswith("| carriers |"))
    assert "| 3/3 | 1100 ± 100 (1000–1200) | 60 % |" in carriers
    mixed = next(line for line in lines if line.startswith("| mixed |"))
    assert "| 1/2 | 900 | 40 % | 10 % |" in mixed  # the failed run counts, its empty figures do not
    assert "- mixed, seed 2 (failed): no report (exit 2): broken" in table


def test_sequences_and_fidelities_other_than_the_default_make_their_own_scenarios() -> None:
    rows = [_row("a", 1, 10.0), _row("a", 1, 12.0, sequence="derive"), _row("a", 1, 9.0, fidelity="plan")]
    assert list(by_scenario(rows)) == ["a", "a / derive", "a / plan"]


def test_the_csv_keeps_every_row_and_writes_missing_figures_as_empty_cells(tmp_path: Path) -> None:
    path = tmp_path / "study.csv"
    write_csv(ROWS, path)
    back = read_csv(path)
    assert [(row["fleet"], row["seed"], row["status"]) for row in back] == [
        (str(r["fleet"]), str(r["seed"]), r["status"]) for r in ROWS
    ]
    assert back[4]["makespan_s"] == "" and back[3]["utilisation_tower_crane"] == "0.1"
    assert back[0]["utilisation_tower_crane"] == ""


def test_the_plot_is_a_png(tmp_path: Path) -> None:
    path = tmp_path / "study.png"
    low_s, high_s = write_plot(ROWS, path)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 10_000
    highest = max(float(row["makespan_s"]) for row in ROWS if row["makespan_s"] not in ("", None))
    assert low_s == 0 and high_s > 1.05 * highest  # from zero, and the highest run not at the edge


def test_the_utilisation_legend_covers_no_bar(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A type busy 84 % of the makespan drew its bar under the legend: the legend has a band of its own
    above 100 %, and no bar's box meets the legend's."""
    from matplotlib.figure import Figure
    from matplotlib.patches import Rectangle

    drawn: list[Figure] = []
    save = Figure.savefig
    monkeypatch.setattr(Figure, "savefig", lambda self, *a, **k: (drawn.append(self), save(self, *a, **k)))
    busy = [{**row, "utilisation_husky": 0.99} for row in ROWS]
    write_plot(busy, tmp_path / "study.png")
    (figure,) = drawn
    renderer = figure._get_renderer()  # the one the saved image was drawn with
    axes = figure.axes[1]
    legend = axes.get_legend().get_window_extent(renderer)
    bars = [patch for patch in axes.patches if isinstance(patch, Rectangle) and patch.get_height() > 0]
    assert bars and axes.get_ylim()[1] > 100
    assert not any(bar.get_window_extent(renderer).overlaps(legend) for bar in bars)
