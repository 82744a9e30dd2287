"""The USD stage: metres and Z up, the site, components and robots as prims, poses as time samples."""

from __future__ import annotations

from pathlib import Path

import pytest
import rerun as rr
from pxr import Usd, UsdGeom, UsdValidation

from bimbot.export.poses import run_poses
from bimbot.export.run_data import RunData, load_run
from bimbot.export.usd_stage import TIME_CODES_PER_S, write_usd
from bimbot.services.observer.twin_items import TIMELINE, component_path, robot_path, transform


@pytest.fixture(scope="module")
def run_data(frame_run: Path) -> RunData:
    return load_run(frame_run)


def _component_prims(stage: Usd.Stage) -> dict[str, Usd.Prim]:
    return {
        prim.GetAttribute("bimbot:guid").Get(): prim
        for prim in stage.Traverse()
        if prim.HasAttribute("bimbot:guid")
    }


def test_from_the_journal_each_placed_component_appears_at_its_target(
    run_data: RunData, tmp_path: Path
) -> None:
    schedule = run_data.schedule()
    poses = run_poses(run_data.manifest, schedule, None)  # no recording in this run
    out = tmp_path / "frame.usda"
    write_usd(run_data.manifest, run_data.build_dir, schedule, poses, out)
    stage = Usd.Stage.Open(str(out))
    assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.z and UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    assert stage.GetDefaultPrim().GetPath() == "/World" and stage.GetPrimAtPath("/World/Site/Ground")
    prims = _component_prims(stage)
    assert set(prims) == {component.guid for component in run_data.manifest.components}
    first = schedule.components[0]
    prim = prims[first.guid]
    visibility = UsdGeom.Imageable(prim).GetVisibilityAttr()
    assert visibility.Get(0.0) == UsdGeom.Tokens.invisible
    assert visibility.Get(8.0 * TIME_CODES_PER_S) == UsdGeom.Tokens.inherited  # placed at 8 s
    target = run_data.manifest.component(first.guid).target_pose_world.position_m
    assert tuple(prim.GetAttribute("xformOp:translate").Get()) == pytest.approx(target)
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath(prim.GetPath().AppendChild("Body")))
    assert len(mesh.GetFaceVertexCountsAttr().Get()) > 0
    assert {p.GetName() for p in stage.GetPrimAtPath("/World/Robots").GetChildren()} == {"r1", "r2"}
    registry = UsdValidation.ValidationRegistry()  # USD's own validators, every one loaded
    errors = UsdValidation.ValidationContext(registry.GetOrLoadAllValidators()).Validate(stage)
    assert [error.GetMessage() for error in errors] == []


def test_from_the_recording_components_and_robots_move_over_the_run(
    run_data: RunData, tmp_path: Path
) -> None:
    schedule = run_data.schedule()
    guid = next(work.guid for work in schedule.components if "$" in work.guid)  # escaped in entity paths
    rrd = tmp_path / "site.rrd"
    recording = rr.RecordingStream("bimbot-test")
    recording.save(rrd)
    for time_s, x in ((0.0, -5.0), (3.0, -2.0), (8.0, 0.0)):  # yard, carried, placed
        recording.set_time(TIMELINE, duration=time_s)
        recording.log(component_path(guid), transform((x, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)))
        recording.log(robot_path("r1"), transform((x - 1.0, 0.5, 0.0), (0.0, 0.0, 0.0, 1.0)))
    recording.flush()
    recording.disconnect()
    poses = run_poses(run_data.manifest, schedule, rrd)
    assert [sample.time_s for sample in poses.components[guid]] == [0.0, 3.0, 8.0]
    out = tmp_path / "frame.usdc"
    write_usd(run_data.manifest, run_data.build_dir, schedule, poses, out)
    stage = Usd.Stage.Open(str(out))
    translate = _component_prims(stage)[guid].GetAttribute("xformOp:translate")
    assert translate.GetTimeSamples() == [0.0, 3.0 * TIME_CODES_PER_S, 8.0 * TIME_CODES_PER_S]
    assert translate.Get(3.0 * TIME_CODES_PER_S)[0] == pytest.approx(-2.0)
    robot = stage.GetPrimAtPath("/World/Robots/r1").GetAttribute("xformOp:translate")
    assert robot.GetNumTimeSamples() == 3 and robot.Get(8.0 * TIME_CODES_PER_S)[0] == pytest.approx(-1.0)
