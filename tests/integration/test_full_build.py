"""The paper's construction run end to end: ``bimbot run`` starts physics, agents, planner and robots as
processes on a loopback Zenoh bus and builds a generated 2×1 light steel frame (2 footings, 2 columns, a
beam) with real PyBullet physics, A*/DWA navigation and particle-filter localisation.

Every component must end constructed within the agents' tolerance (10 mm, 1°), with one robot and with two
(which must keep apart), and an injected placement error must be caught by the agent and fixed by the retry.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from fleets import ground_fleet_file
from wall_clock import bound_s

from bimbot.services.planner.sources import PlanSource, SourceKind, load_plan
from bimbot.shared.manifest import read_manifest
from bimbot.shared.run_folder import RunFolder, latest_run_folder
from bimbot.shared.sequence import read_sequence
from bimbot.shared.verification import Tolerances

pytestmark = pytest.mark.integration
RUN_TIMEOUT_S = 300
TOLERANCES = Tolerances()


@pytest.fixture(scope="module")
def small_frame(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 2×1 frame, generated and converted with the real commands."""
    folder = tmp_path_factory.mktemp("small_frame")
    ifc = folder / "frame.ifc"
    _bimbot("sample", "light-steel-frame", "-o", str(ifc), "--bays", "2x1")
    _bimbot("convert", str(ifc), "-o", str(folder / "build"), "--no-progress")
    return folder / "build"


@pytest.fixture
def build(small_frame: Path, tmp_path: Path) -> Path:
    out = tmp_path / "build"
    shutil.copytree(small_frame, out)
    return out


def _bimbot(*args: str, check: bool = True) -> subprocess.CompletedProcess[str]:
    result = subprocess.run(
        [sys.executable, "-m", "bimbot.cli", *args],
        capture_output=True,
        text=True,
        timeout=bound_s(RUN_TIMEOUT_S),
        check=False,
    )
    if check and result.returncode != 0:
        raise AssertionError(f"bimbot {' '.join(args)} exited {result.returncode}:\n{result.stderr[-3000:]}")
    return result


def _run(build: Path, *options: str) -> tuple[subprocess.CompletedProcess[str], dict]:
    timeout_s = f"{bound_s(RUN_TIMEOUT_S) - 30:.0f}"
    result = _bimbot("run", str(build), "--timeout-s", timeout_s, *options, check=False)
    run = _latest(build)
    logs = run.logs_dir
    detail = "\n".join(
        f"--- {log.name}\n" + "\n".join(log.read_text().splitlines()[-15:])
        for log in sorted(logs.glob("*.log"))
    )
    assert result.returncode == 0, f"run failed:\n{result.stdout}\n{result.stderr[-2000:]}\n{detail}"
    report = json.loads((run.report_dir / "report.json").read_text())
    return result, report


def _latest(build: Path) -> RunFolder:
    run = latest_run_folder(build)
    assert run is not None, f"no run folder under {build}/runs"
    return run


def _assert_all_constructed_within_tolerance(build: Path, report: dict) -> None:
    guids = {component.guid for component in read_manifest(build).components}
    assert {c["guid"] for c in report["components"] if c["state"] == "constructed"} == guids
    for component in report["components"]:
        assert component["position_error_mm"] is not None, component["guid"]
        assert component["position_error_mm"] <= TOLERANCES.position_m * 1000.0
        assert component["angle_error_deg"] <= TOLERANCES.angle_rad * 180.0 / 3.141592653589793
        assert component["released_s"] <= component["picked_s"] <= component["placed_s"]
        assert component["placed_s"] <= component["constructed_s"]


def test_one_robot_builds_the_whole_frame_within_tolerance(build: Path, tmp_path: Path) -> None:
    result, report = _run(build, "--fleet", str(ground_fleet_file(tmp_path)))  # one carrier
    assert re.search(r"constructed 5/5 components", result.stdout)
    _assert_all_constructed_within_tolerance(build, report)
    (robot,) = report["robots"].values()
    assert len(robot["tasks"]) == 5 and robot["distance_m"] > 10.0
    assert (
        report["totals"]["retries"] == 0
        and (_latest(build).report_dir / "report.png").stat().st_size > 10_000
    )
    # the schedule's order (a chain in the IFC work schedule) was kept
    order = sorted(report["components"], key=lambda c: c["sequence_index"])
    assert [c["constructed_s"] for c in order] == sorted(c["constructed_s"] for c in order)
    # every service, the router too, was forked from the run's fork server (bimbot.fork_server)
    logs = _latest(build).logs_dir
    assert "service modules preloaded" in (logs / "fork-server.log").read_text()
    forked = {log.stem for log in logs.glob("*.log") if "forked from a" in log.read_text()}
    assert forked == {"bus", "physics", "agents", "planner", "robot-r1"}, forked


def test_two_robots_share_the_work_and_keep_apart(build: Path, tmp_path: Path) -> None:
    _, report = _run(build, "--fleet", str(ground_fleet_file(tmp_path, 2)), "--derive")  # two carriers
    # the report's sequence is the plan the planner built by (derived here), not the build's sequence.xml
    manifest = read_manifest(build)
    derived = load_plan(manifest, build, PlanSource(kind=SourceKind.DERIVE))
    by_index = sorted(report["components"], key=lambda c: c["sequence_index"])
    assert [c["guid"] for c in by_index] == list(derived.order)
    assert list(derived.order) != read_sequence(build / "sequence.xml").guids()
    _assert_all_constructed_within_tolerance(build, report)
    assert sorted(report["robots"]) == ["r1", "r2"]
    assert all(robot["tasks"] for robot in report["robots"].values()), "both robots must work"
    separation = report["totals"]["min_robot_separation_m"]  # ground truth, at equal sim times
    assert separation is not None and separation > 0.6  # base-frame distance; a Husky is ~0.67 m wide


def test_an_injected_placement_error_is_caught_and_the_retry_fixes_it(build: Path, tmp_path: Path) -> None:
    one_carrier = ground_fleet_file(tmp_path)  # no idle crane, pump or block layer answering every step
    result, report = _run(build, "--fleet", str(one_carrier), "--inject-placement-error-m", "0.05")
    _assert_all_constructed_within_tolerance(build, report)
    assert report["totals"]["retries"] >= 1
    retried = [c for c in report["components"] if c["retries"]]
    assert all(c["misplaced_s"] and c["misplaced_s"][0] < c["constructed_s"] for c in retried)
    assert re.search(r"[1-9]\d* placement\(s\) caught off target or unstable and retried", result.stdout)


def test_a_folder_that_is_not_a_build_gets_one_clear_line(tmp_path: Path) -> None:
    result = _bimbot("run", str(tmp_path), check=False)
    assert result.returncode == 2
    assert "Traceback" not in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1 and str(tmp_path) in result.stderr
