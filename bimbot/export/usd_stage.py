"""The run as a USD stage (``usd-core``): the site, each component and each robot as prims, their poses as
time samples over the run; metres and Z up declared, so Omniverse, Isaac Sim and ``usdview`` place it right.

Layout::

    /World                      default prim (Xform)
      /Site/Ground              a ground quad under the components' footprint, with a margin
      /Components/C0001_<guid>  Xform: translate + orient samples; child Mesh from the converter's visual OBJ
      /Robots/<id>              Xform: translate + orient samples; child Cube (the robot's place holder)

Time codes are sim tenths of a second (``timeCodesPerSecond`` 10: played back at the run's pace). A
component's ``bimbot:guid``, method and final state are custom attributes; a component shown only from its
placing (poses from the journal) is invisible before it.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
from pxr import Gf, Sdf, Usd, UsdGeom, Vt

from bimbot.export.meshes import load_triangles
from bimbot.export.poses import PoseSample, RunPoses
from bimbot.export.sim_schedule import SimSchedule
from bimbot.shared.manifest import Component, Manifest

_log = logging.getLogger(__name__)

TIME_CODES_PER_S = 10.0
GROUND_MARGIN_M = 10.0
ROBOT_BOX_M = (1.0, 0.7, 0.5)


def write_usd(
    manifest: Manifest, build_dir: Path, schedule: SimSchedule, poses: RunPoses, out: Path
) -> Usd.Stage:
    """Write the stage to ``out`` (``.usda`` text or ``.usdc`` binary, by its suffix) and return it."""
    out.parent.mkdir(parents=True, exist_ok=True)
    stage = Usd.Stage.CreateNew(str(out))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, UsdGeom.LinearUnits.meters)
    stage.SetTimeCodesPerSecond(TIME_CODES_PER_S)
    stage.SetFramesPerSecond(TIME_CODES_PER_S)
    stage.SetStartTimeCode(0.0)
    stage.SetEndTimeCode(_code(schedule.end_s))
    animated: list[tuple[UsdGeom.Xform, list[PoseSample]]] = []
    _fill(stage, manifest, build_dir=build_dir, schedule=schedule, poses=poses, animated=animated)
    layer = stage.GetRootLayer()
    with Sdf.ChangeBlock():  # samples straight into the layer, one change notice (not one per sample)
        for xform, samples in animated:
            _samples(layer, xform, samples)
    layer.Save()
    return stage


def _fill(
    stage: Usd.Stage,
    manifest: Manifest,
    *,
    build_dir: Path,
    schedule: SimSchedule,
    poses: RunPoses,
    animated: list[tuple[UsdGeom.Xform, list[PoseSample]]],
) -> None:
    """Define the prims; the xforms with several pose samples go to ``animated`` (set afterwards)."""
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())
    world.GetPrim().SetCustomDataByKey("bimbot:poses", poses.source)
    _ground(stage, manifest)
    UsdGeom.Scope.Define(stage, "/World/Components")
    works = {work.guid: work for work in schedule.components}
    for index, component in enumerate(manifest.components, start=1):
        path = f"/World/Components/{_identifier(f'C{index:04d}_{component.guid}')}"
        xform = UsdGeom.Xform.Define(stage, path)
        prim = xform.GetPrim()
        prim.CreateAttribute("bimbot:guid", Sdf.ValueTypeNames.String).Set(component.guid)
        prim.CreateAttribute("bimbot:method", Sdf.ValueTypeNames.String).Set(component.method.value)
        work = works.get(component.guid)
        prim.CreateAttribute("bimbot:state", Sdf.ValueTypeNames.String).Set(work.state if work else "planned")
        _animate(xform, poses.components.get(component.guid) or [_static(component)], animated)
        if component.guid in poses.appears_s:
            visibility = xform.CreateVisibilityAttr()
            visibility.Set(UsdGeom.Tokens.invisible, 0.0)
            visibility.Set(UsdGeom.Tokens.inherited, _code(poses.appears_s[component.guid]))
        _mesh(stage, f"{path}/Body", build_dir, component)
    UsdGeom.Scope.Define(stage, "/World/Robots")
    for robot_id, robot_type in schedule.robot_types.items():
        xform = UsdGeom.Xform.Define(stage, f"/World/Robots/{_identifier(robot_id)}")
        xform.GetPrim().CreateAttribute("bimbot:type", Sdf.ValueTypeNames.String).Set(robot_type)
        origin = PoseSample(0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
        _animate(xform, poses.robots.get(robot_id) or [origin], animated)
        box = UsdGeom.Cube.Define(stage, f"/World/Robots/{_identifier(robot_id)}/Body")
        box.CreateSizeAttr(1.0)
        box.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.0, ROBOT_BOX_M[2] / 2))
        box.AddScaleOp().Set(Gf.Vec3f(*ROBOT_BOX_M))


def _code(time_s: float) -> float:
    return round(time_s * TIME_CODES_PER_S, 3)


def _identifier(text: str) -> str:
    from pxr import Tf

    return str(Tf.MakeValidIdentifier(text))


def _static(component: Component) -> PoseSample:
    pose = component.target_pose_world
    return PoseSample(0.0, pose.position_m, pose.quat_xyzw)


def _animate(
    xform: UsdGeom.Xform, samples: list[PoseSample], animated: list[tuple[UsdGeom.Xform, list[PoseSample]]]
) -> None:
    """translate + orient ops: a single pose as their value, several kept for :func:`_samples`."""
    translate = xform.AddTranslateOp(UsdGeom.XformOp.PrecisionDouble)
    orient = xform.AddOrientOp(UsdGeom.XformOp.PrecisionDouble)
    if len(samples) == 1:
        translate.Set(Gf.Vec3d(*samples[0].position_m))
        orient.Set(_quat(samples[0]))
    else:
        animated.append((xform, samples))


def _samples(layer: Sdf.Layer, xform: UsdGeom.Xform, samples: list[PoseSample]) -> None:
    path = xform.GetPath()
    translate = path.AppendProperty("xformOp:translate")
    orient = path.AppendProperty("xformOp:orient")
    for sample in samples:
        layer.SetTimeSample(translate, _code(sample.time_s), Gf.Vec3d(*sample.position_m))
        layer.SetTimeSample(orient, _code(sample.time_s), _quat(sample))


def _quat(sample: PoseSample) -> Gf.Quatd:
    x, y, z, w = sample.quat_xyzw
    return Gf.Quatd(w, Gf.Vec3d(x, y, z))


def _mesh(stage: Usd.Stage, path: str, build_dir: Path, component: Component) -> None:
    """The converter's visual mesh (component frame, metres) as a UsdGeom.Mesh, when it is there."""
    mesh = load_triangles(build_dir / component.files.visual_obj) if component.files.visual_obj else None
    if mesh is None:
        return
    usd_mesh = UsdGeom.Mesh.Define(stage, path)
    usd_mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.asarray(mesh.vertices, dtype=np.float32)))
    usd_mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(mesh.faces), 3, dtype=np.int32)))
    usd_mesh.CreateFaceVertexIndicesAttr(
        Vt.IntArray.FromNumpy(np.asarray(mesh.faces, dtype=np.int32).ravel())
    )
    usd_mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
    usd_mesh.CreateExtentAttr(Vt.Vec3fArray.FromNumpy(np.asarray(mesh.bounds, dtype=np.float32)))


def _ground(stage: Usd.Stage, manifest: Manifest) -> None:
    """A ground quad at z 0 under every component's BIM box, with a margin for the yard and the robots."""
    UsdGeom.Xform.Define(stage, "/World/Site")
    boxes = [component.bbox_world for component in manifest.components]
    low = (
        np.min([box.min_m for box in boxes], axis=0) - GROUND_MARGIN_M
        if boxes
        else np.full(3, -GROUND_MARGIN_M)
    )
    high = (
        np.max([box.max_m for box in boxes], axis=0) + GROUND_MARGIN_M
        if boxes
        else np.full(3, GROUND_MARGIN_M)
    )
    ground = UsdGeom.Mesh.Define(stage, "/World/Site/Ground")
    corners = [(low[0], low[1]), (high[0], low[1]), (high[0], high[1]), (low[0], high[1])]
    ground.CreatePointsAttr([Gf.Vec3f(float(x), float(y), 0.0) for x, y in corners])
    ground.CreateFaceVertexCountsAttr([4])
    ground.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    ground.CreateExtentAttr(
        [Gf.Vec3f(float(low[0]), float(low[1]), 0.0), Gf.Vec3f(float(high[0]), float(high[1]), 0.0)]
    )
    ground.CreateDisplayColorAttr([Gf.Vec3f(0.45, 0.42, 0.36)])
