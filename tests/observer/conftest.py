"""A synthetic, deterministic construction run on the bundled build, as the bus would carry it.

Two robots build the first three components of the planned sequence; the second component is misplaced
once and retried. Robots drive straight lines (ground truth poses and odometry), scan, plan; the planner
publishes progress, ending with ``done``. Times are sim seconds, chosen so every expected figure of the
report can be computed by hand (see the report tests).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from pydantic import BaseModel

from bimbot.shared.identifiers import guid_to_key
from bimbot.shared.manifest import Manifest, read_manifest
from bimbot.shared.messages import (
    COMPONENT_POSE_KEY,
    COMPONENT_STATE_KEY,
    PROGRESS_KEY,
    ROBOT_PLAN_KEY,
    ROBOT_POSE_KEY,
    ROBOT_SENSORS_KEY,
    ROBOT_STATE_KEY,
    TASK_KEY,
    ClockMsg,
    ComponentPoseMsg,
    ComponentState,
    ComponentStateMsg,
    OdomMsg,
    PlanMsg,
    PoseMsg,
    ProgressMsg,
    RobotPoseMsg,
    RobotState,
    RobotStateMsg,
    ScanMsg,
    SensorsMsg,
    TaskMsg,
    TaskStatus,
    key,
)
from bimbot.shared.sequence import read_sequence

S = ComponentState
# (guid index in the sequence, robot, release, pick, place times, retried?) — place of the last attempt
PLAN = (
    (0, "r1", 1.0, 2.0, 10.0, False),
    (1, "r2", 1.0, 3.0, 20.0, True),  # misplaced at 12, retried, placed again at 20
    (2, "r1", 11.0, 12.0, 18.0, False),
)
ROBOT_BUSY = {"r1": [(2.0, 10.5), (12.0, 18.5)], "r2": [(3.0, 20.5)]}  # leave idle → back to idle
# r1 drives 6 m east and back (12 m), r2 drives 4 m north (4 m), in 1 m steps of ground truth
ROBOT_PATHS = {
    "r1": [(float(x), 0.0) for x in range(7)] + [(float(x), 0.0) for x in range(5, -1, -1)],
    "r2": [(0.0, float(y)) for y in range(5)],
}
END_S = 21.0


def _state(guid: str, state: S, previous: S | None, t: float, robot: str | None, *, attempt: int = 1):
    return ComponentStateMsg(
        guid=guid,
        state=state,
        previous=previous,
        event="test",
        attempt=attempt,
        robot_id=robot,
        sim_time_s=t,
        wall_time_s=1000.0 + t,
        position_error_m=0.05 if state == S.MISPLACED else None,
    )


def _robot_state(robot: str, state: RobotState, t: float, guid: str | None = None) -> RobotStateMsg:
    return RobotStateMsg(
        robot_id=robot,
        state=state,
        task_id=f"T-{guid}" if guid else None,
        guid=guid,
        pose_xy_yaw=(0.0, 0.0, 0.0),
        sim_time_s=t,
        wall_time_s=1000.0 + t,
    )


def synthetic_run(manifest: Manifest, sequence: list[str]) -> list[tuple[str, BaseModel]]:
    """(key expression, message) pairs in publication order."""
    site = manifest.site
    out: list[tuple[float, int, str, BaseModel]] = []

    def put(t: float, key_expr: str, message: BaseModel) -> None:
        out.append((t, len(out), key_expr, message))

    for guid in [c.guid for c in manifest.components]:
        put(
            0.0,
            key(COMPONENT_STATE_KEY, site=site, key=guid_to_key(guid)),
            _state(guid, S.PLANNED, None, 0.0, None, attempt=0),
        )
    for index, robot, released, picked, placed, retried in PLAN:
        guid = sequence[index]
        k = guid_to_key(guid)
        state_key = key(COMPONENT_STATE_KEY, site=site, key=k)
        target = manifest.component(guid).target_pose_world
        put(released, state_key, _state(guid, S.RELEASED, S.PLANNED, released, None, attempt=0))
        task = TaskMsg(
            task_id=f"T-{guid}",
            guid=guid,
            component_key=k,
            status=TaskStatus.ASSIGNED,
            robot_id=robot,
            target_pose=PoseMsg(position_m=target.position_m, quat_xyzw=target.quat_xyzw),
            sim_time_s=released,
            wall_time_s=1000.0 + released,
        )
        put(released, key(TASK_KEY, site=site, task_id=f"T-{k}"), task)
        put(picked, state_key, _state(guid, S.PICKING, S.RELEASED, picked, robot))
        put(picked + 1, state_key, _state(guid, S.TRANSPORTING, S.PICKING, picked + 1, robot))
        for step in range(3):  # carried poses 0.05 s apart: throttled by the observer
            carried = PoseMsg(position_m=(float(step), 0.0, 0.5), quat_xyzw=(0.0, 0.0, 0.0, 1.0))
            put(
                picked + 1 + 0.05 * step,
                key(COMPONENT_POSE_KEY, site=site, key=k),
                ComponentPoseMsg(
                    guid=guid, pose=carried, sim_time_s=picked + 1 + 0.05 * step, attached_to=robot
                ),
            )
        put(placed - 1, state_key, _state(guid, S.ASSEMBLING, S.TRANSPORTING, placed - 1, robot))
        if retried:
            put(9.0, state_key, _state(guid, S.VERIFYING, S.ASSEMBLING, 9.0, robot))
            put(12.0, state_key, _state(guid, S.MISPLACED, S.VERIFYING, 12.0, robot))
            put(12.5, state_key, _state(guid, S.RELEASED, S.MISPLACED, 12.5, None, attempt=1))
            put(13.0, state_key, _state(guid, S.PICKING, S.RELEASED, 13.0, robot, attempt=2))
            put(15.0, state_key, _state(guid, S.TRANSPORTING, S.PICKING, 15.0, robot, attempt=2))
            put(19.0, state_key, _state(guid, S.ASSEMBLING, S.TRANSPORTING, 19.0, robot, attempt=2))
        placed_pose = PoseMsg(position_m=target.position_m, quat_xyzw=target.quat_xyzw)
        put(
            placed,
            key(COMPONENT_POSE_KEY, site=site, key=k),
            ComponentPoseMsg(guid=guid, pose=placed_pose, sim_time_s=placed, fixed=True),
        )
        attempt = 2 if retried else 1
        put(placed, state_key, _state(guid, S.VERIFYING, S.ASSEMBLING, placed, robot, attempt=attempt))
        put(
            placed + 0.2,
            state_key,
            _state(guid, S.CONSTRUCTED, S.VERIFYING, placed + 0.2, robot, attempt=attempt),
        )
    for robot, intervals in ROBOT_BUSY.items():
        state_key = key(ROBOT_STATE_KEY, site=site, robot_id=robot)
        put(0.0, state_key, _robot_state(robot, RobotState.IDLE, 0.0))
        for (start, end), (index, *_rest) in zip(intervals, [p for p in PLAN if p[1] == robot], strict=True):
            guid = sequence[index]
            put(start, state_key, _robot_state(robot, RobotState.DETECT_COMPONENT_POSITION, start, guid))
            put(start + 0.5, state_key, _robot_state(robot, RobotState.PICK_UP, start + 0.5, guid))
            put(end - 1.0, state_key, _robot_state(robot, RobotState.ASSEMBLE, end - 1.0, guid))
            put(end, state_key, _robot_state(robot, RobotState.IDLE, end))
            put(end + 0.1, state_key, _robot_state(robot, RobotState.IDLE, end + 0.1))  # repeated idle
    for robot, path in ROBOT_PATHS.items():
        for step, (x, y) in enumerate(path):
            t = 2.0 + step
            put(
                t,
                key(ROBOT_POSE_KEY, site=site, robot_id=robot),
                RobotPoseMsg(robot_id=robot, pose_xy_yaw=(x, y, 0.0), sim_time_s=t),
            )
            odom = OdomMsg(
                robot_id=robot, pose_xy_yaw=(x * 1.1, y * 1.1, 0.0), v_mps=1.0, w_radps=0.0, sim_time_s=t
            )
            scan = ScanMsg(
                robot_id=robot,
                angle_min_rad=-1.0,
                angle_increment_rad=0.5,
                range_max_m=10.0,
                ranges_m=[1.0, 2.0, 30.0, 3.0, 4.0],
                sim_time_s=t,
            )
            clock = ClockMsg(sim_time_s=t, step=step, real_time_factor=10.0, lock_step=True)
            sensors = SensorsMsg(robot_id=robot, clock=clock, odom=odom, scan=scan)
            put(t, key(ROBOT_SENSORS_KEY, site=site, robot_id=robot), sensors)
        plan = PlanMsg(robot_id=robot, path_xy_m=list(path), goal_xy_m=path[-1], sim_time_s=2.0)
        put(2.0, key(ROBOT_PLAN_KEY, site=site, robot_id=robot), plan)
    total = len(manifest.components)
    for t, constructed in ((1.0, 0), (10.2, 1), (18.2, 2), (END_S, 3)):
        counts = {S.PLANNED.value: total - constructed, S.CONSTRUCTED.value: constructed}
        progress = ProgressMsg(
            total=total,
            counts=counts,
            percent_constructed=100.0 * constructed / total,
            sim_time_s=t,
            estimated_finish_sim_time_s=None,
            done=t == END_S,
        )
        put(t, key(PROGRESS_KEY, site=site), progress)
    return [
        (key_expr, message) for _, _, key_expr, message in sorted(out, key=lambda item: (item[0], item[1]))
    ]


@pytest.fixture(scope="session")
def frame_manifest(bundled_build: Path) -> Manifest:
    return read_manifest(bundled_build)


@pytest.fixture(scope="session")
def frame_sequence(bundled_build: Path) -> list[str]:
    return read_sequence(bundled_build / "sequence.xml").guids()


@pytest.fixture(scope="session")
def robot_paths() -> dict[str, list[tuple[float, float]]]:
    """The synthetic run's ground-truth robot paths (a fixture: `conftest` is no importable module name)."""
    return ROBOT_PATHS


@pytest.fixture(scope="session")
def run_messages(frame_manifest: Manifest, frame_sequence: list[str]) -> list[tuple[str, BaseModel]]:
    return synthetic_run(frame_manifest, frame_sequence)
