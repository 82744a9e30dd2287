"""Helpers for the physics tests: drive a robot, stand it beside a component, compare frames."""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation

from bimbot.services.physics.scene import Frame
from bimbot.services.physics.simulation import PeriodResult, Simulation
from bimbot.shared.manifest import Component
from bimbot.shared.messages import CmdVelMsg, PoseMsg
from bimbot.shared.site_plan import Rect


def drive(sim: Simulation, robot_id: str, v_mps: float, w_radps: float, seconds: float) -> list[PeriodResult]:
    """Command (v, w) and simulate ``seconds`` of control periods."""
    sim.command(CmdVelMsg(robot_id=robot_id, v_mps=v_mps, w_radps=w_radps, sim_time_s=sim.sim_time_s))
    return [sim.advance() for _ in range(round(seconds / sim.config.control_period_s))]


def idle(sim: Simulation, seconds: float) -> list[PeriodResult]:
    for robot_id in sim.robot_ids:
        sim.command(CmdVelMsg(robot_id=robot_id, v_mps=0.0, w_radps=0.0, sim_time_s=sim.sim_time_s))
    return [sim.advance() for _ in range(round(seconds / sim.config.control_period_s))]


def west_of(rect: Rect, gap_m: float) -> tuple[float, float, float]:
    """A robot pose ``gap_m`` west of a rectangle's west edge, level with its centre, facing +x."""
    return rect.min_xy[0] - gap_m, (rect.min_xy[1] + rect.max_xy[1]) / 2.0, 0.0


def angle_between(q1: tuple[float, ...], q2: tuple[float, ...]) -> float:
    """Geodesic angle between two orientations, radians."""
    relative = Rotation.from_quat(q1).inv() * Rotation.from_quat(q2)
    return float(relative.magnitude())


def wrap(angle_rad: float) -> float:
    return (angle_rad + math.pi) % (2.0 * math.pi) - math.pi


def pose(position_m: tuple[float, float, float], quat_xyzw: tuple[float, float, float, float]) -> PoseMsg:
    return PoseMsg(position_m=position_m, quat_xyzw=quat_xyzw)


def bottom_z(component: Component, frame: Frame) -> float:
    low, high = component.bbox_local.min_m, component.bbox_local.max_m
    corners = np.array(
        [[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])]
    )
    return float((Rotation.from_quat(frame[1]).apply(corners) + np.asarray(frame[0]))[:, 2].min())


def distance_to_footprint(component: Component, frame: Frame, xy: tuple[float, float]) -> float:
    """Horizontal distance from ``xy`` to a lying component's own (oriented) footprint rectangle."""
    turn = Rotation.from_quat(frame[1])
    local = turn.inv().apply(np.array([xy[0], xy[1], frame[0][2]]) - np.asarray(frame[0]))
    vertical = int(np.argmax(np.abs(turn.as_matrix()[2])))  # the local axis that points up
    low, high = component.bbox_local.min_m, component.bbox_local.max_m
    gaps = [max(low[k] - local[k], 0.0, local[k] - high[k]) for k in range(3) if k != vertical]
    return math.hypot(*gaps)
