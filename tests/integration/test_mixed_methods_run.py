"""Every construction method in one build over the bus: a generated site (tests/mixed_methods_model.py) with a
ground slab the IFC says is cast in situ, a block wall laid on it, a 9 t concrete wall on it that the
default fleet cannot lift whole (so ``prefab`` panelises it), a steel pile driven by the piling rig, a pad
footing cast by rule on it with an anchor bolt embedded in it (``with_host``: a guest of the footing) and a
steel column on a base plate over it.

The methods come from the IFC and the default ``prefab`` rules, but for the block wall: ``prefab`` lifts
masonry, so the methods file passed to ``bimbot convert --methods`` lays it (``[by_material] masonry =
"laid"``). The same file lets a crane or robot go of a part 10 s after setting it: the connection holds are
test_connections_run's, and at their defaults they would be most of the stepped physics here.
``bimbot convert`` then ``bimbot run`` as processes on a loopback bus, real pybullet, with the default
fleet's carrier and its fixed machines (``--robots 1``: a carrier, the tower crane, the concrete pump, the
block layer, the line pump and the piling rig). The elements are small, so the formwork, pours and cures
are most of the sim time, and the planner's quiet clock skips them."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from mixed_methods_model import MASONRY_LAID, PILE_M, write_mixed_methods_model
from wall_clock import bound_s

from bimbot.shared.fleet import default_fleet
from bimbot.shared.manifest import read_manifest
from bimbot.shared.run_folder import RunFolder
from bimbot.shared.sequence import read_sequence

pytestmark = pytest.mark.integration
RUN_TIMEOUT_S = 300
LIFT_KG = 8000.0  # the default fleet's largest lift: the tower crane's


def _bimbot(*args: str) -> subprocess.CompletedProcess[str]:
    command = [sys.executable, "-m", "bimbot.cli", *args]
    return subprocess.run(
        command, capture_output=True, text=True, timeout=bound_s(RUN_TIMEOUT_S), check=False
    )


def _began_s(component: dict[str, Any]) -> float:
    """When work on a component began on site: formwork, laying, or the pick of a part that is set down."""
    keys = ("forming_s", "laying_s", "driving_s", "picked_s")
    began = [component[key] for key in keys if component[key] is not None]
    assert began, component
    return float(min(began))


def test_a_site_is_cast_laid_panelised_and_lifted_with_its_anchor_bolt_cast_in_and_cured_before_loading(
    tmp_path: Path,
) -> None:
    ifc, build, methods = tmp_path / "site.ifc", tmp_path / "build", tmp_path / "methods.toml"
    guid = write_mixed_methods_model(ifc)
    methods.write_text(MASONRY_LAID, encoding="utf-8")
    converted = _bimbot("convert", str(ifc), "-o", str(build), "--methods", str(methods), "--no-progress")
    assert converted.returncode == 0, converted.stderr[-3000:]
    run = RunFolder(tmp_path / "run")
    result = _bimbot(
        "run",
        str(build),
        "--robots",
        "1",
        "--run-dir",
        str(run.root),
        "--timeout-s",
        f"{bound_s(RUN_TIMEOUT_S) - 60:.0f}",
    )
    detail = f"{result.stdout}\n{result.stderr[-3000:]}"
    assert result.returncode == 0, detail
    assert "constructed 7/7 components" in result.stdout, detail
    assert (
        "by method (constructed/components): "
        "cast_in_place 2/2, driven 1/1, laid 1/1, lifted 1/1, panelised 2/2; "
        "besides them: with_host 2/2 (built into their hosts)" in result.stdout
    ), detail
    report = json.loads((run.report_dir / "report.json").read_text())
    by_guid = {c["guid"]: c for c in report["components"]}
    assert all(c["state"] == "constructed" for c in report["components"]), detail
    slab, footing = by_guid[guid["Ground slab"]], by_guid[guid["Pad footing"]]
    blocks, column = by_guid[guid["Block wall"]], by_guid[guid["Column"]]

    # the methods, where each came from, and the machine that did the work
    assert (slab["method"], slab["method_source"]) == ("cast_in_place", "ifc")
    assert (footing["method"], footing["method_source"]) == ("cast_in_place", "rule")
    # each poured by one of the two pumps: the boom pump, or the line pump while the boom pump is busy
    pumps = {"concrete_pump", "line_pump"}
    assert len(slab["resources"]) == 1 and set(slab["resources"]) <= pumps
    assert len(footing["resources"]) == 1 and set(footing["resources"]) <= pumps
    assert (blocks["method"], blocks["method_source"], blocks["resources"]) == (
        "laid",
        "user",
        ["block_layer"],
    )
    assert (column["method"], column["resources"]) == ("lifted", ["carrier"])
    panels = [c for c in report["components"] if c["parent_guid"] == guid["Concrete wall"]]
    assert len(panels) == 2 and guid["Concrete wall"] not in by_guid  # the wall is its panels
    manifest = {c.guid: c for c in read_manifest(build).components}
    for panel in panels:
        assert (panel["method"], panel["resources"]) == ("panelised", ["tower_crane"])
        assert manifest[panel["guid"]].mass_kg <= LIFT_KG
    (wall,) = report["panelised"]
    assert wall["guid"] == guid["Concrete wall"] and wall["constructed"]
    assert sorted(wall["panels"]) == sorted(p["guid"] for p in panels)
    assert wall["constructed_s"] == max(p["constructed_s"] for p in panels)
    assert len(wall["joints"]) == 1  # the vertical joint between the two panels

    # the pile was pitched and driven by the piling rig, for its pitch and its length at the rig's rate, and
    # the footing was not begun before the pile stood
    pile = by_guid[guid["Steel pile"]]
    assert (pile["method"], pile["method_source"], pile["resources"]) == ("driven", "rule", ["piling_rig"])
    piling = default_fleet().types["piling_rig"].piling
    assert piling is not None
    assert pile["constructed_s"] - pile["driving_s"] >= piling.drive_s(PILE_M) - 1.0
    assert _began_s(footing) >= pile["constructed_s"]

    # the anchor bolt is no component: it is cast into the footing, constructed when the footing is
    assert guid["Anchor bolt"] not in by_guid and footing["guests"] == [guid["Anchor bolt"]]
    assert column["guests"] == [guid["Base plate"]]  # the base plate goes with the column it is welded to
    guests = {g["guid"]: g for g in report["with_host"]}
    bolt = guests[guid["Anchor bolt"]]
    assert (bolt["host_guid"], bolt["relation"], bolt["constructed"]) == (
        guid["Pad footing"],
        "embedded",
        True,
    )
    assert bolt["constructed_s"] == footing["constructed_s"]
    assert guests[guid["Base plate"]]["host_guid"] == guid["Column"]

    # cast work took its formwork and pour; the wall was laid course by course in physics
    for cast in (slab, footing):
        work = manifest[cast["guid"]].cast
        assert work is not None
        assert cast["pouring_s"] - cast["forming_s"] >= work.formwork_s - 1.0
        assert cast["constructed_s"] - cast["pouring_s"] >= work.pour_s - 1.0
    assert blocks["laying_s"] < blocks["constructed_s"]
    assert (run.logs_dir / "physics.log").read_text().count(f"{guid['Block wall']} laid to") >= 2

    # the curing hold: what rests on a cast element is released, and worked on, only once it has cured
    holds = {slab["guid"]: {blocks["guid"], *(p["guid"] for p in panels)}, footing["guid"]: {column["guid"]}}
    for cast_guid, held in holds.items():
        cast = by_guid[cast_guid]
        work = manifest[cast_guid].cast
        assert work is not None
        curing = cast["curing"]
        assert curing["source"] == "planner" and set(curing["holds"]) == held, curing
        assert curing["until_s"] == pytest.approx(cast["constructed_s"] + work.cure_s, abs=1.0)
        for guid_held in held:
            assert by_guid[guid_held]["released_s"] >= curing["until_s"] - 1e-6
            assert _began_s(by_guid[guid_held]) >= curing["until_s"]

    # the order: what rests on what (the derived sequence), each component begun after its supports
    tasks = read_sequence(build / "sequence.xml").tasks
    guid_of = {task.task_id: task.guid for task in tasks}
    rests_on = {task.guid: {guid_of[p] for p in task.predecessors} for task in tasks}
    assert rests_on == {
        slab["guid"]: set(),
        pile["guid"]: set(),
        footing["guid"]: {pile["guid"]},
        column["guid"]: {footing["guid"]},
        blocks["guid"]: {slab["guid"]},
        **{p["guid"]: {slab["guid"]} for p in panels},
    }
    for component_guid, supports in rests_on.items():
        for support in supports:
            assert _began_s(by_guid[component_guid]) > by_guid[support]["constructed_s"]
