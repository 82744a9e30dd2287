"""The fleet on site in pybullet: one body per robot, from its own type's URDF, at its start in the site plan.

Why a module of its own: which robots stand on the site is the fleet's (:mod:`bimbot.shared.fleet`), not
physics' — physics only turns each robot's description into a body (:func:`.robots.spawn_robot`) and
reports the types with its site info. Without a fleet (tests, benches) the site holds N robots of
:data:`bimbot.shared.robot_description.DEFAULT_ROBOT` (pybullet_data's Husky), as before fleets.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from bimbot.shared.fleet import Fleet, resolve_urdf
from bimbot.shared.messages import RobotPoseMsg
from bimbot.shared.robot_description import DEFAULT_ROBOT, RobotDescription

from .robots import Robot, RobotConfig, spawn_robot
from .scene import robot_group


def robot_types(fleet: Fleet | None, robots: int) -> list[RobotDescription]:
    """One description per robot in id order (r1 first): the fleet's, or ``robots`` default robots."""
    return fleet.robot_types() if fleet is not None else [DEFAULT_ROBOT] * robots


def urdf_of(description: RobotDescription, fleet: Fleet | None) -> Path:
    """A type's URDF file (looked for beside the fleet file first; an InputError names where it looked)."""
    return fleet.resolve_urdf(description.urdf) if fleet is not None else resolve_urdf(description.urdf)


def spawn_fleet(
    client_id: int,
    types: Sequence[RobotDescription],
    starts: Sequence[tuple[float, float, float]],
    config: RobotConfig,
    fleet: Fleet | None,
) -> dict[str, Robot]:
    """Robot id (``r1``…) → its spawned body, each of its own type, at its start."""
    urdfs: dict[str, Path] = {}
    robots: dict[str, Robot] = {}
    for index, (description, start) in enumerate(zip(types, starts, strict=True)):
        if description.name not in urdfs:
            urdfs[description.name] = urdf_of(description, fleet)
        robot_id = f"r{index + 1}"
        robots[robot_id] = spawn_robot(
            client_id,
            robot_id,
            index,
            group=robot_group(index),
            start_xy_yaw=start,
            config=config,
            description=description,
            urdf=urdfs[description.name],
        )
    return robots


def types_on_site(robots: dict[str, Robot]) -> dict[str, RobotDescription]:
    """Type name → description, for the types that have a robot on site."""
    return {robot.description.name: robot.description for robot in robots.values()}


def robot_pose_msg(
    robot: Robot, pose_xy_yaw: tuple[float, float, float], now_s: float, carrying: str | None
) -> RobotPoseMsg:
    """A robot's ground truth; a crane's with its joint values (the observer draws the crane moving)."""
    joints = robot.rig.joints.by_name() if robot.rig is not None else {}
    return RobotPoseMsg(
        robot_id=robot.robot_id,
        pose_xy_yaw=pose_xy_yaw,
        sim_time_s=now_s,
        carrying=carrying,
        joint_positions=joints,
    )
