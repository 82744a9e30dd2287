"""Shared pytest setup: the public IFC sample folder that sits beside the checkout (:data:`SAMPLES_IFC`)."""

from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SAMPLES_IFC = ROOT.parent / "shared" / "samples" / "ifc"


@pytest.fixture(scope="session")
def samples_dir() -> Path:
    """The public IFC samples beside the checkout; tests that need them skip when absent (never in CI)."""
    if not SAMPLES_IFC.is_dir():
        pytest.skip(f"sample folder {SAMPLES_IFC} not present")
    return SAMPLES_IFC


@pytest.fixture(scope="session")
def bundled_build(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The bundled light steel frame converted once per session. Read-only: copy it before writing."""
    from bimbot.demo import bundled_model_path  # heavy imports only when a test needs it
    from bimbot.services.converter.convert import convert_model
    from bimbot.services.converter.ifc_input import open_model

    source = bundled_model_path()
    out = tmp_path_factory.mktemp("bundled_build")
    convert_model(open_model(source), source, out)
    return out
