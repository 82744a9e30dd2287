"""The public IFC samples converted with the default options once per test run, for every test file that reads
such a conversion: ``converted_sample(name, tmp_path_factory)``.

Several files convert the same samples (the Revit house and hub take seconds each, minutes under load), and
with ``--dist loadfile`` they run on different pytest-xdist workers, where a session fixture is converted
once per worker. So the conversion is kept on disk in the run's temporary root, which all workers of a run
share (a single-process run uses its own base folder), under a file lock: the first worker to ask converts,
a worker that asks meanwhile waits for it, the rest read it. A new test run starts from an empty root, so
nothing outlives the code that converted it. The folder is read-only for callers: copy it before writing.
"""

from __future__ import annotations

import fcntl
import os
import shutil
from pathlib import Path

import pytest

from bimbot.shared.manifest import Manifest, read_manifest

SAMPLES_DIR = Path(__file__).resolve().parents[2] / "shared" / "samples" / "ifc"
DONE = "converted"  # written once the build is whole: a worker that died mid-conversion left none


def _shared_root(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The temporary folder every worker of this run shares (xdist gives each worker a child of it)."""
    base = tmp_path_factory.getbasetemp()
    return base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base


def converted_sample(name: str, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Manifest]:
    """The build folder of the sample ``name`` (``SAMPLES_DIR/name``) converted with ``convert_model``'s
    defaults, and its manifest; converted by the first caller of this test run, read by the others."""
    from bimbot.services.converter.convert import convert_model  # heavy imports only when a test needs it
    from bimbot.shared.ifc_input import open_model

    source = SAMPLES_DIR / name
    folder = _shared_root(tmp_path_factory) / "sample-builds" / source.stem
    folder.mkdir(parents=True, exist_ok=True)
    build = folder / "build"
    with open(folder / "lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
        if not (folder / DONE).is_file():
            shutil.rmtree(build, ignore_errors=True)
            convert_model(open_model(source), source, build)
            (folder / DONE).touch()
    return build, read_manifest(build)
