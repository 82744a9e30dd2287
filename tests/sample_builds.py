"""The public IFC samples converted by ``bimbot convert`` with its defaults once per test run, for every test
file that reads such a conversion: ``converted_sample(name, tmp_path_factory)``, and how the command ended:
``sample_conversion_ended(name, tmp_path_factory)``.

Several files convert the same samples (the Revit house and hub take seconds each, minutes under load), and
with ``--dist loadfile`` they run on different pytest-xdist workers, where a session fixture is converted
once per worker. So the conversion is kept on disk in the run's temporary root, which all workers of a run
share (a single-process run uses its own base folder), under a file lock: the first worker to ask converts,
a worker that asks meanwhile waits for it, the rest read it. A new test run starts from an empty root, so
nothing outlives the code that converted it. The folder is read-only for callers: copy it before writing.

The conversion is the command's ``main`` called in the test process (not a process of its own: seconds of
imports), so a test of the command on every sample reads its exit code, summary and log here instead of
converting each sample again. The command's defaults are ``convert_model``'s (same methods, fleet and joint
rules; it reads the file with ``read_model``, which also reports parse damage).
"""

from __future__ import annotations

import contextlib
import fcntl
import io
import json
import logging
import os
import shutil
from dataclasses import dataclass
from pathlib import Path

import pytest

from bimbot.cli import PLAIN_FORMAT
from bimbot.shared.manifest import Manifest, read_manifest

SAMPLES_DIR = Path(__file__).resolve().parents[2] / "shared" / "samples" / "ifc"
DONE = "converted"  # written once the build is whole: a worker that died mid-conversion left none
ENDED = "ended.json"  # how the command ended: its exit code, stdout and log
LOG_FORMAT = PLAIN_FORMAT  # what a command prints of its warnings (bimbot.cli.log_format)


@dataclass(frozen=True)
class Ended:
    """How ``bimbot convert SAMPLE -o BUILD`` ended: exit code, what it printed, what it logged (WARNING and
    above, the command's default verbosity, in its format with tracebacks)."""

    code: int
    stdout: str
    log: str


def _shared_root(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The temporary folder every worker of this run shares (xdist gives each worker a child of it)."""
    base = tmp_path_factory.getbasetemp()
    return base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base


def _convert_with_the_command(source: Path, build: Path) -> Ended:
    """``bimbot.cli.main(["convert", source, "-o", build])`` here, its log caught by a handler of our own
    on the root logger (so ``main``'s ``basicConfig`` adds none) and the logging state restored after."""
    from bimbot.cli import main  # heavy imports only when a test needs it

    root, transitions = logging.getLogger(), logging.getLogger("transitions")
    levels = root.level, transitions.level
    caught = io.StringIO()
    handler = logging.StreamHandler(caught)
    handler.setLevel(logging.WARNING)
    handler.setFormatter(logging.Formatter(LOG_FORMAT))
    root.addHandler(handler)
    root.setLevel(logging.WARNING)
    printed = io.StringIO()
    try:
        with contextlib.redirect_stdout(printed):
            code = main(["convert", str(source), "-o", str(build), "--no-progress"])
    finally:
        root.removeHandler(handler)
        root.setLevel(levels[0])
        transitions.setLevel(levels[1])
    return Ended(code, printed.getvalue(), caught.getvalue())


def _sample_folder(name: str, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The sample's folder in the shared root, converted by the first caller of this test run."""
    source = SAMPLES_DIR / name
    folder = _shared_root(tmp_path_factory) / "sample-builds" / source.stem
    folder.mkdir(parents=True, exist_ok=True)
    build = folder / "build"
    with open(folder / "lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
        if not (folder / DONE).is_file():
            shutil.rmtree(build, ignore_errors=True)
            ended = _convert_with_the_command(source, build)
            (folder / ENDED).write_text(json.dumps(ended.__dict__))
            (folder / DONE).touch()
    return folder


def converted_sample(name: str, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Manifest]:
    """The build folder of the sample ``name`` (``SAMPLES_DIR/name``) converted by ``bimbot convert`` with
    its defaults, and its manifest; converted by the first caller of this test run, read by the others."""
    build = _sample_folder(name, tmp_path_factory) / "build"
    assert (build / "manifest.json").is_file(), sample_conversion_ended(name, tmp_path_factory)
    return build, read_manifest(build)


def sample_conversion_ended(name: str, tmp_path_factory: pytest.TempPathFactory) -> Ended:
    """How the command that converted the sample ``name`` for this test run ended (see ``Ended``)."""
    return Ended(**json.loads((_sample_folder(name, tmp_path_factory) / ENDED).read_text()))
