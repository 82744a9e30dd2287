"""Shared pytest setup: the public IFC sample folder that sits beside the checkout (:data:`SAMPLES_IFC`), and
the order the test files run in.

``scripts/check.sh`` runs the suite on two pytest-xdist workers, a file at a time each (``--dist
loadfile``). The longest files go first — the compose stack, then the builds over the bus — so that they
overlap the many short ones instead of running alone at the end (the compose test alone is about two
minutes). Within a file the order is unchanged. xdist then hands out the files with the most tests first
(its default reorder; keeping this order instead measured slower, see ``scripts/check.sh``), except the
compose smoke test, which goes first all the same (:func:`pytest_xdist_make_scheduler`): as a one-test
file the reorder put it among the last, and most of its time is docker's (an image build, a stack at
work) that then ran alone at the end instead of beside the other worker's files.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from wall_clock import SLOWDOWN_ENV, speed_factor

ROOT = Path(__file__).resolve().parents[1]
SAMPLES_IFC = ROOT.parent / "shared" / "samples" / "ifc"


def _file_rank(path: Path, integration: bool) -> int:
    if "compose" in path.parts:
        return 0
    return 1 if integration else 2


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Longest files first (see the module); a stable sort, so each file's tests keep their order."""
    integration_files = {item.path for item in items if item.get_closest_marker("integration") is not None}
    ranks = {item.path: _file_rank(item.path, item.path in integration_files) for item in items}
    items.sort(key=lambda item: ranks[item.path])


COMPOSE_SMOKE = "tests/compose/test_compose_smoke.py"


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config: pytest.Config, log: object) -> object | None:
    """With ``--dist loadfile``: xdist's own scheduling, the compose smoke test's file handed out first."""
    if config.getoption("dist", None) != "loadfile":
        return None
    from xdist.scheduler import LoadFileScheduling

    class ComposeFirst(LoadFileScheduling):
        def _assign_work_unit(self, node: object) -> None:
            if COMPOSE_SMOKE in self.workqueue:
                self.workqueue.move_to_end(COMPOSE_SMOKE, last=False)
            super()._assign_work_unit(node)  # type: ignore[arg-type]

    return ComposeFirst(config, log)  # type: ignore[arg-type]


def pytest_report_header(config: pytest.Config) -> str:
    """The factor every wall-clock bound of this run is scaled by (tests/wall_clock.py)."""
    return f"wall-clock bounds: x{speed_factor():.2f} (measured speed factor; {SLOWDOWN_ENV} sets a floor)"


@pytest.fixture(scope="session", autouse=True)
def warm_fork_server() -> Iterator[Path]:
    """One warm fork server per test process (each xdist worker): every ``bimbot run`` a test starts takes
    a session of it instead of loading the services' code itself (2-5 s of each run's start-up; see
    :mod:`bimbot.warm_fork_server`). A run that cannot use it starts its own fork server, as without one;
    tests/run/test_fork_server.py tests the run's own server with the variable unset."""
    from bimbot.warm_fork_server import for_the_runs_of_this_process

    with for_the_runs_of_this_process() as path:
        yield path


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
    from bimbot.shared.ifc_input import open_model

    source = bundled_model_path()
    out = tmp_path_factory.mktemp("bundled_build")
    convert_model(open_model(source), source, out)
    return out
