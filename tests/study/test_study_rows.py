"""A run's row in ``study.csv``: figures from its report, cost from the fleet's rates, or the reason it
has none (pure)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from bimbot.study.grid import StudyRun
from bimbot.study.rows import columns, cost, cost_on_site, failed_row, report_row

RUN = StudyRun(fleet=Path("/f/mixed.toml"), fleet_label="mixed", seed=2)


def _report(constructed: int = 28, seed: int | None = None) -> dict[str, Any]:
    """The parts of a ``report.json`` a row reads, as ``bimbot run`` writes them."""
    return {
        "sim_time_s": 1210.04,
        "ending": {"how": "done", "message": "the planner ended (exit 0)"},
        "settings": {"seed": seed} if seed is not None else {"profile": "rehearsal"},
        "totals": {
            "components": 28,
            "constructed": constructed,
            "makespan_s": 1167.04,
            "utilisation": 0.4912,
            "distance_m": 936.27,
            "busy_s": 1800.0,
            "by_type": {
                "carrier": {"robots": ["r2"], "busy_s": 1440.0, "utilisation": 0.6},
                "tower_crane": {"robots": ["r3"], "busy_s": 360.0, "utilisation": 0.2},
            },
        },
    }


def test_a_built_run_has_the_reports_figures_and_utilisation_per_type() -> None:
    row = report_row(
        RUN, _report(), 0, {"carrier": 60.0, "tower_crane": 150.0}, wall_s=153.42, run_dir="runs/mixed-2"
    )
    assert row["status"] == "built" and row["reason"] == ""
    assert (row["fleet"], row["seed"], row["fidelity"]) == ("mixed", 2, "physics")
    assert (row["constructed"], row["components"], row["makespan_s"]) == (28, 28, 1167.0)
    assert (row["utilisation_carrier"], row["utilisation_tower_crane"]) == (0.6, 0.2)
    assert row["distance_m"] == 936.3 and row["busy_h"] == 0.5
    assert row["cost"] == pytest.approx(60.0 * 0.4 + 150.0 * 0.1)  # busy hours × rate
    assert row["cost_on_site"] == pytest.approx((60.0 + 150.0) * 1167.04 / 3600, abs=0.01)
    assert row["wall_s"] == 153.4 and row["run_dir"] == "runs/mixed-2"


def test_the_seed_reached_the_run_only_when_its_report_names_it() -> None:
    rates = {"carrier": 60.0, "tower_crane": 150.0}
    assert report_row(RUN, _report(), 0, rates, wall_s=1.0, run_dir="r")["seed_reached_run"] is False
    assert report_row(RUN, _report(seed=2), 0, rates, wall_s=1.0, run_dir="r")["seed_reached_run"] is True
    assert report_row(RUN, _report(seed=1), 0, rates, wall_s=1.0, run_dir="r")["seed_reached_run"] is False


def test_a_run_that_did_not_build_everything_is_incomplete_with_its_ending() -> None:
    report = _report(constructed=20) | {"ending": {"how": "stalled", "message": "nothing changed for 1500 s"}}
    row = report_row(RUN, report, 1, {}, wall_s=1.0, run_dir="r")
    assert row["status"] == "incomplete" and row["reason"] == "nothing changed for 1500 s"
    assert row["constructed"] == 20 and row["makespan_s"] == 1167.0


def test_cost_is_empty_when_a_type_that_worked_has_no_rate() -> None:
    by_type = _report()["totals"]["by_type"]
    assert cost(by_type, {"carrier": 60.0}) is None
    assert cost_on_site(by_type, {"carrier": 60.0, "tower_crane": None}, 3600.0) is None
    assert cost_on_site(by_type, {"carrier": 60.0, "tower_crane": 150.0}, None) is None
    assert cost_on_site(by_type, {"carrier": 60.0, "tower_crane": 150.0}, 3600.0) == 210.0


def test_a_failed_run_is_a_row_with_its_reason_and_no_figures() -> None:
    row = failed_row(RUN, "no report (exit 2): bimbot run: error: no build", 2, 3.2, "runs/mixed-2")
    assert row["status"] == "failed" and row["reason"].startswith("no report (exit 2)")
    assert row["makespan_s"] is None and row["constructed"] is None and row["exit_code"] == 2


def test_columns_have_one_utilisation_per_type_seen_in_any_row() -> None:
    rows = [
        report_row(RUN, _report(), 0, {}, wall_s=1.0, run_dir="r"),
        failed_row(RUN, "x", 1, 1.0, "r"),
    ]
    names = columns(rows)
    assert names.index("utilisation") < names.index("utilisation_carrier") < names.index("distance_m")
    assert "utilisation_tower_crane" in names and names[-2:] == ["wall_s", "run_dir"]
