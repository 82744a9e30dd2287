"""Tiny synthetic builds for planner tests: a portal frame on two footings plus an independent post.

Layout (world frame, metres)::

    foot_a (0, 0) ─ col_a ─┐
                           beam (2, 0, 3)     post_c on foot_c at (10, 0), independent of the portal
    foot_b (4, 0) ─ col_b ─┘
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Iterable

from bimbot.services.planner.capability import SiteRobot
from bimbot.services.planner.scheduler import PlannerCore
from bimbot.services.planner.sources import plan_from_sequence
from bimbot.shared.construction_methods import CastWork, ConstructionMethod
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
from bimbot.shared.messages import (
    ComponentState,
    ComponentStateMsg,
    PoseMsg,
    RobotState,
    RobotStateMsg,
    SiteInfoMsg,
    TwinMsg,
)
from bimbot.shared.reasons import Reason
from bimbot.shared.robot_description import DEFAULT_ROBOT, Capability, LayingSpec, RobotDescription
from bimbot.shared.site_layout import plan_site
from bimbot.shared.support_graph import derive_sequence

PORTAL = ("foot_a", "foot_b", "foot_c", "col_a", "col_b", "post_c", "beam")


def component(guid: str, ifc_class: str, low: tuple, high: tuple) -> Component:
    centre = tuple((a + b) / 2 for a, b in zip(low, high, strict=True))
    files = ComponentFiles(
        model_dir="m",
        sdf_file="m/model.sdf",
        config_file="m/model.config",
        split_ifc="m/x.ifc",
        visual_dae="a",
        visual_obj="b",
        visual_glb="c",
        collision=[],
    )
    return Component(
        guid=guid,
        key=guid,
        folder=guid,
        ifc_class=ifc_class,
        target_pose_world=Pose(position_m=centre, quat_xyzw=(0, 0, 0, 1), rpy_rad=(0, 0, 0)),
        bbox_world=BoundingBox(min_m=low, max_m=high),
        bbox_local=BoundingBox(min_m=low, max_m=high),
        volume_m3=1.0,
        watertight=True,
        mass_kg=1.0,
        mass_source=MassSource.DEFAULT_DENSITY,
        com_local_m=(0, 0, 0),
        inertia_kg_m2=Inertia(ixx=1, ixy=0, ixz=0, iyy=1, iyz=0, izz=1),
        inertia_source=InertiaSource.MESH,
        collision_method=CollisionMethod.CONVEX_HULL,
        collision_parts=1,
        files=files,
    )


def portal_manifest() -> Manifest:
    components = [
        component("foot_a", "IfcFooting", (-0.3, -0.3, -0.3), (0.3, 0.3, 0.0)),
        component("foot_b", "IfcFooting", (3.7, -0.3, -0.3), (4.3, 0.3, 0.0)),
        component("foot_c", "IfcFooting", (9.7, -0.3, -0.3), (10.3, 0.3, 0.0)),
        component("col_a", "IfcColumn", (-0.05, -0.05, 0.0), (0.05, 0.05, 3.0)),
        component("col_b", "IfcColumn", (3.95, -0.05, 0.0), (4.05, 0.05, 3.0)),
        component("post_c", "IfcColumn", (9.95, -0.05, 0.0), (10.05, 0.05, 3.0)),
        component("beam", "IfcBeam", (0.0, -0.05, 3.0), (4.0, 0.05, 3.2)),
    ]
    return Manifest(
        generator="test",
        site="test-site",
        source=SourceModel(path="portal.ifc", schema_name="IFC4", sha256="0" * 64, length_unit_m=1.0),
        local_origin_m=(0, 0, 0),
        world_file="worlds/test-site.world",
        sequence_file="sequence.xml",
        sequence_source="derived",
        components=components,
    )


def state_msg(
    guid: str,
    state: ComponentState,
    *,
    event: str = "test",
    robot_id: str | None = None,
    attempt: int = 0,
    sim_time_s: float = 0.0,
    wall_time_s: float = 0.0,
    reason: Reason | None = None,
    previous: ComponentState | None = None,
) -> ComponentStateMsg:
    return ComponentStateMsg(
        guid=guid,
        state=state,
        previous=previous,
        event=event,
        attempt=attempt,
        robot_id=robot_id,
        sim_time_s=sim_time_s,
        wall_time_s=wall_time_s,
        reason=reason,
    )


def robot_msg(
    robot_id: str,
    xy: tuple[float, float],
    state: RobotState = RobotState.IDLE,
    task_id: str | None = None,
    sim_time_s: float = 0.0,
) -> RobotStateMsg:
    return RobotStateMsg(
        robot_id=robot_id,
        state=state,
        task_id=task_id,
        pose_xy_yaw=(xy[0], xy[1], 0.0),
        sim_time_s=sim_time_s,
        wall_time_s=0.0,
    )


def twin_msg(
    guid: str,
    state: ComponentState,
    *,
    placed_at_s: float | None = None,
    history: list[ComponentStateMsg] | None = None,
) -> TwinMsg:
    """The twin a component agent of the portal answers: its ``state`` and, with ``placed_at_s``, its
    current pose at its target seen at that sim time; ``history`` its transitions (default none)."""
    item = portal_manifest().component(guid)
    pose = item.target_pose_world
    target = PoseMsg(position_m=pose.position_m, quat_xyzw=pose.quat_xyzw)
    return TwinMsg(
        guid=guid,
        key=guid,
        ifc_class=item.ifc_class,
        name=None,
        storey=None,
        material=None,
        mass_kg=1.0,
        target_pose=target,
        current_pose=None if placed_at_s is None else target,
        current_pose_sim_time_s=placed_at_s,
        state=state,
        attempt=1,
        robot_id=None,
        history=history or [],
    )


# --- work in place: a boom pump and a block layer that stand fixed, and the portal with cast/laid parts ----

PUMP = RobotDescription(
    name="concrete_pump",
    urdf="pump.urdf",
    payload_kg=1.0,
    reach_m=32.0,
    max_place_height_m=28.0,
    length_m=2.5,
    width_m=2.5,
    max_speed_mps=0.0,
    max_turn_radps=0.0,
    handling_s=600.0,
    capabilities=frozenset({Capability.STAND_FIXED, Capability.POUR}),
)
LAYER = RobotDescription(
    name="block_layer",
    urdf="layer.urdf",
    payload_kg=1.0,
    reach_m=15.0,
    max_place_height_m=6.0,
    length_m=2.0,
    width_m=2.0,
    max_speed_mps=0.0,
    max_turn_radps=0.0,
    handling_s=300.0,
    capabilities=frozenset({Capability.STAND_FIXED, Capability.LAY}),
    laying=LayingSpec(
        block_length_m=0.5, block_height_m=0.25, block_width_m=0.2, block_mass_kg=20.0, blocks_per_h=100.0
    ),
)
FOOTING_CAST = CastWork(
    formwork_area_m2=1.2, volume_m3=0.108, formwork_s=3600.0, pour_s=1800.0, cure_s=86400.0
)


def with_methods(manifest: Manifest, **methods: ConstructionMethod) -> Manifest:
    """``manifest`` with the named components built by other methods (a cast one gets FOOTING_CAST)."""
    components = []
    for item in manifest.components:
        method = methods.get(item.guid, item.method)
        cast = FOOTING_CAST if method is ConstructionMethod.CAST_IN_PLACE else None
        components.append(item.model_copy(update={"method": method, "cast": cast}))
    return manifest.model_copy(update={"components": components})


def one_robot_site_info(manifest: Manifest) -> SiteInfoMsg:
    """The site info physics would serve for ``manifest`` with one default robot (lock-step)."""
    layout = plan_site(manifest.components, robots=1)
    return SiteInfoMsg(
        robot_ids=["r1"],
        robot_starts_xy_yaw=list(layout.robot_starts),
        layout=layout,
        robot_type_of={"r1": DEFAULT_ROBOT.name},
        robot_types={DEFAULT_ROBOT.name: DEFAULT_ROBOT},
        step_s=1 / 120,
        control_period_s=0.2,
        lock_step=True,
    )


def idle_core(manifest: Manifest, robots: list[SiteRobot], from_above: Iterable[str] = ()) -> PlannerCore:
    """A planner core on the derived plan of ``manifest`` with ``robots`` alive and idle at their homes
    (``from_above``: what the plan's access check gave a crane first)."""
    plan = plan_from_sequence(derive_sequence(manifest.components), manifest.components, "test")
    plan = dataclasses.replace(plan, from_above=frozenset(from_above))
    counter = itertools.count(1)
    core = PlannerCore(manifest, plan, new_id=lambda: f"ev{next(counter)}", robots=robots, slots={})
    for robot in robots:
        core.robot_liveliness(robot.robot_id, True)
        core.observe_robot_state(robot_msg(robot.robot_id, robot.home_xy_yaw[:2]))
    return core
