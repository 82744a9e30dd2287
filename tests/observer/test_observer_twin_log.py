"""What the observer draws: colours by state, entity paths, transforms from poses, meshes once, throttling."""

from __future__ import annotations

import itertools
import math

import pytest
import rerun as rr
from pydantic import BaseModel

from bimbot.services.observer.app import route_key
from bimbot.services.observer.twin_log import (
    ROBOT_COLORS,
    STATE_COLORS,
    LogItem,
    TwinLog,
    TwinLogOptions,
    component_path,
    robot_path,
)
from bimbot.shared.manifest import Component, Manifest
from bimbot.shared.messages import (
    ComponentPoseMsg,
    ComponentState,
    ComponentStateMsg,
    PlanMsg,
    PoseMsg,
    ProgressMsg,
    RobotPoseMsg,
    RobotState,
    RobotStateMsg,
    ScanMsg,
    SensorsMsg,
    TaskMsg,
)
from bimbot.shared.site_layout import plan_site

MIN_COLOR_DISTANCE = 60.0  # RGB euclidean distance two states must keep to be told apart at a glance


def values(batch: object) -> list:
    return batch.pa_array.to_pylist()  # type: ignore[attr-defined]


def rgba(packed: int) -> tuple[int, int, int, int]:
    return tuple((packed >> shift) & 0xFF for shift in (24, 16, 8, 0))  # type: ignore[return-value]


@pytest.fixture
def twin(frame_manifest: Manifest) -> TwinLog:
    return TwinLog(frame_manifest)


def _by_path(items: list[LogItem], path: str) -> list[LogItem]:
    return [item for item in items if item.entity_path == path]


@pytest.mark.parametrize("table", [STATE_COLORS, ROBOT_COLORS], ids=["components", "robots"])
def test_every_state_has_a_colour_clearly_different_from_every_other(table: dict) -> None:
    enum = type(next(iter(table)))
    assert set(table) == set(enum)
    for (state_a, color_a), (state_b, color_b) in itertools.combinations(table.items(), 2):
        distance = math.dist(color_a[:3], color_b[:3])
        assert distance >= MIN_COLOR_DISTANCE, f"{state_a} and {state_b} look alike ({distance:.0f})"


def test_carried_constructed_and_failed_are_told_apart_from_planned() -> None:
    planned = STATE_COLORS[ComponentState.PLANNED]
    for state in (ComponentState.TRANSPORTING, ComponentState.CONSTRUCTED, ComponentState.MISPLACED):
        assert math.dist(planned[:3], STATE_COLORS[state][:3]) > 100


def test_entity_paths_keep_the_guid_and_escape_the_dollar() -> None:
    assert component_path("0r1e7X$s5TPPvCu2xOwAkz") == "world/components/0r1e7X\\$s5TPPvCu2xOwAkz"
    assert component_path("1OOkmzJBrRNgkdtkXwtYx_") == "world/components/1OOkmzJBrRNgkdtkXwtYx_"
    assert robot_path("r1") == "world/robots/r1"


def test_the_scene_logs_every_mesh_once_static_and_puts_components_in_the_yard_at_time_zero(
    twin: TwinLog, frame_manifest: Manifest
) -> None:
    loaded: list[str] = []

    def load(component: Component) -> tuple[bytes, str]:
        loaded.append(component.guid)
        return b"glb-bytes", "model/gltf-binary"

    meshes, initial = twin.scene(load)
    guids = [c.guid for c in frame_manifest.components]
    assert loaded == guids
    assert [item.entity_path for item in meshes] == [component_path(g) for g in guids]
    assert all(item.static and isinstance(item.archetype, rr.Asset3D) for item in meshes)
    assert all(bytes(values(item.archetype.blob)[0]) == b"glb-bytes" for item in meshes)
    assert not any(item.static for item in initial)
    for guid in guids:
        (color,) = [i for i in _by_path(initial, component_path(guid)) if isinstance(i.archetype, rr.Asset3D)]
        assert rgba(values(color.archetype.albedo_factor)[0]) == STATE_COLORS[ComponentState.PLANNED]
    # the yard poses come from the site physics planned (its site info), for sim time 0
    layout = plan_site(frame_manifest.components, robots=3)
    poses = twin.yard_poses(layout)
    assert not any(item.static for item in poses)  # a static pose would hide every later one
    for guid in guids:
        (transform,) = _by_path(poses, component_path(guid))
        assert values(transform.archetype.translation) == [pytest.approx(list(layout.slots[guid].position_m))]


def test_components_in_place_are_drawn_at_their_target_from_the_start_as_built(
    frame_manifest: Manifest,
) -> None:
    """``convert --in-place``: the footings stand where the model puts them for the whole recording."""
    footings = [c for c in frame_manifest.components if c.ifc_class == "IfcFooting"]
    rest = [c for c in frame_manifest.components if c.ifc_class != "IfcFooting"]
    twin = TwinLog(frame_manifest.model_copy(update={"components": rest, "in_place": footings}))
    meshes, initial = twin.scene(lambda component: (b"glb-bytes", "model/gltf-binary"))
    for footing in footings:
        drawn = _by_path(meshes, component_path(footing.guid))
        assert drawn and all(item.static for item in drawn)
        (transform,) = [item for item in drawn if isinstance(item.archetype, rr.Transform3D)]
        target = footing.target_pose_world.position_m
        assert values(transform.archetype.translation) == [pytest.approx(list(target))]
        colours = [
            item for item in drawn if isinstance(item.archetype, rr.Asset3D) and item.archetype.albedo_factor
        ]
        assert rgba(values(colours[0].archetype.albedo_factor)[0]) == STATE_COLORS[ComponentState.CONSTRUCTED]
        assert not _by_path(initial, component_path(footing.guid))  # no state of its own to follow


def test_a_pose_becomes_the_components_transform(twin: TwinLog, frame_manifest: Manifest) -> None:
    guid = frame_manifest.components[3].guid
    pose = PoseMsg(position_m=(1.0, 2.0, 3.0), quat_xyzw=(0.0, 0.0, 0.7071068, 0.7071068))
    (item,) = twin.component_pose(ComponentPoseMsg(guid=guid, pose=pose, sim_time_s=5.0, fixed=True))
    assert item.entity_path == component_path(guid) and not item.static
    assert values(item.archetype.translation) == [pytest.approx([1.0, 2.0, 3.0])]
    assert values(item.archetype.quaternion) == [pytest.approx([0.0, 0.0, 0.7071068, 0.7071068])]
    again = ComponentPoseMsg(guid=guid, pose=pose, sim_time_s=6.0, fixed=True)
    assert twin.component_pose(again) == []  # no change, no log


def test_carried_poses_are_throttled_and_the_held_back_one_is_flushed(
    twin: TwinLog, frame_manifest: Manifest
) -> None:
    guid = frame_manifest.components[0].guid
    logged = []
    for step in range(5):  # 0.02 s apart: within the 0.1 s interval after the first
        pose = PoseMsg(position_m=(float(step), 0.0, 0.5), quat_xyzw=(0.0, 0.0, 0.0, 1.0))
        logged += twin.component_pose(
            ComponentPoseMsg(guid=guid, pose=pose, sim_time_s=1.0 + 0.02 * step, attached_to="r1")
        )
    assert len(logged) == 1
    ((at_s, last),) = twin.flush()
    assert at_s == pytest.approx(1.08)
    assert values(last.archetype.translation) == [pytest.approx([4.0, 0.0, 0.5])]
    assert twin.flush() == []


def test_a_state_change_recolours_the_mesh_only_and_writes_the_log(
    twin: TwinLog, frame_manifest: Manifest
) -> None:
    component = frame_manifest.components[0]
    message = ComponentStateMsg(
        guid=component.guid,
        state=ComponentState.MISPLACED,
        previous=ComponentState.VERIFYING,
        event="verified",
        attempt=1,
        robot_id="r1",
        sim_time_s=12.0,
        wall_time_s=0.0,
        position_error_m=0.05,
    )
    color, text = twin.component_state(message)
    assert color.entity_path == component_path(component.guid)
    assert color.archetype.blob is None  # a partial update: the static mesh stays
    assert rgba(values(color.archetype.albedo_factor)[0]) == STATE_COLORS[ComponentState.MISPLACED]
    assert text.entity_path == "log/components"
    assert values(text.archetype.level) == ["WARN"]
    line = values(text.archetype.text)[0]
    assert component.guid in line and "verifying → misplaced" in line and "50.0 mm" in line


def test_robot_states_are_logged_on_change_and_place_the_robot_without_ground_truth(twin: TwinLog) -> None:
    def state(s: RobotState, t: float) -> RobotStateMsg:
        return RobotStateMsg(
            robot_id="r1", state=s, pose_xy_yaw=(2.0, 3.0, math.pi / 2), sim_time_s=t, wall_time_s=0.0
        )

    first = twin.robot_state(state(RobotState.IDLE, 0.0))
    (transform,) = _by_path(first, "world/robots/r1")
    assert values(transform.archetype.translation) == [pytest.approx([2.0, 3.0, 0.0])]
    assert values(transform.archetype.quaternion) == [
        pytest.approx([0.0, 0.0, math.sqrt(0.5), math.sqrt(0.5)])
    ]
    assert _by_path(first, "world/robots/r1/body") and _by_path(first, "log/robots")
    assert twin.robot_state(state(RobotState.IDLE, 0.5)) == []  # same state, same pose
    twin.robot_pose(RobotPoseMsg(robot_id="r1", pose_xy_yaw=(5.0, 3.0, 0.0), sim_time_s=1.0))
    busy = twin.robot_state(state(RobotState.PICK_UP, 2.0))
    assert not _by_path(busy, "world/robots/r1")  # ground truth is seen: the state's pose is not used


def test_every_nth_scan_is_drawn_in_the_robot_frame(frame_manifest: Manifest) -> None:
    twin = TwinLog(frame_manifest, TwinLogOptions(scan_every=3))
    scan = ScanMsg(
        robot_id="r1",
        angle_min_rad=0.0,
        angle_increment_rad=math.pi / 2,
        range_max_m=10.0,
        ranges_m=[1.0, 2.0, float("inf"), 10.0],
        sim_time_s=0.0,
    )
    assert [twin.scan_wanted("r1") for _ in range(7)] == [True, False, False, True, False, False, True]
    assert twin.scan_wanted("r2")  # counted per robot
    (points,) = twin.scan(scan)
    assert points.entity_path == "world/robots/r1/scan"
    assert values(points.archetype.positions) == [
        pytest.approx([1.0, 0.0, 0.3], abs=1e-6),
        pytest.approx([0.0, 2.0, 0.3], abs=1e-6),
    ]


def test_trails_grow_in_segments_that_join(frame_manifest: Manifest) -> None:
    options = TwinLogOptions(trail_step_m=1.0, trail_segment_points=3, pose_min_interval_s=0.0)
    twin = TwinLog(frame_manifest, options)
    items = []
    for step in range(6):
        items += twin.robot_pose(
            RobotPoseMsg(robot_id="r1", pose_xy_yaw=(float(step), 0.0, 0.0), sim_time_s=step)
        )
    segments = {
        item.entity_path: values(item.archetype.strips)[0] for item in items if "trails" in item.entity_path
    }
    assert sorted(segments) == ["world/trails/r1/0000", "world/trails/r1/0001", "world/trails/r1/0002"]
    assert [p[0] for p in segments["world/trails/r1/0000"]] == [0.0, 1.0, 2.0]
    assert [p[0] for p in segments["world/trails/r1/0001"]] == [2.0, 3.0, 4.0]  # starts where 0000 ends
    assert [p[0] for p in segments["world/trails/r1/0002"]] == [4.0, 5.0]


def test_plans_tasks_and_progress_are_drawn_and_repeats_skipped(twin: TwinLog) -> None:
    plan = PlanMsg(robot_id="r1", path_xy_m=[(0.0, 0.0), (1.0, 1.0)], goal_xy_m=(1.0, 1.0), sim_time_s=0.0)
    assert {item.entity_path for item in twin.plan(plan)} == {"world/plans/r1", "world/plans/r1/goal"}
    assert twin.plan(plan) == []
    progress = ProgressMsg(
        total=2,
        counts={"planned": 1, "constructed": 1},
        percent_constructed=50.0,
        sim_time_s=1.0,
        estimated_finish_sim_time_s=None,
    )
    items = twin.progress(progress)
    assert values(_by_path(items, "progress/percent_constructed")[0].archetype.scalars) == [50.0]
    assert values(_by_path(items, "progress/components/constructed")[0].archetype.scalars) == [1.0]
    assert twin.progress(progress.model_copy(update={"sim_time_s": 2.0})) == []  # unchanged counts


def test_the_synthetic_run_never_sends_a_mesh_again(
    twin: TwinLog, run_messages: list[tuple[str, BaseModel]]
) -> None:
    items = [item for _, message in run_messages for item in twin.items(message)]
    assert items
    assert not any(
        isinstance(item.archetype, rr.Asset3D) and item.archetype.blob is not None for item in items
    )
    assert not any(item.static for item in items)


@pytest.mark.parametrize(
    ("key_expr", "model"),
    [
        ("bimbot/s/components/1ctEyZqYDQ8hMH8nflPFbd/state", ComponentStateMsg),
        ("bimbot/s/components/0r1e7X-s5TPPvCu2xOwAkz/pose", ComponentPoseMsg),
        ("bimbot/s/tasks/T0001", TaskMsg),
        ("bimbot/s/robots/r1/sensors", SensorsMsg),
        ("bimbot/s/robots/r1/odom", None),  # travels in sensors
        ("bimbot/s/progress", ProgressMsg),
        ("bimbot/s/robots/r1/cmd_vel", None),
        ("bimbot/s/components/x/event", None),
        ("bimbot/other/progress", None),
    ],
)
def test_keys_are_routed_to_their_message_model(key_expr: str, model: type | None) -> None:
    assert route_key("s", key_expr) is model
