"""``bimbot demo`` as a user runs it: convert, build with every service as a process, write ``OUT/``.

On a small generated frame (``--model``) so the suite stays fast; the bundled frame runs the same code.
The recording must be a valid ``.rrd`` (``rerun rrd verify``), the report must say every component was
constructed, and ``--live`` must serve the web viewer at the printed URL until interrupted. The live run
builds with one carrier (``--fleet``): what it proves, the viewer kept up after the build, does not depend
on the fleet, and the default fleet's idle tower crane, pump and block layer, each a process answering
every lock-step step, about doubled its CPU time; the first test runs the demo's default fleet.
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import pytest
from fleets import ground_fleet_file
from wall_clock import bound_s

from bimbot.services.observer.app import rerun_cli_binary
from bimbot.shared.run_folder import latest_run_folder
from bimbot.supervisor import free_port

pytestmark = pytest.mark.integration
TIMEOUT_S = 300


@pytest.fixture(scope="module")
def small_ifc(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("demo_model") / "frame.ifc"
    subprocess.run(
        [sys.executable, "-m", "bimbot.cli", "sample", "light-steel-frame", "-o", str(path), "--bays", "2x1"],
        check=True,
        capture_output=True,
        timeout=bound_s(120),
    )
    return path


def test_demo_writes_world_recording_and_report_and_says_how_to_open_it(
    small_ifc: Path, tmp_path: Path
) -> None:
    out = tmp_path / "demo"
    result = subprocess.run(
        [sys.executable, "-m", "bimbot.cli", "demo", "-o", str(out), "--model", str(small_ifc)],
        capture_output=True,
        text=True,
        timeout=bound_s(TIMEOUT_S),
        check=False,
    )
    assert result.returncode == 0, result.stdout + result.stderr[-3000:]
    assert "constructed 5/5 components" in result.stdout
    assert (out / "world" / "manifest.json").is_file() and (out / "world" / "sequence.xml").is_file()
    run = latest_run_folder(out / "world")  # everything of the run in its own folder, once
    assert run is not None and f"run folder: {run.root}" in result.stdout
    (rrd,) = run.observer_dir.glob("*.rrd")
    assert f"rerun {rrd}" in result.stdout
    report = json.loads((run.report_dir / "report.json").read_text())
    assert report["totals"]["constructed"] == report["totals"]["components"] == 5
    settings = report["settings"]  # what made this report: the demo's profile, with its total station
    assert settings["profile"] == "rehearsal" and settings["physics_hz"] == 120.0
    assert settings["total_station_mm"] == 3.0 and settings["sequence"] == "the build's sequence.xml"
    assert (run.report_dir / "report.png").stat().st_size > 10_000
    assert sorted(p.name for p in run.root.rglob("report.json")) == ["report.json"]  # one report, not two
    assert (run.logs_dir / "planner.log").is_file() and list(run.state_dir.glob("agents-*.jsonl"))
    # the default fleet's pumps and block layer have no work in a frame: they stay off site, and the run
    # says so; its tower crane comes (it may lift), sleeps while it has no task, and the others do not wait
    # for it (shared/step_gate.py)
    off_site = "tower_crane; off site, no work in this build: concrete_pump, block_layer, line_pump, "
    off_site += "piling_rig"
    assert off_site in result.stdout
    assert settings["off_site"] == ["concrete_pump", "block_layer", "line_pump", "piling_rig"]
    logs = sorted(log.stem for log in run.logs_dir.glob("robot-*.log"))
    assert logs == ["robot-r1", "robot-r2", "robot-r3"], logs
    slept = {
        log.stem: int(found.group(1))
        for log in run.logs_dir.glob("robot-*.log")
        if (found := re.search(r"slept (\d+) step\(s\)", log.read_text()))
    }
    assert slept.get("robot-r3", 0) > 100, slept  # r3: the crane
    verify = subprocess.run(
        [str(rerun_cli_binary()), "rrd", "verify", str(rrd)],
        capture_output=True,
        text=True,
        timeout=bound_s(120),
        check=False,
        env={**os.environ, "RUST_LOG": "warn"},
    )
    assert verify.returncode == 0, verify.stdout + verify.stderr


def test_demo_live_serves_the_viewer_at_the_printed_url_until_interrupted(
    small_ifc: Path, tmp_path: Path
) -> None:
    web_port, grpc_port = free_port(), free_port()
    command = [sys.executable, "-m", "bimbot.cli", "demo", "-o", str(tmp_path / "demo"), "--live"]
    command += ["--model", str(small_ifc), "--web-port", str(web_port), "--grpc-port", str(grpc_port)]
    command += ["--fleet", str(ground_fleet_file(tmp_path))]  # one carrier (see the module)
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    lines: list[str] = []
    try:
        deadline = time.monotonic() + bound_s(TIMEOUT_S)
        assert process.stdout is not None
        while time.monotonic() < deadline:
            line = process.stdout.readline()
            if not line:
                break
            lines.append(line)
            if "the viewer stays up at" in line:
                break
        url = re.search(r"stays up at (http\S+)", "".join(lines))
        assert url, "".join(lines)
        assert url.group(1).startswith(f"http://127.0.0.1:{web_port}/")
        with urllib.request.urlopen(url.group(1), timeout=bound_s(10)) as page:
            assert page.status == 200 and b"<html" in page.read(4096).lower()
        assert any("constructed 5/5 components" in line for line in lines), "".join(lines)
        assert process.poll() is None  # still serving
        process.send_signal(signal.SIGINT)
        assert process.wait(timeout=bound_s(60)) == 0
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
        if process.stdout is not None:
            process.stdout.close()
