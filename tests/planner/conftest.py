"""Converted builds for the planner tests: the bundled light steel frame, construction_scheduling_task.ifc.

Each build is converted once per session with ``bimbot.services.converter.convert.convert_model``.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from bimbot.services.converter.convert import ConvertOptions, convert_model
from bimbot.shared.ifc_input import open_model
from bimbot.shared.methods_file import load_methods

SCHEDULING_TASK_IFC = "construction_scheduling_task.ifc"


def _convert(source: Path, out: Path) -> Path:
    """Converted with the paper's ``lifted`` methods: every element one component (the planner tests
    follow the IFC's tasks, which name the elements, not the panels a heavy wall would be split into)."""
    convert_model(open_model(source), source, out, ConvertOptions(methods=load_methods("lifted")))
    return out


@pytest.fixture(scope="session")
def frame_build(bundled_build: Path) -> Path:
    """The bundled 28-component light steel frame, converted (its sequence.xml is its IFC schedule)."""
    return bundled_build


@pytest.fixture(scope="session")
def scheduling_build(tmp_path_factory: pytest.TempPathFactory, samples_dir: Path) -> tuple[Path, Path]:
    """(build, source IFC) of construction_scheduling_task.ifc: a slab, 4 walls, IfcRelSequence links."""
    source = samples_dir / SCHEDULING_TASK_IFC
    if not source.is_file():
        pytest.skip(f"{source} not present")
    return _convert(source, tmp_path_factory.mktemp("scheduling_build")), source


@pytest.fixture(scope="session")
def walls_first_build(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The generated site with a room of four walls round Column R1, its IFC schedule putting the walls
    first (``site_models.WALLS_FIRST_ORDER``), converted."""
    from site_models import WALLS_FIRST_ORDER, build_site_model

    folder = tmp_path_factory.mktemp("walls_first_plan")
    site = build_site_model(heavy="footing", room=True, schedule=WALLS_FIRST_ORDER)
    source = site.write(folder / "site.ifc")
    convert_model(open_model(source), source, folder / "build")
    return folder / "build"
