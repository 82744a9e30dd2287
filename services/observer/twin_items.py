"""The observer's drawing vocabulary: colours, entity paths, the log item and small transform helpers.

Shared by the twin (:mod:`.twin_log`), the robot models (:mod:`.fleet_log`) and the static scene
(:mod:`.blueprint`), so each draws with the same colours at the same paths without importing the other.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import rerun as rr

from bimbot.shared.messages import ComponentState, RobotState

TIMELINE = "sim_time"
Rgba = tuple[int, int, int, int]

# One colour per component state; "carried" (picking/transporting) and the failure path stand out.
STATE_COLORS: dict[ComponentState, Rgba] = {
    ComponentState.PLANNED: (170, 170, 170, 255),  # grey: waiting in the yard
    ComponentState.RELEASED: (33, 150, 243, 255),  # blue: ready, waiting for a robot
    ComponentState.PICKING: (0, 229, 255, 255),  # cyan: a robot is coming for it
    ComponentState.TRANSPORTING: (255, 152, 0, 255),  # orange: carried
    ComponentState.ASSEMBLING: (156, 39, 176, 255),  # purple: being put in place
    ComponentState.FORMING: (0, 0, 195, 255),  # navy: formwork going up around it
    ComponentState.POURING: (0, 150, 136, 255),  # teal: concrete going in
    ComponentState.LAYING: (255, 90, 255, 255),  # magenta: courses going up
    ComponentState.VERIFYING: (255, 235, 59, 255),  # yellow: checking its own pose
    ComponentState.CONSTRUCTED: (46, 160, 67, 255),  # green: done
    ComponentState.MISPLACED: (244, 67, 54, 255),  # red: off target, will be retried
    ComponentState.FAILED: (80, 0, 0, 255),  # dark red: given up
    ComponentState.BLOCKED: (90, 60, 40, 255),  # brown: a predecessor failed, never released
}
ROBOT_COLORS: dict[RobotState, Rgba] = {
    RobotState.IDLE: (120, 120, 120, 255),
    RobotState.DETECT_COMPONENT_POSITION: (33, 150, 243, 255),
    RobotState.PICK_UP: (0, 229, 255, 255),
    RobotState.IDENTIFY_TARGET_LOCATION: (255, 152, 0, 255),
    RobotState.ASSEMBLE: (156, 39, 176, 255),
    RobotState.WORK_IN_PLACE: (0, 150, 136, 255),
}
STATE_LOG_LEVELS: dict[ComponentState, str] = {
    ComponentState.MISPLACED: "WARN",
    ComponentState.FAILED: "ERROR",
    ComponentState.BLOCKED: "WARN",
}
ROBOT_HALF_SIZE_M = (0.495, 0.335, 0.19)  # Clearpath Husky body, for drawing
SITE_LINE_Z_M = 0.01
PLAN_Z_M = 0.05


@dataclass(frozen=True)
class LogItem:
    """One ``rr.log`` call: an archetype at an entity path, static or at the current sim time."""

    entity_path: str
    archetype: rr.AsComponents
    static: bool = False


def component_path(guid: str) -> str:
    return f"world/components/{rr.escape_entity_path_part(guid)}"


def robot_path(robot_id: str) -> str:
    return f"world/robots/{rr.escape_entity_path_part(robot_id)}"


def trail_path(robot_id: str, segment: int) -> str:
    return f"world/trails/{rr.escape_entity_path_part(robot_id)}/{segment:04d}"


def plan_path(robot_id: str) -> str:
    return f"world/plans/{rr.escape_entity_path_part(robot_id)}"


def transform(position_m: Iterable[float], quat_xyzw: Iterable[float]) -> rr.Transform3D:
    return rr.Transform3D(translation=list(position_m), quaternion=rr.Quaternion(xyzw=list(quat_xyzw)))


def planar_transform(pose_xy_yaw: tuple[float, float, float]) -> rr.Transform3D:
    x, y, yaw = pose_xy_yaw
    return transform((x, y, 0.0), (0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0)))


def component_color(state: ComponentState) -> rr.Asset3D:
    """A partial update of a component's mesh: only its colour."""
    return rr.Asset3D.from_fields(albedo_factor=STATE_COLORS[state])


def mesh_archetype(contents: bytes, media_type: str) -> rr.Asset3D:
    """The mesh alone (static): its colour is temporal (a static colour would hide every later one)."""
    return rr.Asset3D(contents=contents, media_type=media_type)
