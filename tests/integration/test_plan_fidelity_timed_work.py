"""``bimbot run --fidelity plan`` over the bus with timed work that ends at different times: a 2×1 frame
whose footings are cast in place by two placing booms, one footing's formwork two hours longer than the
other's. The plan fidelity's clock jumps to each known end; the boom whose formwork ends first says so at
the step the clock jumped to, and the clock must not jump on past it to the other boom's end before it
heard that (nor past a skip the planner asked for): each footing's pour begins where its formwork ends,
and no task is given back for want of progress. Nor past the end of a footing's curing, which only the
planner knows: the column on it is released there."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from frames import convert_small_frame
from test_work_in_place_run import FLEET
from wall_clock import bound_s

from bimbot.shared.construction_methods import CastWork, ConstructionMethod, MethodSource
from bimbot.shared.manifest import Manifest, read_manifest, write_manifest

pytestmark = pytest.mark.integration
RUN_TIMEOUT_S = 240
FORMWORK_S, LONGER_S, POUR_S, CURE_S = 4 * 3600.0, 2 * 3600.0, 1800.0, 24 * 3600.0


def _cast_footings(
    build: Path, formwork_s: float = FORMWORK_S, longer_s: float = LONGER_S, cure_s: float = CURE_S
) -> dict[str, float]:
    """Make the frame's footings cast in place, the second one's formwork longer: GUID → its formwork."""
    manifest = read_manifest(build)
    footings = sorted(c.guid for c in manifest.components if c.ifc_class == "IfcFooting")
    formwork = {guid: formwork_s + index * longer_s for index, guid in enumerate(footings)}
    components = [
        c.model_copy(
            update={
                "method": ConstructionMethod.CAST_IN_PLACE,
                "method_source": MethodSource.USER,
                "cast": CastWork(
                    formwork_area_m2=4.0,
                    volume_m3=1.0,
                    formwork_s=formwork[c.guid],
                    pour_s=POUR_S,
                    cure_s=cure_s,
                ),
            }
        )
        if c.guid in formwork
        else c
        for c in manifest.components
    ]
    write_manifest(manifest.model_copy(update={"components": components}), build)
    return formwork


def _run_two_booms(tmp_path: Path, build: Path) -> dict:
    """``bimbot run --fidelity plan`` of ``build`` with a carrier and two placing booms: its report."""
    fleet = tmp_path / "fleet.toml"
    fleet.write_text(FLEET.replace('type = "placing_boom"\ncount = 1', 'type = "placing_boom"\ncount = 2'))
    run_dir = tmp_path / "run"
    command = [
        sys.executable, "-m", "bimbot.cli", "run", str(build), "--fidelity", "plan", "--fleet", str(fleet),
        "--derive", "--run-dir", str(run_dir), "-q", "--timeout-s", f"{bound_s(RUN_TIMEOUT_S) - 60:.0f}",
    ]  # fmt: skip
    timeout_s = bound_s(RUN_TIMEOUT_S)
    result = subprocess.run(command, capture_output=True, text=True, timeout=timeout_s, check=False)
    detail = f"{result.stdout}\n{result.stderr[-3000:]}"
    assert result.returncode == 0, detail
    return json.loads((run_dir / "report" / "report.json").read_text())


def test_each_pour_begins_where_its_formwork_ends_though_the_clock_jumps(tmp_path: Path) -> None:
    build = convert_small_frame(tmp_path, (2, 1))
    formwork = _cast_footings(build)
    report = _run_two_booms(tmp_path, build)
    by_guid = {c["guid"]: c for c in report["components"]}
    booms = {by_guid[guid]["robot_ids"][0] for guid in formwork}
    assert len(booms) == 2, "each boom casts one footing (their work ends apart)"
    for guid, formwork_s in formwork.items():
        footing = by_guid[guid]
        assert footing["state"] == "constructed" and footing["give_backs"] == [], footing
        began_s = footing["pouring_s"] - (footing["forming_s"] + formwork_s)
        assert 0.0 <= began_s < 5.0, f"{guid}: its pour began {began_s:.1f} s after its formwork's end"
    assert report["totals"]["give_backs"] == 0


def test_a_column_is_released_where_its_footing_has_cured_while_the_other_is_being_set(
    tmp_path: Path,
) -> None:
    """The footings cure a minute apart: the second one's curing ends while the carrier holds the first
    column on its bolts, a hold physics' clock jumps to the end of. The planner asks no skip then (a robot
    is at work), so that curing's end is known to physics only from the planner's answer to the step:
    each column is released where its footing has cured, not where the first column's hold ends."""
    build = convert_small_frame(tmp_path, (2, 1))
    formwork = _cast_footings(build, formwork_s=3600.0, longer_s=60.0, cure_s=3600.0)
    manifest = read_manifest(build)
    report = _run_two_booms(tmp_path, build)
    by_guid = {c["guid"]: c for c in report["components"]}
    first, second = sorted(formwork, key=formwork.__getitem__)
    column_of = {footing: _column_on(manifest, footing) for footing in formwork}
    # the second footing cures while the first column is held: the case this test is about
    assert by_guid[column_of[first]]["picked_s"] < by_guid[second]["curing"]["until_s"]
    assert by_guid[second]["curing"]["until_s"] < by_guid[column_of[first]]["constructed_s"]
    for footing in formwork:
        column, cured_s = by_guid[column_of[footing]], by_guid[footing]["curing"]["until_s"]
        assert column["state"] == "constructed", column
        late_s = column["released_s"] - cured_s
        assert 0.0 <= late_s < 5.0, f"{column['name']} released {late_s:.1f} s after its footing cured"
    assert report["totals"]["give_backs"] == 0


def _column_on(manifest: Manifest, footing: str) -> str:
    """The column standing on ``footing`` (its centre over the footing's plan)."""
    low, high = manifest.component(footing).bbox_world.min_m, manifest.component(footing).bbox_world.max_m
    on_it = [
        c.guid
        for c in manifest.components
        if c.ifc_class == "IfcColumn"
        and low[0] <= (c.bbox_world.min_m[0] + c.bbox_world.max_m[0]) / 2 <= high[0]
        and low[1] <= (c.bbox_world.min_m[1] + c.bbox_world.max_m[1]) / 2 <= high[1]
    ]
    assert len(on_it) == 1, on_it
    return on_it[0]
