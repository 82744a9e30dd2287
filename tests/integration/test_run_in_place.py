"""A run with the foundations in place: ``bimbot run`` builds what stands on them, and counts only that.

Real processes on a loopback bus, real pybullet: the generated 2×1 frame converted with ``--in-place
foundations``. Its two footings stand at their BIM pose from the start (static, in physics only); the
columns rest on them and are released at once; the report lists the footings apart.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from fleets import ground_fleet_file
from wall_clock import bound_s

from bimbot.shared.manifest import read_manifest
from bimbot.shared.run_folder import RunFolder

pytestmark = pytest.mark.integration
RUN_TIMEOUT_S = 300


def _bimbot(*args: str) -> subprocess.CompletedProcess[str]:
    command = [sys.executable, "-m", "bimbot.cli", *args]
    return subprocess.run(
        command, capture_output=True, text=True, timeout=bound_s(RUN_TIMEOUT_S), check=False
    )


def test_a_run_with_the_foundations_in_place_builds_the_rest_on_them(tmp_path: Path) -> None:
    ifc, build = tmp_path / "frame.ifc", tmp_path / "build"
    assert _bimbot("sample", "light-steel-frame", "-o", str(ifc), "--bays", "2x1").returncode == 0
    converted = _bimbot("convert", str(ifc), "-o", str(build), "--no-progress", "--in-place", "foundations")
    assert converted.returncode == 0, converted.stderr
    manifest = read_manifest(build)
    assert len(manifest.components) == 3 and len(manifest.in_place) == 2
    run = RunFolder(tmp_path / "run")
    fleet = str(ground_fleet_file(tmp_path))  # one carrier
    timeout_s = f"{bound_s(RUN_TIMEOUT_S) - 60:.0f}"
    result = _bimbot(
        "run", str(build), "--fleet", fleet, "--run-dir", str(run.root), "--timeout-s", timeout_s
    )
    detail = f"{result.stdout}\n{result.stderr[-3000:]}"
    assert result.returncode == 0, detail
    assert "constructed 3/3 components" in result.stdout, detail
    assert "in place before the run (existing work the IFC marks, or convert --in-place): 2 component(s)" in (
        result.stdout
    ), detail
    report = json.loads((run.report_dir / "report.json").read_text())
    assert report["totals"]["components"] == 3 and report["totals"]["in_place"] == 2
    assert sorted(item["name"] for item in report["in_place"]) == ["Footing A1", "Footing A2"]
    assert {c["guid"] for c in report["components"]} == {c.guid for c in manifest.components}
    # the columns stand on the footings in physics: each verified within tolerance where its footing is
    physics = (run.logs_dir / "physics.log").read_text()
    assert "3 components in the yard, 2 in place" in physics, physics[-2000:]
    assert report["totals"]["max_position_error_mm"] <= 10.0
