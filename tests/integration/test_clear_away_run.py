"""``bimbot run --fidelity plan`` over the bus: a part that cannot stand falls across the robot's only way
into a room, the planner has it carried back to the yard, and what lay behind it is built.

The model (generated): a 6 m square room of existing walls (``--in-place IfcWall``) with one doorway, 2.6 m
wide, in its west wall; ``Beam D1`` hangs over the doorway at 2.2 m, touching nothing (run without
connections nothing holds it: it falls into the doorway, the carrier's only way in); ``Column R1`` stands
at the room's centre, 3 m inside, beyond the carrier's 1.8 m reach from outside. The schedule builds the
beam first. With one attempt the beam fails where it fell; the carrier carries it to its yard slot, then
builds the column. Without the clear-away the column is cut off and fails ``unreachable``.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from site_models import _Builder

pytestmark = pytest.mark.integration
RUN_TIMEOUT_S = 420
ROOM_CENTRE_M = (10.0, 0.0)
INNER_M, WALL_M, HEIGHT_M, DOORWAY_M = 6.0, 0.2, 2.0, 2.6


def _model(path: Path) -> dict[str, str]:
    """The model of the module doc, written to ``path``; name → GlobalId."""
    builder = _Builder("IFC4")
    cx, cy = ROOM_CENTRE_M
    half, t = INNER_M / 2, WALL_M
    west = cx - half - t
    jamb = half - DOORWAY_M / 2  # each wall piece beside the doorway
    walls = {
        "Wall R-S": ((INNER_M + 2 * t, t, HEIGHT_M), (west, cy - half - t, 0.0)),
        "Wall R-N": ((INNER_M + 2 * t, t, HEIGHT_M), (west, cy + half, 0.0)),
        "Wall R-E": ((t, INNER_M, HEIGHT_M), (cx + half, cy - half, 0.0)),
        "Wall R-W1": ((t, jamb, HEIGHT_M), (west, cy - half, 0.0)),
        "Wall R-W2": ((t, jamb, HEIGHT_M), (west, cy + DOORWAY_M / 2, 0.0)),
    }
    for name, (size, corner) in walls.items():
        builder.box("IfcWall", name, size, corner, "timber")
    beam_m = DOORWAY_M - 0.2
    builder.box("IfcBeam", "Beam D1", (0.15, beam_m, 0.15), (west + 0.025, cy - beam_m / 2, 2.2), "steel")
    builder.box("IfcColumn", "Column R1", (0.15, 0.15, HEIGHT_M), (cx - 0.075, cy - 0.075, 0.0), "steel")
    builder.schedule(["Beam D1", "Column R1"])
    builder.assign_guids()
    builder.file.write(str(path))
    return {name: str(element.GlobalId) for name, element in builder.elements.items()}


def _bimbot(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "bimbot.cli", *args],
        capture_output=True,
        text=True,
        timeout=RUN_TIMEOUT_S,
        check=False,
    )


def test_a_fallen_part_across_the_only_doorway_is_cleared_and_what_lay_behind_it_is_built(
    tmp_path: Path,
) -> None:
    guids = _model(tmp_path / "room.ifc")
    build = tmp_path / "build"
    converted = _bimbot("convert", str(tmp_path / "room.ifc"), "-o", str(build), "--in-place", "IfcWall")
    assert converted.returncode == 0, converted.stderr[-2000:]
    shown = _bimbot("fleet", "show")
    types = shown.stdout.split("\n[[robots]]")[0]
    fleet = tmp_path / "carrier.toml"
    fleet.write_text(f'{types}\n[[robots]]\ntype = "carrier"\ncount = 1\n')
    run_dir = build / "runs" / "clear"
    result = _bimbot(
        "run", str(build), "--fidelity", "plan", "--fleet", str(fleet), "--run-dir", str(run_dir), "-q",
        "--no-connections", "--max-attempts", "1", "--timeout-s", str(RUN_TIMEOUT_S - 90),
    )  # fmt: skip
    report_file = run_dir / "report" / "report.json"
    assert report_file.is_file(), f"no report:\n{result.stdout}\n{result.stderr[-3000:]}"
    report = json.loads(report_file.read_text())
    entries = {entry["guid"]: entry for entry in report["components"]}
    beam, column = entries[guids["Beam D1"]], entries[guids["Column R1"]]
    planner_log = (run_dir / "logs" / "planner.log").read_text()
    assert beam["state"] == "failed", f"the beam was to fall: {beam['state']}\n{planner_log[-3000:]}"
    cleared = beam["cleared_away"]
    assert cleared is not None and cleared["cleared"] is True, f"{cleared}\n{planner_log[-3000:]}"
    assert cleared["robot_id"] == "r1" and cleared["took_s"] > 0.0
    assert column["state"] == "constructed", f"{column['reason']}\n{planner_log[-3000:]}"
    assert report["totals"]["cleared_away"] == 1
    assert "failed bodies cleared out of the robots' way" in result.stdout
