"""``bimbot observe`` and ``bimbot watch`` as real processes beside a real construction run.

Bus router, agents and planner run as processes on a loopback Zenoh bus with the integration tests'
robot stand-in in the robots' (and physics') role; the observer and the watch run from the start. The
bundled light steel frame (28 components) is built once for the module; each test checks one output.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest
from wall_clock import bound_s

from bimbot.polling import wait_until
from bimbot.services.observer.app import rerun_cli_binary
from bimbot.shared.bus import BusOptions
from bimbot.shared.manifest import Manifest, read_manifest
from bimbot.supervisor import ServiceProcess, free_port

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "integration"))
from robot_stand_in import RobotStandIn  # the integration tests' robot stand-in

pytestmark = pytest.mark.integration
RUN_TIMEOUT_S = 60.0


@dataclass
class ObservedRun:
    manifest: Manifest
    observer_code: int
    observer_log: str
    watch_code: int | None
    watch_output: str
    rrd: Path
    report_dir: Path


@pytest.fixture(scope="module")
def observed_run(bundled_build: Path, tmp_path_factory: pytest.TempPathFactory) -> ObservedRun:
    tmp = tmp_path_factory.mktemp("observed_run")
    build = tmp / "build"
    shutil.copytree(bundled_build, build)
    manifest = read_manifest(build)
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    rrd, report_dir = tmp / "run.rrd", tmp / "report"
    router = ServiceProcess("bus", ["bus", "--listen", endpoint], tmp)
    observer = ServiceProcess(
        "observe",
        [
            *("observe", "--build", str(build), "--connect", endpoint, "--exit-when-done", "--rrd", str(rrd)),
            *(
                "--report-dir",
                str(report_dir),
                "--web-port",
                str(free_port()),
                "--grpc-port",
                str(free_port()),
            ),
        ],
        tmp,
    )
    watcher = ServiceProcess("watch", ["watch", "--build", str(build), "--connect", endpoint], tmp)
    services: list[ServiceProcess] = []
    try:
        assert wait_until(lambda: "observing" in observer.log(), bound_s(30.0)), observer.log()
        with RobotStandIn(manifest, BusOptions(connect=(endpoint,)), robot_ids=("r1", "r2")):
            agents = ServiceProcess("agents", ["agents", "--build", str(build), "--connect", endpoint], tmp)
            planner_args = ["planner", "--build", str(build), "--connect", endpoint, "--exit-when-done"]
            planner_args += ["--resend-s", "0.5", "--site-info-timeout-s", "0.5"]  # no physics: the stand-in
            planner = ServiceProcess("planner", planner_args, tmp)
            services += [planner, agents]
            assert planner.wait(bound_s(RUN_TIMEOUT_S)) == 0, planner.log()[-3000:]
            try:
                observer_code = observer.wait(bound_s(30.0))
            except subprocess.TimeoutExpired:
                pytest.fail(f"the observer did not exit after the build\n{observer.log()[-3000:]}")
        watcher.process.send_signal(2)  # SIGINT, as Ctrl-C
        watch_code = watcher.wait(bound_s(10.0))
        return ObservedRun(
            manifest, observer_code, observer.log(), watch_code, watcher.log(), rrd, report_dir
        )
    finally:
        for service in [*services, watcher, observer, router]:
            service.stop()


def test_observe_exits_zero_once_the_build_is_done(observed_run: ObservedRun) -> None:
    assert observed_run.observer_code == 0, observed_run.observer_log[-3000:]


def test_the_report_lists_every_component_constructed(observed_run: ObservedRun) -> None:
    report = json.loads((observed_run.report_dir / "report.json").read_text())
    guids = {c.guid for c in observed_run.manifest.components}
    assert {c["guid"] for c in report["components"]} == guids
    assert len(report["components"]) == 28
    assert all(c["state"] == "constructed" for c in report["components"])
    assert all(
        c["released_s"] <= c["picked_s"] <= c["placed_s"] <= c["constructed_s"] for c in report["components"]
    )
    assert report["totals"]["constructed"] == 28 and report["totals"]["done"] is True
    assert set(report["robots"]) == {"r1", "r2"}
    handled = [task["guid"] for robot in report["robots"].values() for task in robot["tasks"]]
    assert sorted(handled) == sorted(guids)  # the stand-in does one task per component
    assert (observed_run.report_dir / "report.png").stat().st_size > 10_000


def test_the_recording_verifies(observed_run: ObservedRun) -> None:
    assert observed_run.rrd.stat().st_size > 0
    result = subprocess.run(
        [str(rerun_cli_binary()), "rrd", "verify", str(observed_run.rrd)],
        check=False,
        capture_output=True,
        text=True,
        timeout=bound_s(60),
    )
    assert result.returncode == 0, result.stderr[-3000:]


def test_watch_on_a_pipe_prints_a_line_per_state_change_and_exits_zero_on_ctrl_c(
    observed_run: ObservedRun,
) -> None:
    assert observed_run.watch_code == 0, observed_run.watch_output[-3000:]
    lines = [line for line in observed_run.watch_output.splitlines() if "-> constructed" in line]
    constructed = {
        guid
        for guid in (c.guid for c in observed_run.manifest.components)
        if any(guid in line for line in lines)
    }
    assert len(constructed) == 28
    footing = next(c for c in observed_run.manifest.components if c.ifc_class == "IfcFooting")
    assert any(footing.guid in line and footing.name in line and "IfcFooting" in line for line in lines)
