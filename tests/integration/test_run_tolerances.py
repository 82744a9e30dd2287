"""One tolerance override reaches every part that judges a placement: ``bimbot run --position-tolerance-m``
is served by physics in its site info, and the agents verify with it, physics connects with it, the run's
audit and report.json judge and say it. Real processes on a loopback bus, real pybullet: the generated
2×1 frame with its footings in place, every first placement set 20 mm off (beyond the default 10 mm)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from fleets import ground_fleet_file
from wall_clock import bound_s

from bimbot.services.physics.simulation import SimConfig, Simulation
from bimbot.shared.manifest import read_manifest
from bimbot.shared.run_folder import RunFolder
from bimbot.shared.verification import Tolerances

pytestmark = pytest.mark.integration
RUN_TIMEOUT_S = 300


def _bimbot(*args: str) -> subprocess.CompletedProcess[str]:
    command = [sys.executable, "-m", "bimbot.cli", *args]
    return subprocess.run(
        command, capture_output=True, text=True, timeout=bound_s(RUN_TIMEOUT_S), check=False
    )


def test_physics_connects_with_the_tolerances_it_serves(bundled_build: Path) -> None:
    wide = Tolerances(position_m=0.03, drift_m=0.008)
    with Simulation(read_manifest(bundled_build), bundled_build, SimConfig(tolerances=wide)) as sim:
        assert sim.handling.connections.fit == wide
        assert sim.info().tolerances == wide


def test_a_run_with_a_wider_position_tolerance_accepts_a_20_mm_placement_everywhere(tmp_path: Path) -> None:
    ifc, build = tmp_path / "frame.ifc", tmp_path / "build"
    assert _bimbot("sample", "light-steel-frame", "-o", str(ifc), "--bays", "2x1").returncode == 0
    converted = _bimbot("convert", str(ifc), "-o", str(build), "--no-progress", "--in-place", "foundations")
    assert converted.returncode == 0, converted.stderr
    run = RunFolder(tmp_path / "run")
    result = _bimbot(
        "run",
        str(build),
        "--fleet",
        str(ground_fleet_file(tmp_path)),  # one carrier
        "--run-dir",
        str(run.root),
        "--timeout-s",
        f"{bound_s(RUN_TIMEOUT_S) - 60:.0f}",
        "--inject-placement-error-m",
        "0.02",
        "--position-tolerance-m",
        "0.03",
    )
    detail = f"{result.stdout}\n{result.stderr[-3000:]}"
    assert result.returncode == 0, detail
    assert "constructed 3/3 components" in result.stdout, detail
    report = json.loads((run.report_dir / "report.json").read_text())
    # the agents: every 20 mm placement accepted at the first attempt (the default would retry each)
    assert [item["attempts"] for item in report["components"]] == [1, 1, 1], report["components"]
    assert report["totals"]["max_position_error_mm"] > 10.0
    # physics served it (its connections judge the fit with it), the agents took it from there
    assert "placement tolerances in force: 30 mm" in (run.logs_dir / "physics.log").read_text()
    assert "placement tolerances in force: 30 mm" in (run.logs_dir / "agents.log").read_text()
    # the audit and the report
    assert report["as_built"]["tolerance_mm"] == pytest.approx(30.0)
    assert report["as_built"]["errors"] == []
    assert report["settings"]["tolerances"]["position_mm"] == pytest.approx(30.0)
