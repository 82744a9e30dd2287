"""A mixed fleet over the bus: ``bimbot run --fleet`` on a generated 3×1 frame (3 footings, 3 columns,
2 beams) with a Husky (75 kg, places up to 3 m), a heavy carrier and a tower crane whose 14.5 m jib reaches
every target and its staging area but not every yard slot (which ones depends on the yard's layout: on
this site neither beam's, so both come to the crane by hand-off).

What must happen, and would not if capability-aware planning or hand-offs broke: every component is
constructed; no footing (259 kg) is ever given to the Husky; no beam (its top at 3.16 m) is built by a
ground robot; the crane places the beams at height; a beam out of its reach reaches it through a
hand-off task of a ground robot, which is a task of its own in the report.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from frames import convert_small_frame
from wall_clock import bound_s

from bimbot.shared.manifest import read_manifest
from bimbot.shared.run_folder import RunFolder

pytestmark = pytest.mark.integration
RUN_TIMEOUT_S = 400

FLEET = """
default_type = "carrier"

[types.husky]
urdf = "husky/husky.urdf"
payload_kg = 75
reach_m = 1.5
max_place_height_m = 3.0
length_m = 0.99
width_m = 0.67
max_speed_mps = 1.0
max_turn_radps = 1.5

[types.carrier]
urdf = "carrier.urdf"
payload_kg = 3000
reach_m = 1.8
max_place_height_m = 3.0
length_m = 1.4
width_m = 0.9
max_speed_mps = 0.8
max_turn_radps = 1.0
handling_s = 4.0

[types.tower_crane]
urdf = "tower_crane.urdf"
payload_kg = 2000
reach_m = 14.5
max_place_height_m = 30.0
length_m = 2.0
width_m = 2.0
max_speed_mps = 0
max_turn_radps = 0
handling_s = 20.0

[types.tower_crane.crane]
jib_height_m = 32.0
min_radius_m = 2.5
slew_radps = 0.1
trolley_mps = 1.0
hoist_mps = 1.0
load_chart = [{ radius_m = 10.0, payload_kg = 2000 }, { radius_m = 14.5, payload_kg = 1000 }]

[[robots]]
type = "husky"
count = 1

[[robots]]
type = "carrier"
count = 1

[[robots]]
type = "tower_crane"
count = 1
"""


def _bimbot(*args: str, timeout_s: float = 180) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "bimbot.cli", *args],
        capture_output=True,
        text=True,
        timeout=bound_s(timeout_s),
        check=False,
    )


@pytest.fixture(scope="module")
def frame_3x1(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return convert_small_frame(tmp_path_factory.mktemp("fleet_frame"), (3, 1))


def test_a_mixed_fleet_builds_by_capability_with_crane_lifts_and_hand_offs(
    frame_3x1: Path, tmp_path: Path
) -> None:
    frame = frame_3x1
    fleet = tmp_path / "fleet.toml"
    fleet.write_text(FLEET, encoding="utf-8")
    check = _bimbot("fleet", "check", str(frame), "--fleet", str(fleet), "--json")
    assert check.returncode == 0, check.stderr
    routes = {row["name"]: row["routes"] for row in map(json.loads, check.stdout.splitlines())}
    hand_offs = {name for name, found in routes.items() if any("hand-off" in r for r in found)}
    beams_handed = {name for name in hand_offs if name.startswith("Beam")}  # only the crane places a beam
    assert beams_handed, routes

    run = RunFolder(tmp_path / "run")
    result = _bimbot(
        "run", str(frame), "-q", "--fleet", str(fleet), "--run-dir", str(run.root),
        "--timeout-s", f"{bound_s(RUN_TIMEOUT_S) - 60:.0f}", timeout_s=RUN_TIMEOUT_S,
    )  # fmt: skip
    logs = "\n".join(
        f"--- {log.name}\n" + "\n".join(log.read_text().splitlines()[-12:])
        for log in run.logs_dir.glob("*.log")
    )
    assert result.returncode == 0, f"{result.stdout}\n{result.stderr[-2000:]}\n{logs}"
    report = json.loads((run.report_dir / "report.json").read_text())
    manifest = read_manifest(frame)
    by_guid = {component.guid: component for component in manifest.components}
    assert all(c["state"] == "constructed" for c in report["components"]), report["components"]

    robots = report["robots"]
    assert {robot_id: robot["type"] for robot_id, robot in robots.items()} == {
        "r1": "husky",
        "r2": "carrier",
        "r3": "tower_crane",
    }
    for robot_id, robot in robots.items():
        for task in robot["tasks"]:
            component = by_guid[task["guid"]]
            if robot_id == "r1":  # the Husky: never a footing, never a beam built up there
                assert component.mass_kg <= 75, task
                assert task["kind"] == "hand_off" or component.ifc_class != "IfcBeam", task
            if task["kind"] == "build" and component.ifc_class == "IfcBeam":
                assert robot_id == "r3", f"beam {component.name} built by {robot_id}"
    crane_beams = {task["guid"] for task in robots["r3"]["tasks"] if task["kind"] == "build"}
    beams = {g for g, c in by_guid.items() if c.ifc_class == "IfcBeam"}
    assert len(beams) == 2 and beams <= crane_beams
    hand_off_tasks = [
        task for robot_id in ("r1", "r2") for task in robots[robot_id]["tasks"] if task["kind"] == "hand_off"
    ]
    assert beams_handed <= {by_guid[task["guid"]].name for task in hand_off_tasks} <= hand_offs
    assert all(task["task_id"].endswith("-h1") for task in hand_off_tasks)
    assert report["totals"]["hand_off_tasks"] == len(hand_off_tasks)
    assert report["totals"]["by_type"]["tower_crane"]["build_tasks"] >= len(beams)
    for component in report["components"]:
        if by_guid[component["guid"]].ifc_class == "IfcBeam":
            assert component["final_position_error_mm"] <= 10.0  # at its BIM pose, 3 m up
