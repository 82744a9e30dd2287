"""Run folders: one per run under BUILD/runs/, ``latest`` follows the newest, services agree on one."""

from __future__ import annotations

import json
import multiprocessing
from pathlib import Path

import pytest

from bimbot.cli import main
from bimbot.shared.run_folder import (
    LATEST_NAME,
    latest_run_folder,
    new_run_folder,
    open_run_folder,
    remember_run_dir,
    runs_dir,
    runs_elsewhere,
)

NOON_S = 1_795_000_000.0


def test_each_new_run_gets_its_own_folder_and_latest_follows(tmp_path: Path) -> None:
    first = new_run_folder(tmp_path, now_s=NOON_S)
    second = new_run_folder(tmp_path, now_s=NOON_S)  # the same second: a suffix, never the same folder
    third = new_run_folder(tmp_path, now_s=NOON_S + 60)
    assert len({first.root, second.root, third.root}) == 3
    assert second.root.name == f"{first.root.name}-2"
    assert all(run.root.parent == runs_dir(tmp_path) and run.root.is_dir() for run in (first, second, third))
    latest = runs_dir(tmp_path) / LATEST_NAME
    assert latest.is_symlink() and not Path(latest.readlink()).is_absolute()  # the build can move
    assert latest_run_folder(tmp_path) == type(third)(third.root.resolve())
    assert {p.name for p in runs_dir(tmp_path).iterdir() if p.name.startswith(".latest")} == set()


def test_a_service_without_run_dir_uses_latest_or_makes_the_first(tmp_path: Path) -> None:
    assert latest_run_folder(tmp_path) is None
    made = open_run_folder(tmp_path)
    assert made.root.is_dir() and latest_run_folder(tmp_path) == made
    assert open_run_folder(tmp_path) == made  # a second service joins the same run
    given = tmp_path / "elsewhere"
    assert open_run_folder(tmp_path, given).root == given
    assert made.state_dir == made.root / "state" and made.recording_path("s") == made.root / "observer/s.rrd"


def test_a_finished_run_is_never_joined_by_services_started_later(tmp_path: Path) -> None:
    finished = new_run_folder(tmp_path, now_s=NOON_S)
    assert open_run_folder(tmp_path) == type(finished)(finished.root.resolve())  # still open: joined
    finished.mark_ended("done: the planner ended")
    later = open_run_folder(tmp_path)
    assert later.root != finished.root.resolve() and not later.ended
    assert latest_run_folder(tmp_path) == later
    assert (finished.root / "ENDED").read_text().startswith("done")


def _open_latest(build: str) -> str:
    return str(open_run_folder(Path(build)).root)


def test_services_starting_together_agree_on_one_run_folder(tmp_path: Path) -> None:
    with multiprocessing.get_context("spawn").Pool(4) as pool:
        roots = pool.map(_open_latest, [str(tmp_path)] * 8)
    assert len(set(roots)) == 1
    assert [p for p in runs_dir(tmp_path).iterdir() if p.is_dir() and not p.is_symlink()] == [Path(roots[0])]


def test_bimbot_runs_lists_runs_with_their_reports_and_makes_new_ones(
    bundled_build: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    build = tmp_path / "build"
    build.mkdir()
    (build / "manifest.json").write_bytes((bundled_build / "manifest.json").read_bytes())
    assert main(["runs", str(build), "--new"]) == 0
    made = Path(capsys.readouterr().out.strip())
    assert made.parent == runs_dir(build) and made.is_dir()
    report = {
        "totals": {"constructed": 27, "components": 28},
        "ending": {"how": "stalled"},
        "sim_time_s": 812.4,
    }
    (made / "report").mkdir()
    (made / "report" / "report.json").write_text(json.dumps(report))
    assert main(["runs", str(build)]) == 0
    listed = capsys.readouterr().out
    assert f"{made.name} (latest)  constructed 27/28, stalled, 812 s sim\n" in listed
    # a run that ended by itself with much left unbuilt says why, most common reason first
    report["totals"] |= {"constructed": 3, "by_reason": {"too_heavy": 8, "blocked_by": 95, "out_of_reach": 9}}
    report["ending"] = {"how": "done"}
    (made / "report" / "report.json").write_text(json.dumps(report))
    assert main(["runs", str(build)]) == 0
    listed = capsys.readouterr().out
    assert (
        "constructed 3/28, done, 812 s sim; not constructed: 95 blocked_by, 9 out_of_reach, 8 too_heavy"
        in listed
    )
    # and what tells two runs of one build apart: the robots asked for, the components in place
    report["settings"] = {"robots": 3, "fleet": "the default fleet"}
    report["totals"] |= {"in_place": 9}
    (made / "report" / "report.json").write_text(json.dumps(report))
    assert main(["runs", str(build)]) == 0
    said = "812 s sim, 3 robot(s) of the default type, with the fleet's machines, 9 in place; not constructed"
    assert said in capsys.readouterr().out
    # the type named where the report's robots say it (a trial user asked which type "the default" was)
    report["robots"] = {f"r{i}": {"type": "carrier"} for i in (1, 2, 3)} | {"r4": {"type": "tower_crane"}}
    (made / "report" / "report.json").write_text(json.dumps(report))
    assert main(["runs", str(build)]) == 0
    assert "812 s sim, 3 carrier(s) (--robots 3), with the fleet's machines, 9 in" in capsys.readouterr().out
    del report["robots"]
    report["settings"] = {"robots": None, "fleet": "site.toml"}
    (made / "report" / "report.json").write_text(json.dumps(report))
    assert main(["runs", str(build)]) == 0
    assert "812 s sim, site.toml, 9 in place; not constructed" in capsys.readouterr().out
    report["settings"] = {"robots": None, "fleet": "site.toml", "connections": False}
    (made / "report" / "report.json").write_text(json.dumps(report))
    assert main(["runs", str(build)]) == 0
    assert "site.toml, 9 in place, without connections; not constructed" in capsys.readouterr().out
    report["sim_time_s"] = 473683.2  # a curing site's days: grouped as the run's summary prints them
    (made / "report" / "report.json").write_text(json.dumps(report))
    assert main(["runs", str(build)]) == 0
    assert "done, 473,683 s sim (5.5 days)" in capsys.readouterr().out
    # the methods: what the build has when all was built; what was built of each when not (a trial user
    # read "54 lifted" of an interrupted run as 54 built)
    methods = {"cast_in_place": {"components": 2, "constructed": 2}, "lifted": {"components": 54}}
    report["totals"] |= {"by_method": methods | {"lifted": {"components": 54, "constructed": 54}}}
    (made / "report" / "report.json").write_text(json.dumps(report))
    assert main(["runs", str(build)]) == 0
    assert ", 2 cast_in_place 54 lifted; not constructed" in capsys.readouterr().out
    report["totals"] |= {"by_method": methods | {"lifted": {"components": 54, "constructed": 35}}}
    (made / "report" / "report.json").write_text(json.dumps(report))
    assert main(["runs", str(build)]) == 0
    assert ", built by method: cast_in_place 2/2, lifted 35/54; not" in capsys.readouterr().out
    assert main(["runs", str(tmp_path / "nothing")]) == 2
    # the folder asked for, not its parent's missing manifest (a new-user trial was told of tmp/manifest.json)
    assert f"{tmp_path / 'nothing'}: no such folder" in capsys.readouterr().err


def test_a_run_dir_given_outside_the_build_is_listed_by_bimbot_runs(
    bundled_build: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    build = tmp_path / "build"
    build.mkdir()
    (build / "manifest.json").write_bytes((bundled_build / "manifest.json").read_bytes())
    outside, inside = tmp_path / "mine" / "run1", runs_dir(build) / "by-hand"
    for folder in (outside, inside):
        (folder / "report").mkdir(parents=True)
        remember_run_dir(build, folder)
    remember_run_dir(build, outside)  # given again: listed once
    assert runs_elsewhere(build) == [outside.resolve()]
    assert main(["runs", str(build)]) == 0
    out = capsys.readouterr().out
    assert f"{outside.resolve()}  no report" in out
    assert out.count(str(outside.resolve())) == 1
    assert "by-hand  no report" in out
    (outside / "report").rmdir()
    outside.rmdir()
    assert runs_elsewhere(build) == []  # a folder since removed is not listed
