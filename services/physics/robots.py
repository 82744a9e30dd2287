"""Robots from their type's URDF (:mod:`bimbot.shared.fleet`): ground robots driven differentially on their
wheel joints, tower cranes standing still on a fixed base (odometry: :mod:`.odometry`).

Drive (ground robots): a command ``(v, w)`` (clamped to the robot type's ``max_speed_mps`` /
``max_turn_radps``) becomes wheel speeds ``(v ∓ w·track·k/2) / radius`` for the left/right wheels, applied
with VELOCITY_CONTROL and a torque limit. The limit is ``RobotConfig.wheel_torque_nm`` (60 N·m, the
Husky's) scaled to each robot by its mass times wheel radius per wheel (:func:`wheel_torque_nm`), so every
type has the Husky's tractive force per kilogram: at 60 N·m the 600 kg carrier could not turn at all.
Robots are skid-steered: their wheels must slip sideways to turn, and in Bullet a 4-wheel skid steer turns
at only ~35 % of the geometric rate, with a yaw rate that oscillates with heading (friction pyramid).
Two measured remedies, both configurable:

* the wheels' lateral friction is ``wheel_lateral_friction_ratio`` (0.2) of their rolling friction
  (anisotropic friction along the axle), and the track width is multiplied by ``track_multiplier`` (1.5),
  as ``husky_control``'s ``wheel_separation_multiplier`` does on the real robot;
* a low-level integral correction, updated each control period from the measured speed and yaw rate (the
  robot's own wheel encoders and gyro would give the same), removes what is left: measured on flat ground,
  ``w·t`` within 1 % over 8 s, per-period yaw-rate RMS error ≈ 0.1 rad/s at 1 rad/s (Husky and carrier
  alike; ``tests/physics/test_physics_fleet.py``).

Wheel joints: ``--wheel-joints`` (names or indices, for every ground type), or detected: revolute joints
whose axis is along the base's y axis; left wheels are those with y > 0. Wheel radius from the wheel's
cylinder/sphere collision shape (URDF cylinders are loaded as implicit cylinders) or its bounding box;
track from the wheel positions.

Tower cranes (a type with ``crane``): loaded with a fixed base, no wheels, no drive; a command is taken
(for lock-step) and does nothing. Their joints are a :class:`.crane_rig.CraneRig`.

Frames: a robot's pose is its URDF base link frame (for the Husky ``base_footprint``, on the ground between
the wheels), not pybullet's base CoM frame. ``pose_xy_yaw`` is (x, y, heading) in the world frame.
"""

from __future__ import annotations

import contextlib
import logging
import math
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bimbot.shared.crane_mast import raised_mast_urdf
from bimbot.shared.errors import InputError
from bimbot.shared.geometry import wrap_angle
from bimbot.shared.robot_description import Capability, RobotDescription

from .client import p, quiet_stdout
from .crane_rig import CraneRig
from .scene import (
    ALL_GROUPS,
    GROUND_GROUP,
    PIT_EDGE_GROUP,
    Frame,
    Quat,
    Vec3,
    compose,
    invert,
    set_filter,
    yaw_of,
    yaw_quat,
)

_log = logging.getLogger(__name__)

# pybullet_data's Husky as pybullet loads it (its six empty links weigh 1 kg each): the torque reference
HUSKY_MASS_KG = 50.003
HUSKY_WHEEL_RADIUS_M = 0.17775
HUSKY_WHEELS = 4


@dataclass(frozen=True)
class RobotConfig:
    """Drive tuning shared by every ground robot type (a type's limits are in its description)."""

    wheel_joints: tuple[str, ...] = ()  # joint names or indices, for every ground type; empty: detected
    wheel_torque_nm: float = 60.0  # the Husky's; scaled to each robot (:func:`wheel_torque_nm`)
    track_multiplier: float = 1.5
    wheel_lateral_friction_ratio: float = 0.2
    tracking_gain_per_s: float = 5.0  # integral gain of the speed / yaw-rate correction
    max_correction: tuple[float, float] = (0.5, 2.0)  # |speed| m/s, |yaw rate| rad/s


def wheel_torque_nm(husky_torque_nm: float, mass_kg: float, wheel_radius_m: float, wheels: int) -> float:
    """A robot's torque limit per wheel: the Husky's, scaled so that every robot has the Husky's tractive
    force per kilogram (torque ∝ mass · wheel radius / wheels)."""
    reference = HUSKY_MASS_KG * HUSKY_WHEEL_RADIUS_M / HUSKY_WHEELS
    return husky_torque_nm * (mass_kg * wheel_radius_m / max(1, wheels)) / reference


@dataclass(frozen=True)
class DriveGeometry:
    """Wheel joints with their spin sign (+1 when a positive joint speed drives the robot forward)."""

    left: tuple[tuple[int, float], ...]
    right: tuple[tuple[int, float], ...]
    wheel_radius_m: float
    track_m: float


def _joint_index(body_id: int, client_id: int, name_or_index: str) -> int:
    count = p.getNumJoints(body_id, physicsClientId=client_id)
    if name_or_index.strip().lstrip("-").isdigit():
        index = int(name_or_index)
        if 0 <= index < count:
            return index
        raise InputError(f"wheel joint {index} out of range 0..{count - 1}")
    for index in range(count):
        if p.getJointInfo(body_id, index, physicsClientId=client_id)[1].decode() == name_or_index.strip():
            return index
    raise InputError(f"no joint named {name_or_index!r} in the robot URDF")


def _link_frame(client_id: int, body_id: int, link: int) -> Frame:
    state = p.getLinkState(body_id, link, computeForwardKinematics=True, physicsClientId=client_id)
    return tuple(state[4]), tuple(state[5])


def detect_drive(
    client_id: int, body_id: int, base_frame: Frame, wheel_joints: tuple[str, ...]
) -> DriveGeometry:
    """The differential drive of the robot at ``base_frame`` (its base link frame in the world)."""
    to_base = invert(base_frame)
    if wheel_joints:
        joints = [_joint_index(body_id, client_id, item) for item in wheel_joints]
    else:
        joints = []
        for index in range(p.getNumJoints(body_id, physicsClientId=client_id)):
            info = p.getJointInfo(body_id, index, physicsClientId=client_id)
            if info[2] != p.JOINT_REVOLUTE:
                continue
            link_quat = compose(to_base, _link_frame(client_id, body_id, index))[1]
            axis_base = _rotate_axis(link_quat, info[13])
            if abs(axis_base[1]) > 0.9:
                joints.append(index)
    if len(joints) < 2:
        raise InputError(
            "no wheel joints found (revolute joints about the base's y axis); give --wheel-joints"
        )
    left: list[tuple[int, float]] = []
    right: list[tuple[int, float]] = []
    radii: list[float] = []
    lateral: dict[int, float] = {}
    for index in joints:
        info = p.getJointInfo(body_id, index, physicsClientId=client_id)
        wheel_in_base = compose(to_base, _link_frame(client_id, body_id, index))
        axis_base = _rotate_axis(wheel_in_base[1], info[13])
        sign = 1.0 if axis_base[1] > 0.0 else -1.0  # spin about +y rolls the robot forward (+x)
        (left if wheel_in_base[0][1] > 0.0 else right).append((index, sign))
        lateral[index] = wheel_in_base[0][1]
        radii.append(_wheel_radius(client_id, body_id, index))
    if not left or not right:
        raise InputError(f"wheel joints {joints} are not on both sides of the robot")
    track = float(np.mean([lateral[i] for i, _ in left]) - np.mean([lateral[i] for i, _ in right]))
    return DriveGeometry(tuple(left), tuple(right), float(np.mean(radii)), track)


def _rotate_axis(quat_xyzw: Quat, axis: Vec3) -> Vec3:
    matrix = np.array(p.getMatrixFromQuaternion(quat_xyzw)).reshape(3, 3)
    v = matrix @ np.asarray(axis, dtype=float)
    return float(v[0]), float(v[1]), float(v[2])


def _wheel_radius(client_id: int, body_id: int, link: int) -> float:
    for shape in p.getCollisionShapeData(body_id, link, physicsClientId=client_id):
        geometry, dimensions = shape[2], shape[3]
        if geometry == p.GEOM_CYLINDER:
            return float(dimensions[1])
        if geometry == p.GEOM_SPHERE:
            return float(dimensions[0])
    low, high = p.getAABB(body_id, link, physicsClientId=client_id)
    return (high[2] - low[2]) / 2.0


def _axle_friction(client_id: int, body_id: int, joint: int, ratio: float) -> list[float]:
    """Anisotropic friction factors in the wheel collider's (CoM) frame: ``ratio`` along the axle."""
    axis = p.getJointInfo(body_id, joint, physicsClientId=client_id)[13]
    inertial_quat = p.getDynamicsInfo(body_id, joint, physicsClientId=client_id)[4]
    axle = _rotate_axis(invert(((0.0, 0.0, 0.0), tuple(inertial_quat)))[1], axis)
    return [1.0 - (1.0 - ratio) * abs(component) for component in axle]


@dataclass
class Robot:
    """One spawned robot: its type, body, drive (None for a crane), command and speed control state."""

    robot_id: str
    index: int
    body_id: int
    group: int
    drive: DriveGeometry | None
    config: RobotConfig
    description: RobotDescription
    start_xy_yaw: tuple[float, float, float]
    top_height_m: float  # highest point of its collision shapes above its base frame (where loads go)
    base_height_m: float  # its base frame's height above the ground at rest
    half_extents_xy_m: tuple[
        float, float
    ]  # farthest collision extents from its base frame, forward / sideways
    base_inertial: Frame  # CoM frame in the base link frame
    wheel_torque_nm: float = 0.0  # per wheel (:func:`wheel_torque_nm`)
    rig: CraneRig | None = None  # a tower crane's joints
    command: tuple[float, float] = (0.0, 0.0)
    held: bool = False  # wheels stopped whatever the command (assembling, lost)
    _correction: list[float] = field(default_factory=lambda: [0.0, 0.0])
    _may_sleep: bool = False  # told to stand still: Bullet may put it to sleep once at rest
    _last_xy_yaw: tuple[float, float, float] = (0.0, 0.0, 0.0)
    _base_from_com: Frame = field(init=False)  # the base link frame in the CoM frame (asked every step)

    def __post_init__(self) -> None:
        self._base_from_com = invert(self.base_inertial)

    def frame(self, client_id: int) -> Frame:
        """Base link frame in the world."""
        position, quat = p.getBasePositionAndOrientation(self.body_id, physicsClientId=client_id)
        return compose((position, quat), self._base_from_com)

    def pose_xy_yaw(self, client_id: int) -> tuple[float, float, float]:
        (x, y, _), quat = self.frame(client_id)
        return x, y, yaw_of(quat)

    @property
    def drives(self) -> bool:
        """It moves itself (differential drive, odometry, a laser); else it stands where it was set up."""
        return self.description.can(Capability.DRIVE)

    @property
    def lifts_by_hook(self) -> bool:
        return self.description.can(Capability.HOOK_LIFT)

    def set_command(self, v_mps: float, w_radps: float) -> None:
        """Take ``(v, w)`` within the robot type's limits (a crane's are 0: it never drives)."""
        if not (math.isfinite(v_mps) and math.isfinite(w_radps)):
            v_mps, w_radps = 0.0, 0.0
        d = self.description
        self.command = (
            max(-d.max_speed_mps, min(d.max_speed_mps, v_mps)),
            max(-d.max_turn_radps, min(d.max_turn_radps, w_radps)),
        )

    def reset_control(self) -> None:
        """Forget the speed / yaw-rate correction (after a teleport)."""
        self._correction[:] = [0.0, 0.0]

    def apply_motors(self, client_id: int) -> None:
        """Wheel speed targets for the next control period (nothing for a crane). A robot told to stand
        still may fall asleep in Bullet once it has come to rest (it then costs the solver almost nothing:
        0.016 ms a step against 0.055 for the carrier at rest); any other command wakes it first."""
        if self.drive is None:
            return
        v, w = (0.0, 0.0) if self.held else self.command
        still = v == 0.0 and w == 0.0
        if still != self._may_sleep:
            self._may_sleep = still
            state = p.ACTIVATION_STATE_ENABLE_SLEEPING if still else p.ACTIVATION_STATE_WAKE_UP
            p.changeDynamics(self.body_id, -1, activationState=state, physicsClientId=client_id)
            if not still:
                p.changeDynamics(
                    self.body_id,
                    -1,
                    activationState=p.ACTIVATION_STATE_DISABLE_SLEEPING,
                    physicsClientId=client_id,
                )
        if not self.held:
            v += self._correction[0]
            w = w * self.config.track_multiplier + self._correction[1]
        else:
            self._correction[:] = [0.0, 0.0]
        half = self.drive.track_m / 2.0
        left = (v - w * half) / self.drive.wheel_radius_m
        right = (v + w * half) / self.drive.wheel_radius_m
        for wheels, speed in ((self.drive.left, left), (self.drive.right, right)):
            for joint, sign in wheels:
                p.setJointMotorControl2(
                    self.body_id,
                    joint,
                    p.VELOCITY_CONTROL,
                    targetVelocity=sign * speed,
                    force=self.wheel_torque_nm,
                    physicsClientId=client_id,
                )

    def measure(
        self, client_id: int, period_s: float
    ) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """(previous, current) true ``pose_xy_yaw``; updates the speed / yaw-rate correction."""
        previous = self._last_xy_yaw
        current = self.pose_xy_yaw(client_id)
        self._last_xy_yaw = current
        if not self.held and self.drive is not None:
            dx, dy = current[0] - previous[0], current[1] - previous[1]
            speed = (dx * math.cos(previous[2]) + dy * math.sin(previous[2])) / period_s
            rate = wrap_angle(current[2] - previous[2]) / period_s
            gain = self.config.tracking_gain_per_s * period_s
            limit_v, limit_w = self.config.max_correction
            self._correction[0] = max(
                -limit_v, min(limit_v, self._correction[0] + gain * (self.command[0] - speed))
            )
            self._correction[1] = max(
                -limit_w, min(limit_w, self._correction[1] + gain * (self.command[1] - rate))
            )
        return previous, current


def spawn_robot(
    client_id: int,
    robot_id: str,
    index: int,
    *,
    group: int,
    start_xy_yaw: tuple[float, float, float],
    config: RobotConfig,
    description: RobotDescription,
    urdf: Path,
) -> Robot:
    """Load ``urdf`` standing on the ground at ``start_xy_yaw``: a ground robot on its wheels with drive,
    friction and torque set; a crane (``description.crane``) on a fixed base with its joints parked."""
    if not urdf.is_file():
        raise InputError(f"robot URDF {urdf} not found")
    x, y, yaw = start_xy_yaw
    crane = description.crane
    with quiet_stdout(), _as_erected(urdf, description) as loaded:  # loaded facing +x at the origin to
        body_id = p.loadURDF(  # measure it, then moved to its start
            str(loaded),
            [0.0, 0.0, 0.0],
            useFixedBase=description.can(Capability.STAND_FIXED),
            flags=p.URDF_USE_IMPLICIT_CYLINDER,
            physicsClientId=client_id,
        )
    if body_id < 0:
        raise InputError(f"pybullet could not load the robot URDF {urdf}")
    info = p.getDynamicsInfo(body_id, -1, physicsClientId=client_id)
    base_inertial: Frame = (tuple(info[3]), tuple(info[4]))
    links = range(-1, p.getNumJoints(body_id, physicsClientId=client_id))
    with_shapes = [
        link for link in links if p.getCollisionShapeData(body_id, link, physicsClientId=client_id)
    ]
    boxes = [p.getAABB(body_id, link, physicsClientId=client_id) for link in with_shapes] or [
        ((0, 0, 0), (0, 0, 0))
    ]
    bottom = min(box[0][2] for box in boxes)
    top = max(box[1][2] for box in boxes)
    half_x = max(max(abs(box[0][0]), abs(box[1][0])) for box in boxes)
    half_y = max(max(abs(box[0][1]), abs(box[1][1])) for box in boxes)
    base_frame = ((x, y, -bottom), yaw_quat(yaw))  # wheels (or footing) touching the ground
    com = compose(base_frame, base_inertial)
    p.resetBasePositionAndOrientation(body_id, com[0], com[1], physicsClientId=client_id)
    drive: DriveGeometry | None = None
    torque = 0.0
    rig: CraneRig | None = None
    if description.can(Capability.STAND_FIXED):  # on the ground for good: no contacts with it to compute
        set_filter(client_id, body_id, group, ALL_GROUPS ^ group ^ GROUND_GROUP ^ PIT_EDGE_GROUP, links)
        if crane is not None:  # a hook's slew, trolley and hoist joints
            rig = CraneRig(client_id, body_id, crane, name=description.name)
    else:
        drive = detect_drive(client_id, body_id, base_frame, config.wheel_joints)
        mass = sum(p.getDynamicsInfo(body_id, link, physicsClientId=client_id)[0] for link in links)
        wheels = len(drive.left) + len(drive.right)
        torque = wheel_torque_nm(config.wheel_torque_nm, mass, drive.wheel_radius_m, wheels)
        for wheel_set in (drive.left, drive.right):
            for joint, _ in wheel_set:
                p.changeDynamics(
                    body_id,
                    joint,
                    anisotropicFriction=_axle_friction(
                        client_id, body_id, joint, config.wheel_lateral_friction_ratio
                    ),
                    physicsClientId=client_id,
                )
        # not with its own load, nor the pits' rims (the ground plane carries robots over the pits)
        set_filter(client_id, body_id, group, ALL_GROUPS ^ group ^ PIT_EDGE_GROUP, links)
    robot = Robot(
        robot_id=robot_id,
        index=index,
        body_id=body_id,
        group=group,
        drive=drive,
        config=config,
        description=description,
        start_xy_yaw=start_xy_yaw,
        top_height_m=top,
        base_height_m=-bottom,
        half_extents_xy_m=(half_x, half_y),
        base_inertial=base_inertial,
        wheel_torque_nm=torque,
        rig=rig,
    )
    robot._last_xy_yaw = (x, y, yaw)
    if drive is not None:
        _log.debug(
            "robot %s (%s): wheels L%s R%s radius %.3f m track %.3f m torque %.0f N·m top %.3f m",
            robot_id,
            description.name,
            [j for j, _ in drive.left],
            [j for j, _ in drive.right],
            drive.wheel_radius_m,
            drive.track_m,
            torque,
            robot.top_height_m,
        )
    return robot


@contextlib.contextmanager
def _as_erected(urdf: Path, description: RobotDescription) -> Iterator[Path]:
    """``urdf`` as pybullet should load it: a crane the site erected taller than its file draws it
    (``crane.mast_raised_m``, :mod:`bimbot.shared.crane_erection`) from a copy with its mast stretched
    (:mod:`bimbot.shared.crane_mast`), removed once loaded; any other robot from the file itself."""
    raised_m = description.crane.mast_raised_m if description.crane is not None else 0.0
    if raised_m <= 0.0:
        yield urdf
        return
    stretched = raised_mast_urdf(urdf.read_bytes(), raised_m, source=urdf)
    with tempfile.TemporaryDirectory(prefix="bimbot-crane-") as folder:
        copy = Path(folder) / urdf.name
        copy.write_bytes(stretched)
        yield copy
