"""Work in place over the bus: a frame whose footings are cast in place, built by a made-up machine kind
that exists only as a fleet entry (a placing boom on a mast: it stands fixed and pours), with the curing
hold before the columns. Real processes on a loopback bus, real pybullet; the clock skips the formwork and
the three-day cure while nothing else moves."""

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
FORMWORK_S, POUR_S, CURE_S = 4 * 3600.0, 1800.0, 72 * 3600.0
CAST_IN_PLACE = ConstructionMethod.CAST_IN_PLACE

# A kind no service knows by name: a concrete placing boom on a climbing mast (it never drives, it pours
# within its boom). Only its capabilities say what it does.
FLEET = """
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
placement_precision_m = 0.003
placement_precision_yaw_deg = 0.15
[types.placing_boom]
urdf = "carrier.urdf"
capabilities = ["stand_fixed", "pour"]
payload_kg = 1
reach_m = 32
max_place_height_m = 30
length_m = 1.4
width_m = 0.9
max_speed_mps = 0
max_turn_radps = 0
[[robots]]
type = "carrier"
count = 1
[[robots]]
type = "placing_boom"
count = 1
"""


def _bimbot(*args: str) -> subprocess.CompletedProcess[str]:
    command = [sys.executable, "-m", "bimbot.cli", *args]
    return subprocess.run(
        command, capture_output=True, text=True, timeout=bound_s(RUN_TIMEOUT_S), check=False
    )


def test_cast_footings_are_poured_by_the_machine_that_can_pour_and_cure_before_the_columns(
    tmp_path: Path,
) -> None:
    build = convert_small_frame(tmp_path, (2, 1))
    manifest = read_manifest(build)
    cast = CastWork(formwork_area_m2=4.0, volume_m3=1.0, formwork_s=FORMWORK_S, pour_s=POUR_S, cure_s=CURE_S)
    footings = {c.guid for c in manifest.components if c.ifc_class == "IfcFooting"}
    write_manifest(
        manifest.model_copy(
            update={
                "components": [
                    c.model_copy(
                        update={"method": CAST_IN_PLACE, "method_source": MethodSource.USER, "cast": cast}
                    )
                    if c.guid in footings
                    else c
                    for c in manifest.components
                ]
            }
        ),
        build,
    )
    fleet = tmp_path / "fleet.toml"
    fleet.write_text(FLEET, encoding="utf-8")
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
    assert "by method (constructed/components): cast_in_place 2/2, lifted 3/3" in result.stdout, detail
    report = json.loads((run.report_dir / "report.json").read_text())
    by_guid = {c["guid"]: c for c in report["components"]}
    for guid in footings:  # poured by the only machine that can pour, from where it stands
        assert by_guid[guid]["method"] == "cast_in_place"
        assert by_guid[guid]["resources"] == ["placing_boom"]
    poured_s = {guid: by_guid[guid]["constructed_s"] for guid in footings}
    assert min(poured_s.values()) >= FORMWORK_S + POUR_S - 1.0  # formwork and pour took their time
    columns = [c for c in report["components"] if c["ifc_class"] == "IfcColumn"]
    assert len(columns) == 2
    for column in columns:  # released only once the footing under it had cured
        assert column["resources"] == ["carrier"] and column["method"] == "lifted"
        assert column["released_s"] >= min(poured_s.values()) + CURE_S - 1.0
    assert report["totals"]["by_method"] == {
        "cast_in_place": {"components": 2, "constructed": 2},
        "lifted": {"components": 3, "constructed": 3},
    }
    assert "skipped" in (run.logs_dir / "physics.log").read_text()  # the cure passed in a jump
