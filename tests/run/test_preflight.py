"""``bimbot run`` checks the user's input before it starts any service: one line, exit 2, no process.

A missing or broken ``--sequence`` used to start every service, let the planner exit 2 into its log and
show "0/28 constructed" with exit 1. Now the run's own process rejects it: no run folder (``runs/``, where
every service logs from its start) and nothing but one line on stderr.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from wall_clock import bound_s

from bimbot.run.options import RunOptions
from bimbot.run.preflight import check_run_input
from bimbot.shared.errors import UserError


@pytest.fixture
def build(bundled_build: Path, tmp_path: Path) -> Path:
    copy = tmp_path / "build"
    shutil.copytree(bundled_build, copy)
    return copy


def _nothing_started(build: Path) -> bool:
    """No run folder and no log: a run makes BUILD/runs/<time>/logs/ before it starts its first service."""
    return not (build / "runs").exists() and not (build / "logs").exists()


def _run(build: Path, *options: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-P", "-m", "bimbot.cli", "run", str(build), "-q", *options],
        check=False,
        capture_output=True,
        text=True,
        timeout=bound_s(120),
    )


@pytest.mark.parametrize("content", [None, "this is not XML", "<sequence><task guid='nope'/></sequence>"])
def test_a_bad_sequence_exits_2_with_one_line_before_any_service_starts(
    build: Path, tmp_path: Path, content: str | None
) -> None:
    sequence = tmp_path / "sequence.xml"
    if content is not None:
        sequence.write_text(content)
    done = _run(build, "--sequence", str(sequence))
    assert done.returncode == 2, done.stderr
    lines = [line for line in done.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, done.stderr
    assert str(sequence) in lines[0] or "sequence" in lines[0]
    assert "Traceback" not in done.stderr
    assert _nothing_started(build), "a service was started"
    assert "constructed" not in done.stdout


def test_an_impossible_robot_option_is_rejected_before_the_run(build: Path) -> None:
    with pytest.raises(UserError, match="inject-placement-error"):
        check_run_input(build, RunOptions(inject_placement_error_m=-1.0))
    assert _nothing_started(build)


def test_a_control_period_that_is_no_whole_number_of_physics_steps_is_rejected(build: Path) -> None:
    with pytest.raises(UserError, match="physics"):
        check_run_input(build, RunOptions(physics_hz=120.0, control_period_s=0.0125))


def test_a_good_run_passes_the_checks_and_starts_nothing(build: Path) -> None:
    checked = check_run_input(build, RunOptions(planner_source=("--derive",)))
    assert checked.manifest.components
    assert _nothing_started(build)
