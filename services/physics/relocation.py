"""A truck-mounted machine that stands fixed moves to another of its set-up positions (``relocate``).

The robot has spent the relocation's time itself (stowing, driving on site, setting up again:
:meth:`~bimbot.shared.robot_description.RobotDescription.relocation_s`) before it asks; physics then moves
the machine's fixed base there at once, so what it builds next is judged from where it stands now. Only
to one of the set-up positions the site plan gives that machine (``SiteLayout.setups``): anywhere else
would stand on a lane, the yard or another machine, which the plan keeps clear.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

from bimbot.shared.messages import PhysicsReply
from bimbot.shared.robot_description import Capability
from bimbot.shared.site_plan import SiteLayout, machine_setups

from .client import p
from .robots import Robot
from .scene import compose, yaw_quat

_log = logging.getLogger(__name__)

SAME_POSE_M = 1e-3  # a requested pose this near a set-up (metres, radians) is that set-up


def robot_setups(
    layout: SiteLayout, robots: Sequence[Robot], robot_id: str
) -> tuple[tuple[float, float, float], ...]:
    """The set-up positions the plan gives ``robot_id`` (``robots`` in robot id order)."""
    machines = [robot for robot in robots if robot.description.can(Capability.STAND_FIXED)]
    index = next(number for number, robot in enumerate(machines) if robot.robot_id == robot_id)
    return machine_setups(layout, index, machines[index].start_xy_yaw)


def is_setup(pose_xy_yaw: Sequence[float], setups: Sequence[Sequence[float]]) -> bool:
    """``pose_xy_yaw`` is one of ``setups`` (within :data:`SAME_POSE_M`)."""
    return any(
        max(abs(a - b) for a, b in zip(pose_xy_yaw, setup, strict=True)) < SAME_POSE_M for setup in setups
    )


def move_base(client_id: int, robot: Robot, pose_xy_yaw: tuple[float, float, float]) -> None:
    """Put the machine's fixed base at ``pose_xy_yaw`` on the ground (its body, with its collision box)."""
    base = ((pose_xy_yaw[0], pose_xy_yaw[1], robot.base_height_m), yaw_quat(pose_xy_yaw[2]))
    com = compose(base, robot.base_inertial)
    p.resetBasePositionAndOrientation(robot.body_id, com[0], com[1], physicsClientId=client_id)
    robot._last_xy_yaw = pose_xy_yaw


def relocate(
    client_id: int,
    robot: Robot | None,
    setups: Sequence[tuple[float, float, float]],
    pose_xy_yaw: tuple[float, float, float],
    now_s: float,
) -> PhysicsReply:
    """Move ``robot`` to ``pose_xy_yaw``, one of its ``setups``; or refuse, saying why."""
    if robot is None:
        return PhysicsReply(ok=False, reason="no such robot on site", sim_time_s=now_s)
    if not robot.description.relocates:
        return PhysicsReply(
            ok=False,
            reason=f"{robot.robot_id} ({robot.description.name}) does not relocate (capability relocate)",
            sim_time_s=now_s,
        )
    if not is_setup(pose_xy_yaw, setups):
        x, y, _ = pose_xy_yaw
        return PhysicsReply(
            ok=False,
            reason=f"({x:.2f}, {y:.2f}) is not one of the {len(setups)} set-up positions of {robot.robot_id}",
            sim_time_s=now_s,
        )
    move_base(client_id, robot, pose_xy_yaw)
    _log.info("%s set up at (%.1f, %.1f)", robot.robot_id, pose_xy_yaw[0], pose_xy_yaw[1])
    return PhysicsReply(ok=True, sim_time_s=now_s)
