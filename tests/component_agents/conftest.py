"""The converted bundled light steel frame (28 components) for the agent tests."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest


@pytest.fixture(scope="session")
def agents_build(bundled_build: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A private copy of the bundled build (agent processes write their journal into it)."""
    out = tmp_path_factory.mktemp("agents_build")
    shutil.copytree(bundled_build, out, dirs_exist_ok=True)
    return out
