"""``bimbot run`` ends by itself and says why, however it ends (real processes on a loopback bus, the small
2×1 frame of the full-build test, paced at real time so there is a run to stop):

* SIGTERM: within seconds no service and no process of their groups is left, exit 143, and report.json
  (written every second meanwhile) gives every component not built a reason;
* the stall watchdog: a site where nothing changes for the bound ends the run, exit 1, ``stalled``;
* ``--timeout-s``: the report is written, exit 1, ``interrupted``; the terminal table names each; the
  services are stopped before the report is drawn (physics does not step on beside matplotlib).
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from fleets import ground_fleet_file
from frames import convert_small_frame
from processes import alive
from wall_clock import bound_s

from bimbot.polling import wait_until
from bimbot.shared.run_folder import RunFolder, latest_run_folder

pytestmark = pytest.mark.integration
TIMEOUT_S = 120


@pytest.fixture(scope="module")
def small_frame(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return convert_small_frame(tmp_path_factory.mktemp("small_frame"), (2, 1))


def _start(build: Path, *options: str) -> subprocess.Popen[str]:
    fleet = ground_fleet_file(build.parent)  # one carrier
    command = [
        sys.executable,
        "-m",
        "bimbot.cli",
        "run",
        str(build),
        "--rtf",
        "1",
        "--fleet",
        str(fleet),
        *options,
    ]
    return subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _finish(process: subprocess.Popen[str], timeout_s: float) -> tuple[str, str]:
    """The run's output once it exits, at most ``timeout_s`` on the reference machine (scaled) from now."""
    try:
        return process.communicate(timeout=bound_s(timeout_s))
    finally:
        if process.poll() is None:
            process.kill()
            process.communicate()


def _processes() -> dict[int, tuple[int, int]]:
    """pid → (parent pid, process group) of every process on this machine."""
    found = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            found[int(entry.name)] = (int(fields[1]), int(fields[2]))
    return found


def _descendants(pid: int) -> set[int]:
    table = _processes()
    found, frontier = set(), {pid}
    while frontier:
        frontier = {child for child, (parent, _) in table.items() if parent in frontier} - found
        found |= frontier
    return found


def _run_processes(run_pid: int, build: Path) -> set[int]:
    """The run's processes: its descendants, and, when its services fork from a session of a warm fork
    server (tests/conftest.py), that session (its title names the run) and the services of ``build``."""
    found = _descendants(run_pid)
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit() and int(entry.name) != run_pid:
            try:
                title = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
            except OSError:
                continue
            ours = f"bimbot run {run_pid})" in title or ("bimbot.cli" in title and str(build) in title)
            if ours:
                found |= {int(entry.name)} | _descendants(int(entry.name))
    return found


def _assert_every_component_not_built_has_a_reason(report: dict) -> list[dict]:
    not_built = [c for c in report["components"] if c["state"] != "constructed"]
    assert not_built, "the run was meant to end before the frame was built"
    for component in not_built:
        assert component["reason"] and component["reason"]["code"] and component["reason"]["message"], (
            component
        )
    return not_built


def _in_the_table(out: str, component: dict) -> bool:
    """The component's own row (its GUID and state), or a row that takes it together with alike ones
    (``N components  (report.json)  <state>  <code>``, every one of them in report.json)."""
    own = f"{component['guid']}  {component['state']}" in out
    state, code = component["state"], component["reason"]["code"]
    together = re.search(rf"\d+ components\s+\(report\.json\)\s+{state}\s+{code}", out) is not None
    return own or together


def test_sigterm_stops_every_service_and_their_groups_and_still_writes_the_report(
    small_frame: Path, tmp_path: Path
) -> None:
    run = RunFolder(tmp_path / "run")  # --run-dir: this run's output, where the user said
    report_path = run.report_dir / "report.json"
    process = _start(small_frame, "--report-every-s", "1", "--run-dir", str(run.root))
    try:
        assert wait_until(report_path.exists, timeout_s=bound_s(60.0), interval_s=0.2), (
            "no report while running"
        )
        assert json.loads(report_path.read_text())["ending"]["how"] == "running"
        children = _run_processes(process.pid, small_frame)
        groups = {pgid for pid, (_, pgid) in _processes().items() if pid in children}
        assert len(children) >= 5 and process.pid not in groups  # bus, physics, agents, planner, robot
        process.send_signal(signal.SIGTERM)
        stopped_at = time.monotonic()
        out, err = _finish(process, timeout_s=30)
        assert time.monotonic() - stopped_at < bound_s(12.0)  # within seconds: not its 30 s bound
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 128 + signal.SIGTERM, out + err[-2000:]
    # a process that has ended is none left behind, even before its parent reaps it (a zombie)
    ours = {pid for pid, (_, pgid) in _processes().items() if pid in children or pgid in groups}
    left = {pid for pid in ours if alive(pid)}
    assert not left, f"left behind: {left}"
    report = json.loads(report_path.read_text())
    assert report["ending"]["how"] == "interrupted" and "SIGTERM" in report["ending"]["message"]
    for component in _assert_every_component_not_built_has_a_reason(report):
        assert component["reason"]["code"] == "interrupted"
        assert _in_the_table(out, component), out
    assert "interrupted" in out and "the run ended early: stopped by SIGTERM" in out
    # the signal is acknowledged at once, and the summary starts with why it is short
    heard = out.index("SIGTERM: stopping the services and writing the report")
    assert heard < out.index("the run ended early") < out.index(" components in ")


def test_a_site_where_nothing_changes_ends_stalled_saying_what_each_robot_was_doing(
    small_frame: Path,
) -> None:
    # 2 sim seconds without a change: the first drive to the yard is longer than that
    process = _start(small_frame, "--stall-after-s", "2", "-q")
    out, err = _finish(process, TIMEOUT_S)
    assert process.returncode == 1, out + err[-2000:]
    # the planner's progress (every 5 control periods, 1 s of sim time) confirms the stall
    assert re.search(r"the site stalled: nothing on the site changed for [234] s of sim time", out), (
        out + err[-2000:]
    )
    assert "robot r1:" in out
    report = json.loads((_latest(small_frame).report_dir / "report.json").read_text())
    assert report["ending"]["how"] == "stalled" and any(
        d.startswith("robot r1:") for d in report["ending"]["details"]
    )
    for component in _assert_every_component_not_built_has_a_reason(report):
        assert component["reason"]["code"] == "stalled"
        assert _in_the_table(out, component), out
    assert "progress:" not in out  # -q


def test_the_time_limit_ends_the_run_with_its_report_and_exit_1(small_frame: Path) -> None:
    process = _start(small_frame, "--timeout-s", "6", "--stall-after-s", "0")
    out, err = _finish(process, TIMEOUT_S)
    assert process.returncode == 1, out + err[-2000:]
    assert "--timeout-s limit of 6 s wall" in out
    report = json.loads((_latest(small_frame).report_dir / "report.json").read_text())
    assert report["ending"]["how"] == "timeout"
    assert {c["reason"]["code"] for c in _assert_every_component_not_built_has_a_reason(report)} == {
        "interrupted"
    }
    run = _latest(small_frame)
    assert os.path.getsize(run.report_dir / "report.png") > 10_000
    # physics' closing lines (written as it stops) come before the chart: stopped, then reported
    physics_log_ns = (run.logs_dir / "physics.log").stat().st_mtime_ns
    assert physics_log_ns <= (run.report_dir / "report.png").stat().st_mtime_ns


def _latest(build: Path) -> RunFolder:
    run = latest_run_folder(build)
    assert run is not None, f"no run folder under {build}/runs"
    return run
