"""Work in place in the live twin (see method_run): a cast or laid component is never drawn in the yard
nor at the origin, appears at its target with its first pose, shows its formwork, pour and courses
while worked on; every component carries its method, and the log says the method and the machine."""

from __future__ import annotations

import pytest
import rerun as rr
from method_run import method_manifest
from observer_site_info import site_info

from bimbot.services.observer.twin_log import TwinLog, component_path, robot_path
from bimbot.services.observer.work_log import courses_laid, work_path
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import (
    ComponentPoseMsg,
    ComponentState,
    ComponentStateMsg,
    PoseMsg,
    RobotState,
    RobotStateMsg,
)
from bimbot.shared.robot_description import Capability, LayingSpec, RobotDescription
from bimbot.shared.site_layout import plan_site

S = ComponentState
MACHINE = {"urdf": "carrier.urdf", "payload_kg": 1.0, "reach_m": 40.0, "max_place_height_m": 30.0}
MACHINE |= {"length_m": 1.4, "width_m": 0.9, "max_speed_mps": 0.0, "max_turn_radps": 0.0}
PUMP = RobotDescription(name="pump", capabilities={Capability.STAND_FIXED, Capability.POUR}, **MACHINE)
LAYING = LayingSpec(
    block_length_m=0.4, block_height_m=0.2, block_width_m=0.2, block_mass_kg=10.0, blocks_per_h=60.0
)
LAYER = RobotDescription(
    name="block_layer", capabilities={Capability.STAND_FIXED, Capability.LAY}, laying=LAYING, **MACHINE
)


def values(batch: object) -> list:
    return batch.pa_array.to_pylist()  # type: ignore[attr-defined]


def any_value(item: rr.AnyValues, name: str) -> object:
    (batch,) = [b for b in item.as_component_batches() if b.component_descriptor().component == name]
    return batch.as_arrow_array().to_pylist()[0]


@pytest.fixture
def manifest(frame_manifest: Manifest) -> Manifest:
    return method_manifest(frame_manifest)


@pytest.fixture
def twin(manifest: Manifest) -> TwinLog:
    twin = TwinLog(manifest)
    base = site_info({"r1": "carrier", "r2": "carrier", "r3": "carrier"})
    types = {"carrier": base.robot_types["carrier"], "pump": PUMP, "block_layer": LAYER}
    info = base.model_copy(
        update={"robot_type_of": {"r1": "carrier", "r2": "pump", "r3": "block_layer"}, "robot_types": types}
    )
    twin.robots(info, 0.0)
    return twin


def _state(guid: str, previous: S, state: S, t: float, robot: str | None = None) -> ComponentStateMsg:
    return ComponentStateMsg(
        guid=guid, previous=previous, state=state, event="e", robot_id=robot, sim_time_s=t, wall_time_s=t
    )


def test_a_component_built_in_place_is_never_in_the_yard_and_appears_with_its_first_pose(
    twin: TwinLog, manifest: Manifest
) -> None:
    footing, laid, column = (manifest.components[i] for i in (0, 2, 9))
    meshes, initial = twin.scene(lambda component: (b"glb", "model/gltf-binary"))
    static_paths = {item.entity_path for item in meshes}
    assert component_path(column.guid) in static_paths
    assert component_path(footing.guid) not in static_paths  # a mesh without a pose: drawn at the origin
    assert component_path(laid.guid) not in static_paths
    yard = {item.entity_path for item in twin.yard_poses(plan_site(manifest.components, robots=1))}
    assert component_path(column.guid) in yard and component_path(footing.guid) not in yard
    methods = {
        item.entity_path: any_value(item.archetype, "method")
        for item in initial
        if isinstance(item.archetype, rr.AnyValues)
    }
    assert methods[component_path(footing.guid)] == "cast_in_place"
    assert methods[component_path(column.guid)] == "lifted"
    target = footing.target_pose_world
    built = ComponentPoseMsg(
        guid=footing.guid,
        pose=PoseMsg(position_m=target.position_m, quat_xyzw=target.quat_xyzw),
        sim_time_s=16201.0,
        fixed=True,
    )
    items = twin.component_pose(built)
    assert [type(item.archetype) for item in items] == [rr.Asset3D, rr.Transform3D]
    assert all(item.entity_path == component_path(footing.guid) and not item.static for item in items)
    assert twin.component_pose(built) == []  # once


def test_the_work_on_a_cast_component_is_drawn_and_logged_with_its_method_and_machine(
    twin: TwinLog, manifest: Manifest
) -> None:
    footing = manifest.components[0]
    items = twin.component_state(_state(footing.guid, S.RELEASED, S.FORMING, 1.0, "r2"))
    (log,) = [item for item in items if item.entity_path == "log/components"]
    text = values(log.archetype.text)[0]
    assert "(IfcFooting, cast in place)" in text and "robot r2 (pump)" in text
    (box,) = [item for item in items if item.entity_path == work_path(footing.guid)]
    assert values(box.archetype.labels) == ["Footing A1: formwork, r2 (pump)"]
    (values_item,) = [item for item in items if isinstance(item.archetype, rr.AnyValues)]
    assert any_value(values_item.archetype, "resource") == "pump"
    pouring = twin.component_state(_state(footing.guid, S.FORMING, S.POURING, 14401.0, "r2"))
    assert [values(i.archetype.labels) for i in pouring if i.entity_path == work_path(footing.guid)] == [
        ["Footing A1: pour, r2 (pump)"]
    ]
    verifying = twin.component_state(_state(footing.guid, S.POURING, S.VERIFYING, 16201.0, "r2"))
    (cleared,) = [item for item in verifying if item.entity_path == work_path(footing.guid)]
    assert isinstance(cleared.archetype, rr.Clear)


def test_a_laid_component_grows_by_the_courses_its_block_layer_says_stand(
    twin: TwinLog, manifest: Manifest
) -> None:
    laid = manifest.components[2]
    twin.component_state(_state(laid.guid, S.RELEASED, S.LAYING, 1.0, "r3"))
    height = laid.bbox_world.max_m[2] - laid.bbox_world.min_m[2]
    state = {"robot_id": "r3", "state": RobotState.WORK_IN_PLACE, "task_id": "T1", "guid": laid.guid}
    state |= {"pose_xy_yaw": (0.0, 0.0, 0.0), "wall_time_s": 0.0}
    heights = []
    for course in (1, 2, 3):
        message = RobotStateMsg(**state, sim_time_s=course * 100.0, activity=f"course {course}/3")
        items = twin.robot_state(message)
        (courses,) = [item for item in items if item.entity_path == f"{work_path(laid.guid)}/courses"]
        heights.append(2.0 * values(courses.archetype.half_sizes)[0][2])
        (outline,) = [item for item in items if item.entity_path == work_path(laid.guid)]
        label = f"Footing A3: laying {course - 1}/3 courses, r3 (block_layer)"
        assert values(outline.archetype.labels) == [label]
        (marker,) = [item for item in items if item.entity_path == f"{robot_path('r3')}/marker"]
        assert values(marker.archetype.labels) == [f"r3 (block_layer): course {course}/3"]
    assert heights == [pytest.approx(0.01), pytest.approx(height / 3), pytest.approx(2 * height / 3)]
    assert courses_laid("course 4/8") == (3, 8) and courses_laid("pour") is None
