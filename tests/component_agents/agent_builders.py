"""Synthetic manifest components and bus messages for the agent tests (no conversion needed)."""

from __future__ import annotations

import itertools
import math

from bimbot.services.component_agents.agent import PLANNER_EVENTS
from bimbot.shared.identifiers import guid_to_folder, guid_to_key
from bimbot.shared.manifest import (
    BoundingBox,
    CollisionMethod,
    Component,
    ComponentFiles,
    Inertia,
    InertiaSource,
    Manifest,
    MassSource,
    Pose,
    SourceModel,
)
from bimbot.shared.messages import ClockMsg, ComponentEvent, ComponentEventMsg, ComponentPoseMsg, PoseMsg

SITE = "test-site"
# Valid 22-character GlobalIds, some with the `$` and `_` that need the key mapping.
GUIDS = (
    "1ctEyZqYDQ8hMH8nflPFbd",
    "2$E215S9vVeQ$YatrTq2Oc",
    "0T1QiaRO5HAfnu8L1NjF6H",
    "3_abcDEF0123456789_$xy",
)
_ids = itertools.count()


def quat_z(angle_rad: float) -> tuple[float, float, float, float]:
    """Unit quaternion (x, y, z, w) of a rotation about +Z."""
    return (0.0, 0.0, math.sin(angle_rad / 2), math.cos(angle_rad / 2))


def component(
    guid: str, position_m: tuple[float, float, float] = (1.0, 2.0, 3.0), yaw_rad: float = 0.3
) -> Component:
    folder = guid_to_folder(guid)
    model_dir = f"models/{folder}"
    return Component(
        guid=guid,
        key=guid_to_key(guid),
        folder=folder,
        ifc_class="IfcBeam",
        name=f"Beam {guid[:4]}",
        storey="Level 1",
        material="S275",
        target_pose_world=Pose(position_m=position_m, quat_xyzw=quat_z(yaw_rad), rpy_rad=(0.0, 0.0, yaw_rad)),
        bbox_world=BoundingBox(min_m=(0.0, 0.0, 0.0), max_m=(1.0, 0.1, 0.1)),
        bbox_local=BoundingBox(min_m=(0.0, 0.0, 0.0), max_m=(1.0, 0.1, 0.1)),
        volume_m3=0.01,
        watertight=True,
        mass_kg=78.5,
        mass_source=MassSource.MATERIAL_DENSITY_TABLE,
        com_local_m=(0.5, 0.05, 0.05),
        inertia_kg_m2=Inertia(ixx=0.1, ixy=0.0, ixz=0.0, iyy=6.6, iyz=0.0, izz=6.6),
        inertia_source=InertiaSource.MESH,
        collision_method=CollisionMethod.CONVEX_HULL,
        collision_parts=1,
        files=ComponentFiles(
            model_dir=model_dir,
            sdf_file=f"{model_dir}/model.sdf",
            config_file=f"{model_dir}/model.config",
            split_ifc=f"{model_dir}/{guid}.ifc",
            visual_dae=f"{model_dir}/meshes/visual.dae",
            visual_obj=f"{model_dir}/meshes/visual.obj",
            visual_glb=f"{model_dir}/meshes/visual.glb",
            collision=[f"{model_dir}/meshes/collision_0.obj"],
        ),
    )


def manifest(guids: tuple[str, ...] = GUIDS, site: str = SITE) -> Manifest:
    return Manifest(
        generator="tests",
        site=site,
        source=SourceModel(path="synthetic.ifc", schema_name="IFC4", sha256="0" * 64, length_unit_m=1.0),
        local_origin_m=(0.0, 0.0, 0.0),
        world_file=f"worlds/{site}.world",
        sequence_file="sequence.xml",
        sequence_source="derived",
        components=[component(guid, (float(i), 0.0, 0.0)) for i, guid in enumerate(guids)],
    )


def event(
    guid: str,
    name: ComponentEvent | str,
    *,
    sim_time_s: float = 1.0,
    event_id: str | None = None,
    robot_id: str | None = "robot-1",
) -> ComponentEventMsg:
    """An event as its sender sends it: the planner's (release, retry, fail, block) from the planner, the
    rest from ``robot_id`` (from the planner when None)."""
    event = ComponentEvent(name)
    planner = event in PLANNER_EVENTS or robot_id is None
    return ComponentEventMsg(
        guid=guid,
        event=event,
        source="planner" if planner else robot_id,
        event_id=event_id or f"ev-{next(_ids)}",
        robot_id=None if planner else robot_id,
        sim_time_s=sim_time_s,
        wall_time_s=0.0,
    )


def pose_of(
    target: Component,
    *,
    sim_time_s: float,
    offset_m: tuple[float, float, float] = (0.0, 0.0, 0.0),
    extra_yaw_rad: float = 0.0,
) -> ComponentPoseMsg:
    """``target`` at its BIM target pose, shifted by ``offset_m`` and turned by ``extra_yaw_rad``."""
    position = tuple(p + d for p, d in zip(target.target_pose_world.position_m, offset_m, strict=True))
    yaw = target.target_pose_world.rpy_rad[2] + extra_yaw_rad
    return ComponentPoseMsg(
        guid=target.guid, pose=PoseMsg(position_m=position, quat_xyzw=quat_z(yaw)), sim_time_s=sim_time_s
    )


def clock(sim_time_s: float) -> ClockMsg:
    return ClockMsg(sim_time_s=sim_time_s, step=int(sim_time_s * 100), real_time_factor=1.0)
