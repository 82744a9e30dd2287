"""A build that cannot finish ends by itself and says why, per component (issue: every build ends).

The generated site model (``tests/site_models.py``) has what the bundled frame lacks: a 5,760 kg footing
under ``Column A1`` (far above the default robot's 1,000 kg payload) and a room whose four walls, built
first by the model's own IFC 4D schedule, cut its inner column off. ``bimbot run`` starts every service as
a process on a loopback bus and must end, exit 1, and report for every component not constructed a reason
a user can act on: the footing ``too_heavy`` with its mass, the column and beam on it ``blocked_by`` the
footing, the room's column ``unreachable``/``no_approach_pose``; everything else is constructed.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from fleets import ground_fleet_file
from site_models import HEAVY_MASS_KG, ROOM_WALLS, WALLS_FIRST_ORDER, SiteModel, build_site_model
from wall_clock import bound_s

from bimbot.shared.reasons import ReasonCode
from bimbot.shared.run_folder import RunFolder, latest_run_folder

pytestmark = pytest.mark.integration
RUN_TIMEOUT_S = 420


def _bimbot(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "bimbot.cli", *args],
        capture_output=True,
        text=True,
        timeout=bound_s(RUN_TIMEOUT_S),
        check=False,
    )


@pytest.fixture(scope="module")
def walls_first(tmp_path_factory: pytest.TempPathFactory) -> tuple[SiteModel, Path]:
    folder = tmp_path_factory.mktemp("walls_first")
    site = build_site_model(heavy="footing", room=True, schedule=WALLS_FIRST_ORDER)
    source = str(site.write(folder / "site.ifc"))  # everything lifted: the heavy part is too heavy to lift
    converted = _bimbot("convert", source, "-o", str(folder / "build"), "--methods", "lifted")
    assert converted.returncode == 0, converted.stderr[-2000:]
    return site, folder / "build"


def test_a_build_that_cannot_finish_ends_with_a_reason_for_every_component_not_built(
    walls_first: tuple[SiteModel, Path],
) -> None:
    site, build = walls_first
    fleet = str(ground_fleet_file(build.parent))  # one carrier: the 5.8 t footing is too heavy for it
    timeout_s = f"{bound_s(RUN_TIMEOUT_S) - 60:.0f}"
    result = _bimbot("run", str(build), "-q", "--fleet", fleet, "--timeout-s", timeout_s)
    run = _latest(build)
    logs = "\n".join(
        f"--- {log.name}\n" + "\n".join(log.read_text().splitlines()[-12:])
        for log in sorted(run.logs_dir.glob("*.log"))
    )
    assert result.returncode == 1, f"{result.stdout}\n{result.stderr[-2000:]}\n{logs}"
    report = json.loads((run.report_dir / "report.json").read_text())
    by_name = {c["name"]: c for c in report["components"]}
    constructed = {name for name, c in by_name.items() if c["state"] == "constructed"}
    assert constructed == {"Column A2", *ROOM_WALLS}, logs

    footing = by_name["Footing A1"]
    assert footing["state"] == "failed" and footing["reason"]["code"] == ReasonCode.TOO_HEAVY
    assert f"{HEAVY_MASS_KG['footing']:,.0f}" in footing["reason"]["message"]
    for name in ("Column A1", "Beam A1-A2"):
        component = by_name[name]
        assert component["state"] == "blocked" and component["reason"]["code"] == ReasonCode.BLOCKED_BY
        assert component["reason"]["guid"] in (site.guid("Footing A1"), site.guid("Column A1"))
    column = by_name["Column R1"]
    assert column["state"] == "failed", column
    assert column["reason"]["code"] in (ReasonCode.UNREACHABLE, ReasonCode.NO_APPROACH_POSE), column
    # the terminal table names what was not built and why
    for name in ("Footing A1", "Column R1"):
        assert site.guid(name) in result.stdout + result.stderr
    assert "too_heavy" in result.stdout + result.stderr
    # the planner's warnings reach the user's summary, not only its log
    assert "the planner warned about its plan" in result.stdout and "cuts off" in result.stdout


def test_with_strict_a_sequence_that_walls_a_column_in_is_refused_before_the_build(
    walls_first: tuple[SiteModel, Path],
) -> None:
    site, build = walls_first
    earlier = _runs(build)
    fleet = str(ground_fleet_file(build.parent))
    timeout_s = f"{bound_s(120):.0f}"  # refused before the build: this only stops a hang
    result = _bimbot("run", str(build), "-q", "--fleet", fleet, "--strict", "--timeout-s", timeout_s)
    planner_log = (_latest(build).logs_dir / "planner.log").read_text()
    # a run of its own: the earlier runs on this build keep their folders and reports
    assert len(_runs(build)) == len(earlier) + 1 and set(earlier) < set(_runs(build))
    assert all((run / "report" / "report.json").is_file() for run in earlier)
    assert result.returncode == 2, f"{result.stdout}\n{result.stderr[-2000:]}\n{planner_log[-2000:]}"
    assert "cut off" in planner_log and site.guid("Column R1") in planner_log


def _latest(build: Path) -> RunFolder:
    run = latest_run_folder(build)
    assert run is not None, f"no run folder under {build}/runs"
    return run


def _runs(build: Path) -> list[Path]:
    folder = build / "runs"
    return sorted(p for p in folder.iterdir() if p.is_dir() and not p.is_symlink()) if folder.is_dir() else []
