"""The observer's drawing vocabulary: entity paths, the log item, state colours as rerun updates (the
colour table itself is :mod:`bimbot.shared.state_colors`) and small transform helpers.

Shared by the twin (:mod:`.twin_log`), the robot models (:mod:`.fleet_log`) and the static scene
(:mod:`.blueprint`), so each draws with the same colours at the same paths without importing the other.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import rerun as rr

from bimbot.shared.messages import ComponentState
from bimbot.shared.state_colors import STATE_COLORS

TIMELINE = "sim_time"

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
