"""One run's output folder, apart from the build it ran on: journal, logs, report and recording.

The converted build (``BUILD/manifest.json``, models, world, ``sequence.xml``) is an input that many runs
share; everything a run writes goes to its own folder, so two runs on one build never overwrite each
other and a finished run stays as it was::

    BUILD/runs/20261125-101530/     one run (named by its start time, local clock)
        state/                      the component agents' journal (what a restarted agent resumes from)
        logs/                       one log per service (``bimbot run``)
        report/                     report.json and report.png
        observer/<site>.rrd         the rerun recording
    BUILD/runs/latest -> 20261125-101530

``bimbot run`` makes a new run folder per run and hands it to every service (``--run-dir``), and marks it
ended when it ends (``ENDED``, with how it ended); so does ``bimbot observe`` once the build is done. A
service started by hand without ``--run-dir`` (or in ``docker compose``) joins ``BUILD/runs/latest`` while
that run has not ended, and otherwise makes a new run folder: a finished run is never resumed or
overwritten by accident. :func:`open_run_folder` decides under a lock, so services starting together agree
on one folder.

A build that cannot hold a run folder (read-only, ``runs`` not a folder) is a
:class:`~bimbot.shared.errors.UserError` that says to give the run a folder elsewhere (``--run-dir``).
"""

from __future__ import annotations

import contextlib
import fcntl
import logging
import os
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from bimbot.shared.errors import UserError

_log = logging.getLogger(__name__)

RUNS_DIR_NAME = "runs"
LATEST_NAME = "latest"
ELSEWHERE_NAME = "elsewhere"  # run folders given outside runs/ (--run-dir), one path a line
ENDED_NAME = "ENDED"  # in a run folder: the run is over (its first line says how)
_LOCK_NAME = ".lock"
RUN_DIR_HINT = "a build is input: give the run a folder of its own elsewhere with --run-dir DIR"


@dataclass(frozen=True)
class RunFolder:
    """The paths of one run's output (the folders are made when first written)."""

    root: Path

    @property
    def state_dir(self) -> Path:
        return self.root / "state"

    @property
    def logs_dir(self) -> Path:
        return self.root / "logs"

    @property
    def report_dir(self) -> Path:
        return self.root / "report"

    @property
    def observer_dir(self) -> Path:
        return self.root / "observer"

    def recording_path(self, site: str) -> Path:
        return self.observer_dir / f"{site}.rrd"

    @property
    def ended(self) -> bool:
        return (self.root / ENDED_NAME).is_file()

    def mark_ended(self, how: str) -> None:
        """The run is over: services started later without ``--run-dir`` make a new run folder."""
        self.root.mkdir(parents=True, exist_ok=True)
        (self.root / ENDED_NAME).write_text(how.rstrip("\n") + "\n", encoding="utf-8")


def runs_dir(build_dir: Path) -> Path:
    return Path(build_dir) / RUNS_DIR_NAME


def run_folders(build_dir: Path) -> list[Path]:
    """The build's run folders, oldest first (``latest`` is a link, not one of them)."""
    folder = runs_dir(build_dir)
    if not folder.is_dir():
        return []
    return sorted(path for path in folder.glob("*") if path.is_dir() and not path.is_symlink())


def remember_run_dir(build_dir: Path, run_dir: Path) -> None:
    """Note a run folder given outside ``BUILD/runs/`` (``--run-dir``) in ``BUILD/runs/elsewhere``, so
    ``bimbot runs BUILD`` lists it too. Best effort: a build a user may not write to still runs."""
    run_dir = Path(run_dir).resolve()
    folder = runs_dir(build_dir)
    if run_dir.is_relative_to(folder.resolve()) or run_dir in runs_elsewhere(build_dir):
        return
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with open(folder / ELSEWHERE_NAME, "a", encoding="utf-8") as listing:
            listing.write(f"{run_dir}\n")
    except OSError as error:
        _log.debug("%s: run folder %s not noted (%s)", build_dir, run_dir, error)


def runs_elsewhere(build_dir: Path) -> list[Path]:
    """The run folders given outside ``BUILD/runs/`` that still exist, in the order they were run."""
    try:
        lines = (runs_dir(build_dir) / ELSEWHERE_NAME).read_text(encoding="utf-8").splitlines()
    except OSError:
        return []
    return [Path(line) for line in dict.fromkeys(lines) if line and Path(line).is_dir()]


@contextlib.contextmanager
def _runs_locked(build_dir: Path) -> Iterator[Path]:
    folder = runs_dir(build_dir)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        lock = open(folder / _LOCK_NAME, "a")  # noqa: SIM115 (the with below closes it)
    except OSError as error:
        raise _cannot_make(folder, error) from None
    with lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield folder
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


def new_run_folder(build_dir: Path, now_s: float | None = None) -> RunFolder:
    """A new, empty run folder under ``BUILD/runs/`` named by the time, and ``latest`` pointing to it."""
    with _runs_locked(build_dir) as folder:
        return _make_new(folder, time.time() if now_s is None else now_s)


def open_run_folder(build_dir: Path, run_dir: Path | None = None) -> RunFolder:
    """``run_dir`` when given; else the build's latest run folder while that run has not ended, or a new
    one (logged either way, so a user sees which run a service joined)."""
    if run_dir is not None:
        return RunFolder(Path(run_dir))
    with _runs_locked(build_dir) as folder:
        latest = folder / LATEST_NAME
        if latest.is_dir() and not RunFolder(latest.resolve()).ended:
            joined = RunFolder(latest.resolve())
            _log.info("joining the open run folder %s (runs/latest)", joined.root)
            return joined
        made = _make_new(folder, time.time())
        _log.info("new run folder %s (runs/latest)", made.root)
        return made


def latest_run_folder(build_dir: Path) -> RunFolder | None:
    """The build's latest run folder, or None when it has none."""
    latest = runs_dir(build_dir) / LATEST_NAME
    return RunFolder(latest.resolve()) if latest.is_dir() else None


def _cannot_make(folder: Path, error: OSError) -> UserError:
    return UserError(f"cannot make a run folder in {folder} ({error.strerror or error}); {RUN_DIR_HINT}")


def _make_new(folder: Path, now_s: float) -> RunFolder:
    try:
        return _make_new_folder(folder, now_s)
    except OSError as error:
        raise _cannot_make(folder, error) from None


def _make_new_folder(folder: Path, now_s: float) -> RunFolder:
    stamp = time.strftime("%Y%m%d-%H%M%S", time.localtime(now_s))
    root, number = folder / stamp, 1
    while root.exists():  # two runs within one second
        number += 1
        root = folder / f"{stamp}-{number}"
    root.mkdir()
    link = folder / f".{LATEST_NAME}.{os.getpid()}"
    link.unlink(missing_ok=True)
    link.symlink_to(root.name)  # relative: the build folder can move
    link.replace(folder / LATEST_NAME)  # atomic: a reader sees the old or the new run, never none
    return RunFolder(root)
