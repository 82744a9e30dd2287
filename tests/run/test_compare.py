"""``bimbot compare``: two runs side by side by construction method (bimbot/compare_cli.py,
shared/report/compare.py), from hand-made reports shaped as report.json is."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import pytest

from bimbot import compare_cli
from bimbot.shared.errors import UserError
from bimbot.shared.report.compare import by_method


def _component(method: str, state: str = "constructed", **times: object) -> dict[str, object]:
    return {"method": method, "state": state, **times}


PREFAB = {
    "totals": {"makespan_s": 1000.0, "constructed": 3, "components": 3},
    "components": [
        _component("lifted", picked_s=100.0, placed_s=160.0),
        _component("lifted", picked_s=200.0, placed_s=240.0),
        _component("panelised", picked_s=300.0, placed_s=400.0),
    ],
}
CONVENTIONAL = {
    "totals": {"makespan_s": 5000.0, "constructed": 3, "components": 4},
    "components": [
        _component("lifted", picked_s=4000.0, placed_s=4050.0),
        _component(
            "cast_in_place",
            forming_s=10.0,
            pouring_s=500.0,
            placed_s=900.0,
            curing={"from_s": 900.0, "until_s": 3900.0},
        ),
        _component("laid", laying_s=1000.0, placed_s=1600.0),
        _component("laid", state="failed", laying_s=2000.0, placed_s=None),
    ],
}


def test_each_method_sums_its_own_work_and_keeps_its_longest_cure() -> None:
    figures = by_method(CONVENTIONAL)
    assert figures["cast_in_place"].work_s == pytest.approx(890.0)  # formwork and pour
    assert figures["cast_in_place"].cure_s == pytest.approx(3000.0)
    assert (figures["laid"].components, figures["laid"].constructed) == (2, 1)
    assert figures["laid"].work_s == pytest.approx(600.0)  # what was built only
    prefab = by_method(PREFAB)
    assert prefab["lifted"].work_s == pytest.approx(100.0)
    assert prefab["lifted"].span_s == pytest.approx(140.0)  # first pick to last placement
    assert prefab["panelised"].work_s == pytest.approx(100.0)


def _run_folder(root: Path, name: str, report: dict[str, object]) -> Path:
    folder = root / name
    (folder / "report").mkdir(parents=True)
    (folder / "report" / "report.json").write_text(json.dumps(report), encoding="utf-8")
    return folder


def test_the_table_has_a_row_per_method_and_the_makespan_against_the_first(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    a, b = _run_folder(tmp_path, "prefab", PREFAB), _run_folder(tmp_path, "conventional", CONVENTIONAL)
    assert compare_cli.run(argparse.Namespace(runs=[a, b / "report" / "report.json"])) == 0
    out = capsys.readouterr().out
    rows = {line.split("|")[1].strip(): line for line in out.splitlines() if line.startswith("| ")}
    assert set(rows) >= {"constructed", "makespan", "lifted", "panelised", "cast_in_place", "laid"}
    assert "3/3" in rows["constructed"] and "3/4" in rows["constructed"]
    assert "1/2 built" in rows["laid"] and rows["laid"].split("|")[2].strip() == "–"  # prefab laid none
    assert "cure up to 50.0 min" in rows["cast_in_place"]
    assert "makespan +1.1 h (4,000 s) (+400.0 %) against" in out


def test_a_path_with_no_report_is_one_clear_error(tmp_path: Path) -> None:
    with pytest.raises(UserError, match=r"no report\.json there"):
        compare_cli.report_path(tmp_path)
