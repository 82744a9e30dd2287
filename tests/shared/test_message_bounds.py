"""Schema-valid nonsense is rejected by decode: logged, counted as invalid, never handed to a service.

A ``sim_time_s`` of 1e40 flipped constructed components back to released and a clock ``step`` of 1e9 froze
a robot; now every number of a message has bounds (``shared/message_bounds.py``). Each case takes a valid
message, changes one field in its JSON to nonsense and checks that :func:`decode` refuses it, while the
unchanged message still passes.
"""

from __future__ import annotations

import json
import math
from typing import Any

import pytest
from pydantic import BaseModel, ValidationError

from bimbot.shared.bus import InvalidPayloads, decode, encode
from bimbot.shared.message_bounds import MAX_SIM_TIME_S, MAX_STEP
from bimbot.shared.messages import (
    ClockMsg,
    CmdVelMsg,
    ComponentPoseMsg,
    ComponentState,
    ComponentStateMsg,
    CuringHold,
    OdomMsg,
    PoseMsg,
    ProgressMsg,
    RobotState,
    RobotStateMsg,
    ScanMsg,
    SitePosesMsg,
    TaskMsg,
    TaskStatus,
)

POSE = PoseMsg(position_m=(1.0, -2.0, 0.5), quat_xyzw=(0.0, 0.0, 0.0, 1.0))
GOOD: dict[str, BaseModel] = {
    "clock": ClockMsg(sim_time_s=12.5, step=125, real_time_factor=0.0, lock_step=True, epoch=1),
    "pose": ComponentPoseMsg(guid="2O2Fr$t4X7Zf8NOew3FLOH", pose=POSE, sim_time_s=3.0),
    "state": ComponentStateMsg(
        guid="g",
        state=ComponentState.CONSTRUCTED,
        event="verify",
        sim_time_s=10.0,
        wall_time_s=1.7e9,
        position_error_m=0.001,
        angle_error_rad=0.0,
    ),
    "task": TaskMsg(
        task_id="t1",
        guid="g",
        component_key="g",
        status=TaskStatus.RELEASED,
        target_pose=POSE,
        sim_time_s=1.0,
        wall_time_s=1.7e9,
    ),
    "cmd_vel": CmdVelMsg(robot_id="r1", v_mps=0.5, w_radps=-0.2, sim_time_s=1.0, step=10),
    "odom": OdomMsg(
        robot_id="r1", pose_xy_yaw=(1.0, 2.0, math.pi - 1e-9), v_mps=0.5, w_radps=0.1, sim_time_s=1
    ),
    "scan": ScanMsg(
        robot_id="r1",
        angle_min_rad=-math.pi,
        angle_increment_rad=math.pi / 2,
        range_max_m=15.0,
        ranges_m=[1.0, 15.0, math.inf, 0.0],
        sim_time_s=1.0,
    ),
    "robot": RobotStateMsg(
        robot_id="r1", state=RobotState.IDLE, pose_xy_yaw=(0.0, 0.0, 0.0), sim_time_s=0.0, wall_time_s=1.7e9
    ),
    "progress": ProgressMsg(
        total=2,
        counts={"constructed": 1, "planned": 1},
        percent_constructed=50.0,
        sim_time_s=100.0,
        estimated_finish_sim_time_s=200.0,
    ),
    "poses": SitePosesMsg(step=3, epoch=0, sim_time_s=0.6, components={}, robots={}),
}


def _payload(message: BaseModel, path: tuple[str | int, ...], value: Any) -> bytes:
    """``message`` as JSON with the field at ``path`` replaced by ``value`` (NaN/Infinity written as JSON5
    literals, which pydantic reads unless the field forbids them)."""
    data = json.loads(encode(message))
    target = data
    for part in path[:-1]:
        target = target[part]
    target[path[-1]] = value
    return json.dumps(data, allow_nan=True).encode()


def test_a_build_of_a_year_and_more_is_in_bounds() -> None:
    """A 945-element Revit frame (concrete cast and cured bay by bay) runs past 116 days of sim time: the
    planner's curing hold of 10,033,010 s was refused and the planner died halfway through the build."""
    clock = GOOD["clock"]
    later = clock.model_copy(update={"sim_time_s": 3.2e7})  # a year of site time
    assert decode(type(clock), "k", encode(later), InvalidPayloads()) == later
    assert CuringHold(guid="g", cast_guid="c", until_s=10_033_010.4).until_s == 10_033_010.4


@pytest.mark.parametrize("name", sorted(GOOD))
def test_every_good_message_still_decodes(name: str) -> None:
    invalid = InvalidPayloads()
    message = GOOD[name]
    assert decode(type(message), "k", encode(message), invalid) == message
    assert invalid.total == 0


@pytest.mark.parametrize(
    ("name", "path", "value"),
    [
        ("clock", ("sim_time_s",), 1e40),  # flipped constructed components back to released
        ("clock", ("sim_time_s",), MAX_SIM_TIME_S * 1.01),
        ("clock", ("sim_time_s",), -1.0),
        ("clock", ("sim_time_s",), math.nan),
        ("clock", ("sim_time_s",), math.inf),
        ("clock", ("step",), 10**9),  # froze a robot
        ("clock", ("step",), 10**12),
        ("clock", ("step",), -1),
        ("clock", ("epoch",), -1),
        ("clock", ("real_time_factor",), -1.0),
        ("clock", ("real_time_factor",), math.inf),
        ("pose", ("sim_time_s",), 1e40),
        ("pose", ("pose", "position_m", 0), math.nan),
        ("pose", ("pose", "position_m", 2), 1e6),
        ("pose", ("pose", "quat_xyzw", 3), math.nan),
        ("pose", ("pose", "quat_xyzw"), [0.0, 0.0, 0.0, 0.0]),
        ("pose", ("pose", "quat_xyzw"), [0.0, 0.0, 0.0, 2.0]),
        ("state", ("sim_time_s",), 1e40),
        ("state", ("wall_time_s",), math.nan),
        ("state", ("attempt",), -1),
        ("state", ("position_error_m",), math.inf),
        ("task", ("target_pose", "position_m", 1), -math.inf),
        ("cmd_vel", ("v_mps",), 1e9),
        ("cmd_vel", ("w_radps",), math.nan),
        ("cmd_vel", ("step",), MAX_STEP),
        ("odom", ("pose_xy_yaw", 2), math.nan),
        ("odom", ("pose_xy_yaw", 0), 1e40),
        ("scan", ("ranges_m", 1), math.nan),
        ("scan", ("ranges_m", 1), -1.0),
        ("scan", ("range_max_m",), 0.0),
        ("robot", ("distance_m",), -5.0),
        ("progress", ("percent_constructed",), 101.0),
        ("progress", ("total",), -1),
        ("progress", ("counts", "planned"), -1),
        ("poses", ("step",), 10**9),
    ],
)
def test_decode_counts_schema_valid_nonsense_as_invalid(
    name: str, path: tuple[str | int, ...], value: Any
) -> None:
    invalid = InvalidPayloads()
    message = GOOD[name]
    assert decode(type(message), "bimbot/site/k", _payload(message, path, value), invalid) is None
    assert invalid.by_key["bimbot/site/k"] == 1


def test_a_producer_cannot_build_nonsense_either() -> None:
    with pytest.raises(ValidationError):
        ClockMsg(sim_time_s=1e40, step=0, real_time_factor=1.0)
    with pytest.raises(ValidationError):
        PoseMsg(position_m=(math.nan, 0.0, 0.0), quat_xyzw=(0.0, 0.0, 0.0, 1.0))
