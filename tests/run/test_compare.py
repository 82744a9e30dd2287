"""``bimbot compare``: two runs side by side by construction method (bimbot/compare_cli.py,
shared/report/compare.py), from hand-made reports shaped as report.json is."""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

import pytest

from bimbot import compare_cli
from bimbot.shared.errors import UserError
from bimbot.shared.report.building_name import report_building
from bimbot.shared.report.compare import by_method, run_column
from bimbot.shared.run_folder import RunFolder, new_run_folder, remember_run_dir


def _component(method: str, state: str = "constructed", **times: object) -> dict[str, object]:
    return {"method": method, "state": state, **times}


PREFAB = {
    "settings": {"fleet": "the default fleet", "robots": None, "seed": 0},
    "totals": {"makespan_s": 1000.0, "constructed": 3, "components": 3},
    "components": [
        _component("lifted", picked_s=100.0, placed_s=160.0),
        _component("lifted", picked_s=200.0, placed_s=240.0),
        _component("panelised", picked_s=300.0, placed_s=400.0),
    ],
}
CONVENTIONAL = {
    "settings": {"fleet": "the default fleet", "robots": 3, "seed": 7},
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
    # what tells the two runs apart: their robots and seeds (a trial compared fleets by folder name)
    assert [cell.strip() for cell in rows["robots"].split("|")[2:4]] == [
        "the default fleet",
        "3 robot(s) of the default type, with the fleet's machines",
    ]
    assert [cell.strip() for cell in rows["seed"].split("|")[2:4]] == ["0", "7"]
    assert "work: a method's own work summed over the components it built" in out  # what "work" means
    back = compare_cli.run(argparse.Namespace(runs=[b, a]))
    assert back == 0 and "makespan −1.1 h (4,000 s) (−80.0 %) against" in capsys.readouterr().out


def test_a_path_that_does_not_exist_says_so(tmp_path: Path) -> None:
    """A new user's typo read 'no report.json there' for a folder that is not there at all."""
    with pytest.raises(UserError, match=r"nosuch: no such file or folder"):
        compare_cli.report_path(tmp_path / "nosuch")


def test_a_path_with_no_report_is_one_clear_error(tmp_path: Path) -> None:
    with pytest.raises(UserError, match=r"no report\.json there"):
        compare_cli.report_path(tmp_path)


def test_a_build_names_its_newest_report_also_of_a_run_given_elsewhere(tmp_path: Path) -> None:
    """``bimbot run BUILD --run-dir DIR`` keeps the run outside ``BUILD/runs/``; ``bimbot compare BUILD``
    still finds it (``BUILD/runs/elsewhere``), and takes the newest report of the build's runs."""
    build = tmp_path / "build"
    build.mkdir()
    (build / "manifest.json").write_text("{}", encoding="utf-8")
    with pytest.raises(UserError, match="a build with no runs yet"):
        compare_cli.report_path(build)
    older = _run_folder(tmp_path, "older", PREFAB)
    newer = _run_folder(tmp_path, "newer", CONVENTIONAL)
    remember_run_dir(build, older)
    remember_run_dir(build, newer)
    os.utime(older / "report" / "report.json", ns=(2_000_000_000, 2_000_000_000))
    os.utime(newer / "report" / "report.json", ns=(1_000_000_000, 1_000_000_000))
    assert compare_cli.report_path(build) == older.resolve() / "report" / "report.json"
    in_runs = new_run_folder(build)  # runs/latest, its report the newest
    in_runs.report_dir.mkdir(parents=True)
    (in_runs.report_dir / "report.json").write_text(json.dumps(PREFAB), encoding="utf-8")
    assert compare_cli.report_path(build) == in_runs.report_dir / "report.json"
    RunFolder(newer.resolve()).mark_ended("done")  # a run that ended comes before one still going
    assert compare_cli.report_path(build) == newer.resolve() / "report" / "report.json"


def test_a_run_still_going_is_labelled_so(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    going = {**PREFAB, "ending": {"how": "running", "code": "interrupted"}}
    a, b = _run_folder(tmp_path, "done", PREFAB), _run_folder(tmp_path, "going", going)
    assert compare_cli.run(argparse.Namespace(runs=[a, b])) == 0
    header = capsys.readouterr().out.splitlines()[0]
    assert f"| {b} (still running) |" in header and f"| {a} |" in header


def _of(report: dict[str, object], site: str, model: str, sha256: str, fidelity: str) -> dict[str, object]:
    settings = {"fidelity": fidelity, "model": {"path": f"models/{model}", "sha256": sha256}}
    return {**report, "site": site, "settings": settings}


def test_runs_of_another_building_or_fidelity_are_warned_of_and_marked_in_the_table(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    frame = _run_folder(tmp_path, "frame", _of(PREFAB, "greenhouse-site", "frame.ifc", "aa", "physics"))
    frame_plan = _run_folder(tmp_path, "plan", _of(PREFAB, "greenhouse-site", "frame.ifc", "aa", "plan"))
    hub = _run_folder(tmp_path, "hub", _of(CONVENTIONAL, "hub-site", "rac_sample.ifc", "bb", "physics"))
    with caplog.at_level("WARNING", logger="bimbot.compare_cli"):
        assert compare_cli.run(argparse.Namespace(runs=[frame, frame_plan, hub])) == 0
    out = capsys.readouterr().out
    warnings = [record.getMessage() for record in caplog.records]
    assert len(warnings) == 2, warnings  # one line per mismatch
    assert f"{frame_plan} ran at fidelity plan, {frame} at physics" in warnings[0]
    assert f"{hub} built hub-site (rac_sample.ifc), {frame} built greenhouse-site (frame.ifc)" in warnings[1]
    rows = {
        line.split("|")[1].strip(): line.split("|")[2:-1]
        for line in out.splitlines()
        if line.startswith("| ")
    }
    assert [cell.strip() for cell in rows["building"]] == [
        "greenhouse-site (frame.ifc)",
        "greenhouse-site (frame.ifc)",
        "hub-site (rac_sample.ifc) ⚠ differs",
    ]
    assert [cell.strip() for cell in rows["fidelity"]] == ["physics", "plan ⚠ differs", "physics"]
    assert "note: these runs do not all compare (2 difference(s), marked ⚠ above)" in out


def test_a_site_revit_names_default_is_shown_by_its_model_alone() -> None:
    """Revit names every site "Default": a trial user read "default (revit2021_sample_project.ifc)" as the
    building's name."""
    house = run_column("house", _of(PREFAB, "default", "revit2021_sample_project.ifc", "cc", "physics"))
    assert house.building == "revit2021_sample_project.ifc"
    frame = run_column("frame", _of(PREFAB, "greenhouse-site", "frame.ifc", "aa", "physics"))
    assert frame.building == "greenhouse-site (frame.ifc)"
    assert report_building(_of(PREFAB, "default", "house.ifc", "cc", "plan")) == "house.ifc"  # report.png
    assert report_building({"site": "default"}) == "default"  # no model named: the site is all there is


def test_one_model_converted_two_ways_at_one_fidelity_compares_without_a_warning(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    prefab = _run_folder(tmp_path, "prefab", _of(PREFAB, "hub-site", "hub.ifc", "aa", "physics"))
    conventional = _run_folder(tmp_path, "conv", _of(CONVENTIONAL, "hub-site", "hub.ifc", "aa", "physics"))
    with caplog.at_level("WARNING", logger="bimbot.compare_cli"):
        assert compare_cli.run(argparse.Namespace(runs=[prefab, conventional])) == 0
    assert not caplog.records
    out = capsys.readouterr().out
    assert "⚠" not in out and "note:" not in out


def test_a_run_that_ended_early_is_warned_of_and_marked(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    stopped = {**PREFAB, "ending": {"how": "interrupted"}, "totals": {**PREFAB["totals"], "constructed": 1}}
    a, b = (
        _run_folder(tmp_path, "done", {**PREFAB, "ending": {"how": "done"}}),
        _run_folder(tmp_path, "cut", stopped),
    )
    with caplog.at_level("WARNING", logger="bimbot.compare_cli"):
        assert compare_cli.run(argparse.Namespace(runs=[a, b])) == 0
    (warning,) = [record.getMessage() for record in caplog.records]
    assert f"{b} ended interrupted with 1/3 constructed" in warning
    row = next(line for line in capsys.readouterr().out.splitlines() if line.startswith("| constructed"))
    assert [cell.strip() for cell in row.split("|")[2:4]] == ["3/3", "1/3 ⚠ interrupted"]


def test_each_run_says_its_retries_give_backs_walled_in_robots_and_what_each_type_did(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A new user compared the Revit house with the default fleet and with --robots 3 and saw only the
    makespan: not that the husky was gone, nor that a carrier stood walled in."""
    one = {
        **PREFAB,
        "totals": {**PREFAB["totals"], "retries": 2, "give_backs": 0},
        "robots": {
            "r1": {"type": "husky", "built": 2, "busy_s": 600.0, "distance_m": 900.0},
            "r2": {"type": "tower_crane", "built": 1, "busy_s": 300.0, "distance_m": 0.0},
        },
    }
    three = {
        **PREFAB,
        "totals": {**PREFAB["totals"], "retries": 1, "give_backs": 2, "last_constructed_s": 5000.0},
        "robots": {
            "r1": {"type": "carrier", "built": 2, "busy_s": 500.0, "distance_m": 400.0},
            "r2": {
                "type": "carrier",
                "built": 1,
                "busy_s": 100.0,
                "distance_m": 50.0,
                "walled_in": [{"since_s": 1000.0, "until_s": 2472.0}, {"since_s": 4000.0, "until_s": None}],
            },
        },
    }
    a, b = _run_folder(tmp_path, "one", one), _run_folder(tmp_path, "three", three)
    assert compare_cli.run(argparse.Namespace(runs=[a, b])) == 0
    rows = {
        line.split("|")[1].strip(): [cell.strip() for cell in line.split("|")[2:4]]
        for line in capsys.readouterr().out.splitlines()
        if line.startswith("| ")
    }
    assert rows["retries, give-backs"] == ["2 retried, 0 given back", "1 retried, 2 given back"]
    assert rows["walled in"] == ["none", "r2 41.2 min (2,472 s)"]  # the open spell to the last construction
    assert rows["husky"] == ["1 robot(s), 2 built, busy 600.0 s, 900 m driven", "–"]
    assert rows["carrier"] == ["–", "2 robot(s), 3 built, busy 600.0 s, 450 m driven"]
    assert rows["tower_crane"][0] == "1 robot(s), 1 built, busy 300.0 s"  # it drives nowhere


def test_a_run_still_going_does_not_hide_the_builds_ended_runs(tmp_path: Path) -> None:
    """A new user compared a build while a second run of it was going: ``runs/latest`` named the new run,
    which had no report yet, and compare said "a build with no runs yet" beside a finished run."""
    build = tmp_path / "build"
    build.mkdir()
    (build / "manifest.json").write_text("{}", encoding="utf-8")
    ended = new_run_folder(build)
    ended.report_dir.mkdir(parents=True)
    (ended.report_dir / "report.json").write_text(json.dumps(PREFAB), encoding="utf-8")
    ended.mark_ended("done")
    going = new_run_folder(build)  # runs/latest now: no report yet
    assert going.root != ended.root
    assert compare_cli.report_path(build) == ended.report_dir / "report.json"
