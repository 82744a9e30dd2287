"""One run of a study: ``bimbot run`` as a process of its own, and its row (:mod:`.rows`).

This is what a Dask task executes, on whichever worker it lands: the build and the study folder must be at
the same paths there (one machine, or a shared folder). The process leads its own process group, and a run
that outlives its limit is ended with its whole group (``bimbot run`` and the services it started), so a
stuck run costs its time limit and no more. Whatever happens, the answer is a row: a run that wrote no
report is a ``failed`` row with the reason (the process's last words, the exit code, or the time limit).
"""

from __future__ import annotations

import json
import logging
import os
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .grid import StudyRun, run_arguments
from .rows import failed_row, report_row

_log = logging.getLogger(__name__)

GRACE_S = 120.0  # beyond the run's own --timeout-s: stopping its services and writing its report
REASON_CHARS = 300


@dataclass(frozen=True)
class RunJob:
    """Everything a worker needs for one run (plain values: it travels to the worker pickled)."""

    build: Path
    study_dir: Path
    run: StudyRun
    timeout_s: float
    pass_seed: bool
    extra: tuple[str, ...] = ()

    @property
    def run_dir(self) -> Path:
        return self.study_dir / "runs" / self.run.name


def fleet_rates(fleet: Path) -> dict[str, float | None]:
    """Robot type → hourly rate from the fleet file (None where it gives none, or the file is unusable:
    the run itself then says what is wrong with it)."""
    from bimbot.shared.errors import UserError
    from bimbot.shared.fleet import load_fleet

    try:
        return {name: description.cost_per_h for name, description in load_fleet(fleet).types.items()}
    except UserError:
        return {}


def _last_words(*texts: str) -> str:
    """The last non-empty line of the first text that has one (stderr, then stdout)."""
    for text in texts:
        lines = [line.strip() for line in text.splitlines() if line.strip()]
        if lines:
            return lines[-1][:REASON_CHARS]
    return ""


def _stop_group(process: subprocess.Popen[str]) -> None:
    """TERM the run's process group (it stops its services and writes its report), then KILL it."""
    for sig, wait_s in ((signal.SIGTERM, 30.0), (signal.SIGKILL, 10.0)):
        try:
            os.killpg(process.pid, sig)
        except ProcessLookupError:
            return
        try:
            process.wait(timeout=wait_s)
            return
        except subprocess.TimeoutExpired:
            continue


def run_one(job: RunJob) -> dict[str, Any]:
    """Run ``job`` as ``python -m bimbot.cli run …`` in its own run folder and return its row."""
    run_dir = job.run_dir
    run_dir.mkdir(parents=True, exist_ok=True)
    command = [sys.executable, "-m", "bimbot.cli", *command_arguments(job)]
    relative = str(run_dir.relative_to(job.study_dir))
    report_path = run_dir / "report" / "report.json"
    report_path.unlink(missing_ok=True)  # a study run again into its folder: this run's report only
    started = time.perf_counter()
    process = subprocess.Popen(
        command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True
    )
    timed_out = False
    try:
        stdout, stderr = process.communicate(timeout=job.timeout_s + GRACE_S)
    except subprocess.TimeoutExpired:
        timed_out = True
        _stop_group(process)
        stdout, stderr = process.communicate()
    wall_s = time.perf_counter() - started
    (run_dir / "study-run.log").write_text(f"$ {' '.join(command)}\n{stdout}\n{stderr}", encoding="utf-8")
    code = process.returncode
    if timed_out:
        reason = f"no end within {job.timeout_s + GRACE_S:.0f} s wall (the run's limit and its grace)"
        return failed_row(job.run, reason, code, wall_s, relative)
    try:
        report = json.loads(report_path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as error:
        words = _last_words(stderr, stdout) or f"{type(error).__name__}: {error}"
        return failed_row(job.run, f"no report (exit {code}): {words}", code, wall_s, relative)
    if code not in (0, 1):  # a report left from a run that then broke (input error, signal, bug)
        words = _last_words(stderr, stdout)
        return failed_row(job.run, f"exit {code}: {words}", code, wall_s, relative)
    return report_row(job.run, report, code, fleet_rates(job.run.fleet), wall_s=wall_s, run_dir=relative)


def command_arguments(job: RunJob) -> list[str]:
    """The ``bimbot`` arguments of ``job``'s run."""
    return run_arguments(
        job.build, job.run, job.run_dir, job.timeout_s, pass_seed=job.pass_seed, extra=job.extra
    )
