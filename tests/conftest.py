"""Shared pytest setup: the public IFC sample folder that sits beside the checkout (``../shared``)."""

from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SAMPLES_IFC = ROOT.parent / "shared" / "samples" / "ifc"


@pytest.fixture(scope="session")
def samples_dir() -> Path:
    """``../shared/samples/ifc``; tests that need it skip when it is absent (never in CI)."""
    if not SAMPLES_IFC.is_dir():
        pytest.skip(f"sample folder {SAMPLES_IFC} not present")
    return SAMPLES_IFC
