"""The export tests' run: the bundled frame built in order by two robots, the last component failed
(:mod:`export_runs`)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from export_runs import RUN_NAME, write_run

from bimbot.shared.manifest import read_manifest
from bimbot.shared.sequence import read_sequence


@pytest.fixture(scope="session")
def frame_run(bundled_build: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A copy of the bundled build with one finished run (read-only: copy it before writing)."""
    build = tmp_path_factory.mktemp("export_frame") / "build"
    shutil.copytree(bundled_build, build)
    manifest = read_manifest(build)
    write_run(build, manifest, read_sequence(build / manifest.sequence_file).guids())
    return build / "runs" / RUN_NAME
