"""``bimbot run --fidelity plan`` over the bus: a generated 2×1 frame (2 footings, 2 columns, a beam) with
one carrier, kinematic and with a clock that jumps by events. The physics fidelity builds every component
of this frame (``test_reproducible_runs.py``, ``test_full_build.py``); the plan fidelity must build the same
set, say its fidelity in the report's settings and in ``bimbot runs``, and its physics must have jumped
its clock (else it ran period by period, as the physics fidelity does) and stopped it once the build was
over (else the services step an empty site while the run closes), and its carrier must have slept through
drives (else it answered every step of them)."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest
from frames import convert_small_frame

pytestmark = pytest.mark.integration
RUN_TIMEOUT_S = 240


def _bimbot(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "bimbot.cli", *args],
        capture_output=True,
        text=True,
        timeout=RUN_TIMEOUT_S,
        check=False,
    )


def test_plan_fidelity_builds_the_frame_and_says_so(tmp_path: Path) -> None:
    build = convert_small_frame(tmp_path)
    shown = _bimbot("fleet", "show")
    assert shown.returncode == 0, shown.stderr[-2000:]
    types = shown.stdout.split("\n[[robots]]")[0]  # the default fleet's types, one carrier on site
    fleet = tmp_path / "carrier.toml"
    fleet.write_text(f'{types}\n[[robots]]\ntype = "carrier"\ncount = 1\n')
    run_dir = build / "runs" / "plan"
    result = _bimbot(
        "run", str(build), "--fidelity", "plan", "--fleet", str(fleet), "--run-dir", str(run_dir), "-q",
        "--timeout-s", str(RUN_TIMEOUT_S - 60),
    )  # fmt: skip
    assert result.returncode == 0, f"run failed:\n{result.stdout}\n{result.stderr[-2000:]}"
    report = json.loads((run_dir / "report" / "report.json").read_text())
    manifest = json.loads((build / "manifest.json").read_text())
    every = {component["guid"] for component in manifest["components"]}
    built = {item["guid"] for item in report["components"] if item["state"] == "constructed"}
    assert built == every
    assert report["settings"]["fidelity"] == "plan"
    assert "fidelity plan" in result.stdout
    assert report["totals"]["distance_m"] > 10.0  # the carrier drove between the yard and the frame
    physics_log = (run_dir / "logs/physics.log").read_text()
    jumps = re.search(r"plan fidelity: (\d+) period\(s\).*?(\d+) jump\(s\)", physics_log)
    assert jumps is not None and int(jumps.group(2)) > 0
    # once the build is over the clock stops (tests/physics/test_physics_plan_fidelity.py); the run may stop
    # physics before it sees that (it stops the services once it has audited), never after a period more
    over = re.search(r"the build is over at step (\d+)", physics_log)
    if over is not None:
        assert int(jumps.group(1)) == int(over.group(1)) + 1, physics_log[-3000:]
    # a kinematic robot sleeps through its drives (services/robot/plan_executor.py: sleeps_until_s): physics
    # neither sends it its sensors nor waits for its answers until the drive ends
    slept = re.search(
        r"slept (\d+) step\(s\) \((\d+) of them until a drive", (run_dir / "logs/robot-r1.log").read_text()
    )
    assert slept is not None and int(slept.group(2)) > 0
    runs = _bimbot("runs", str(build))
    assert runs.returncode == 0 and "fidelity plan" in runs.stdout
