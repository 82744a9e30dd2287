"""A truck-mounted pump relocates over the bus: two footings cast in place, 3 m apart, under a pump whose
short boom (5.2 m) covers only one of them from any set-up position the site plan gives it. It pours one,
stows, drives to another set-up (busy for its set-up time and the drive, which the planner's quiet clock
skips), physics moves its base there, and it pours the other. Real processes on a loopback bus, real
pybullet."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from frames import convert_small_frame
from wall_clock import bound_s

from bimbot.shared.construction_methods import CastWork, ConstructionMethod, MethodSource
from bimbot.shared.manifest import read_manifest, write_manifest
from bimbot.shared.run_folder import RunFolder

pytestmark = pytest.mark.integration
RUN_TIMEOUT_S = 300
SETUP_S, SPEED_MPS = 600.0, 1.0
FORMWORK_S, POUR_S, CURE_S = 1800.0, 600.0, 3600.0

FLEET = f"""
default_type = "carrier"
[types.carrier]
urdf = "carrier.urdf"
payload_kg = 3000
reach_m = 1.8
max_place_height_m = 3.5
length_m = 1.4
width_m = 0.9
max_speed_mps = 0.8
max_turn_radps = 1.0
handling_s = 4.0
[types.short_pump]
urdf = "carrier.urdf"
capabilities = ["stand_fixed", "pour", "relocate"]
payload_kg = 1
reach_m = 5.2
max_place_height_m = 30
length_m = 1.4
width_m = 0.9
max_speed_mps = 0
max_turn_radps = 0
relocation_speed_mps = {SPEED_MPS}
setup_s = {SETUP_S}
[[robots]]
type = "carrier"
count = 1
[[robots]]
type = "short_pump"
count = 1
"""


def _bimbot(*args: str) -> subprocess.CompletedProcess[str]:
    command = [sys.executable, "-m", "bimbot.cli", *args]
    return subprocess.run(
        command, capture_output=True, text=True, timeout=bound_s(RUN_TIMEOUT_S), check=False
    )


def test_the_pump_relocates_to_pour_the_footing_its_boom_cannot_reach_from_where_it_stands(
    tmp_path: Path,
) -> None:
    build = convert_small_frame(tmp_path, (2, 1))
    manifest = read_manifest(build)
    cast = CastWork(formwork_area_m2=2.0, volume_m3=0.1, formwork_s=FORMWORK_S, pour_s=POUR_S, cure_s=CURE_S)
    footings = {c.guid for c in manifest.components if c.ifc_class == "IfcFooting"}
    assert len(footings) == 2
    update = {"method": ConstructionMethod.CAST_IN_PLACE, "method_source": MethodSource.USER, "cast": cast}
    components = [c.model_copy(update=update) if c.guid in footings else c for c in manifest.components]
    write_manifest(manifest.model_copy(update={"components": components}), build)
    fleet = tmp_path / "fleet.toml"
    fleet.write_text(FLEET, encoding="utf-8")
    check = _bimbot("fleet", "check", str(build), "--fleet", str(fleet))
    assert "buildable: 5 of 5" in check.stdout, check.stdout + check.stderr
    run = RunFolder(tmp_path / "run")
    result = _bimbot(
        "run",
        str(build),
        "--fleet",
        str(fleet),
        "--derive",
        "--run-dir",
        str(run.root),
        "--timeout-s",
        f"{bound_s(RUN_TIMEOUT_S) - 60:.0f}",
    )
    detail = f"{result.stdout}\n{result.stderr[-3000:]}"
    assert result.returncode == 0, detail
    assert "constructed 5/5 components" in result.stdout, detail
    report = json.loads((run.report_dir / "report.json").read_text())
    by_guid = {c["guid"]: c for c in report["components"]}
    assert {by_guid[guid]["resources"][0] for guid in footings} == {"short_pump"}
    pump = report["robots"]["r2"]
    assert pump["type"] == "short_pump" and pump["relocations"] >= 1, pump
    assert report["robots"]["r1"]["relocations"] == 0
    first, second = sorted(by_guid[guid]["constructed_s"] for guid in footings)
    assert second - first >= SETUP_S + FORMWORK_S + POUR_S - 1.0  # the relocation took its time
    robot_log = (run.logs_dir / "robot-r2.log").read_text()
    assert "relocating to" in robot_log and "set up at" in robot_log
    assert "set up at" in (run.logs_dir / "physics.log").read_text()  # physics moved its base
