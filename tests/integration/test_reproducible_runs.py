"""Same build, fleet, sequence and seed: the same outcome. ``bimbot run`` builds a generated 2×1 frame (2
footings, 2 columns, a beam) with three carriers (the default fleet's types, no fixed machines: three
robot processes) and a derived sequence twice with ``--seed 1``; both reports
must name the same robots for every component, the same states and attempts, the same order of
construction and the same tasks per robot, with makespans within 1 % (:mod:`bimbot.run_outcome`).

Three robots for five components make the assignment a real choice (who is idle first, who bids lowest),
which is what differed from run to run before the planner, the agents and the robots took their inputs
at defined lock-step steps. The two runs go one after the other (about 30–60 s each on two cores, a few
minutes under a load of 30).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from bimbot.run_outcome import differences, outcome

pytestmark = pytest.mark.integration
RUN_TIMEOUT_S = 480


def _bimbot(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "bimbot.cli", *args],
        capture_output=True,
        text=True,
        timeout=RUN_TIMEOUT_S,
        check=False,
    )


@pytest.fixture(scope="module")
def frame(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("reproducible")
    ifc = folder / "frame.ifc"
    for args in (
        ("sample", "light-steel-frame", "-o", str(ifc), "--bays", "2x1"),
        ("convert", str(ifc), "-o", str(folder / "build"), "--no-progress"),
    ):
        result = _bimbot(*args)
        assert result.returncode == 0, result.stderr[-2000:]
    shown = _bimbot("fleet", "show")
    assert shown.returncode == 0, shown.stderr[-2000:]
    types = shown.stdout.split("\n[[robots]]")[0]  # the default fleet's types, three carriers on site
    (folder / "carriers.toml").write_text(f'{types}\n[[robots]]\ntype = "carrier"\ncount = 3\n')
    return folder / "build"


def _run(build: Path, run_dir: Path) -> dict:
    fleet = build.parent / "carriers.toml"
    options = ("--fleet", str(fleet), "--derive", "--seed", "1", "--timeout-s", str(RUN_TIMEOUT_S - 90), "-q")
    result = _bimbot("run", str(build), "--run-dir", str(run_dir), *options)
    assert result.returncode == 0, f"run failed:\n{result.stdout}\n{result.stderr[-2000:]}"
    return json.loads((run_dir / "report" / "report.json").read_text())


def test_one_seed_builds_the_same_way_twice(frame: Path, tmp_path: Path) -> None:
    first, second = (_run(frame, tmp_path / f"run{index}") for index in (1, 2))
    assert first["settings"]["seed"] == second["settings"]["seed"] == 1
    a, b = outcome(first), outcome(second)
    assert a.constructed == len(a.components) == 5
    assert sum(len(tasks) > 0 for tasks in a.tasks.values()) >= 2, "a real choice of robots"
    assert differences(a, b) == [], "\n".join(differences(a, b))
    states = [
        [(c["guid"], c["state"], c["robot_ids"], c["attempts"]) for c in r["components"]]
        for r in (first, second)
    ]
    assert states[0] == states[1]
