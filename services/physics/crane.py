"""A tower crane's kinematics: where its hook must be for a load, as joint values (pure, no pybullet).

Why: physics moves a crane's load itself (:mod:`.handling`), and shows the crane doing it by setting its
joints so that the hook hangs above the load: every viewer (pybullet's GUI, the observer through
``RobotPoseMsg.joint_positions``) then sees the crane lift and place it. The crane's URDF
(``shared/robots/tower_crane.urdf``) has three joints:

* ``slew`` — rad, about the mast, relative to the crane base's heading (0: the jib points along the base's
  +x axis), wrapped to [−π, π);
* ``trolley`` — m, the hook's horizontal radius from the mast axis, within the crane's smallest and largest
  hook radius (:class:`bimbot.shared.robot_description.CraneSpec`);
* ``hoist`` — m, the hook's drop below the jib, within 0 and the jib height.

A point the hook cannot reach gives the nearest joint values within those limits (the reach rule, not this
module, decides whether a crane may lift a load there).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

from bimbot.shared.geometry import wrap_angle
from bimbot.shared.robot_description import CraneSpec

SLEW, TROLLEY, HOIST = "slew", "trolley", "hoist"  # the URDF's joint names
JOINT_NAMES = (SLEW, TROLLEY, HOIST)


@dataclass(frozen=True)
class CraneJoints:
    """One set of crane joint values (rad, m, m)."""

    slew_rad: float
    trolley_m: float
    hoist_m: float

    def by_name(self) -> dict[str, float]:
        """Joint name → value, as ``RobotPoseMsg.joint_positions`` carries them."""
        return {SLEW: self.slew_rad, TROLLEY: self.trolley_m, HOIST: self.hoist_m}


def parked(spec: CraneSpec) -> CraneJoints:
    """An idle crane: jib along its heading, trolley innermost, hook up at the jib."""
    return CraneJoints(0.0, spec.min_radius_m, 0.0)


def hook_joints(
    crane_xy_yaw: tuple[float, float, float],
    hook_xyz_m: ArrayLike,
    spec: CraneSpec,
    jib_height_m: float | None = None,
) -> CraneJoints:
    """The joint values that put the hook's tip at ``hook_xyz_m`` (world, m), clamped to the joint limits.

    ``crane_xy_yaw`` is the crane base's pose on the ground; ``jib_height_m`` the hook's height at hoist 0
    (default: the spec's jib height; physics passes the height measured on the URDF, so the hook is drawn
    where the load is). Straight above the mast the bearing is undefined: slew 0."""
    x, y, yaw = crane_xy_yaw
    px, py, pz = (float(v) for v in np.asarray(hook_xyz_m, dtype=float)[:3])
    jib = spec.jib_height_m if jib_height_m is None else jib_height_m
    dx, dy = px - x, py - y
    radius = math.hypot(dx, dy)
    slew = wrap_angle(math.atan2(dy, dx) - yaw) if radius > 1e-9 else 0.0
    trolley = min(max(radius, spec.min_radius_m), spec.max_radius_m)
    hoist = min(max(jib - pz, 0.0), jib)
    return CraneJoints(float(slew), float(trolley), float(hoist))


def hook_position(
    crane_xy_yaw: tuple[float, float, float], joints: CraneJoints, jib_height_m: float
) -> tuple[float, float, float]:
    """Where the hook's tip is for ``joints`` (world, m): the inverse of :func:`hook_joints` within limits."""
    x, y, yaw = crane_xy_yaw
    heading = yaw + joints.slew_rad
    return (
        x + joints.trolley_m * math.cos(heading),
        y + joints.trolley_m * math.sin(heading),
        jib_height_m - joints.hoist_m,
    )


def load_box(
    bbox_min_m: ArrayLike, bbox_max_m: ArrayLike, position_m: ArrayLike, quat_xyzw: ArrayLike
) -> tuple[np.ndarray, np.ndarray]:
    """The world-aligned box (low, high corners, m) around a load posed at ``position_m``/``quat_xyzw``;
    ``bbox_*`` are its bounding box in its own frame."""
    low, high = np.asarray(bbox_min_m, dtype=float), np.asarray(bbox_max_m, dtype=float)
    corners = np.array(
        [[a, b, c] for a in (low[0], high[0]) for b in (low[1], high[1]) for c in (low[2], high[2])]
    )
    turn = Rotation.from_quat(np.asarray(quat_xyzw, dtype=float))
    world = turn.apply(corners) + np.asarray(position_m, dtype=float)
    return world.min(axis=0), world.max(axis=0)


def load_top(
    bbox_min_m: ArrayLike, bbox_max_m: ArrayLike, position_m: ArrayLike, quat_xyzw: ArrayLike
) -> tuple[float, float, float]:
    """Where a hook holds a load: the centre (x, y) and the top (z) of its posed box (world, m)."""
    low, high = load_box(bbox_min_m, bbox_max_m, position_m, quat_xyzw)
    return float(low[0] + high[0]) / 2.0, float(low[1] + high[1]) / 2.0, float(high[2])


def lift_position(
    start_m: ArrayLike, end_m: ArrayLike, fraction: float, peak_z_m: float
) -> tuple[float, float, float]:
    """Where a crane's load is at ``fraction`` of its lift from ``start_m`` to ``end_m``: hoisted straight
    up to ``peak_z_m``, carried across at that height, lowered straight onto the target; each leg takes
    its share of the time by its length (a straight line would drag the load across the ground). Plain
    floats: it runs for a lifted load after every physics step."""
    sx, sy, sz = _xyz(start_m)
    ex, ey, ez = _xyz(end_m)
    peak = max(peak_z_m, sz, ez)
    up, across, down = peak - sz, math.hypot(ex - sx, ey - sy), peak - ez
    total = up + across + down
    if total <= 0.0 or fraction >= 1.0:
        return ex, ey, ez
    travelled = max(0.0, fraction) * total
    if travelled <= up:
        return sx, sy, sz + travelled
    travelled -= up
    if travelled <= across and across > 0.0:
        share = travelled / across
        return sx + (ex - sx) * share, sy + (ey - sy) * share, peak
    travelled -= across
    return ex, ey, peak - min(travelled, down)


def _xyz(point: ArrayLike) -> tuple[float, float, float]:
    if isinstance(point, tuple) and len(point) == 3:  # the loop's own frames: no array needed
        return float(point[0]), float(point[1]), float(point[2])
    x, y, z = np.asarray(point, dtype=float)[:3]
    return float(x), float(y), float(z)
