"""Element placements (4×4 matrices, metres) → SDF poses in the simulation world frame.

The simulation world frame is the IFC world frame moved by a *local origin*: when a model sits far from
the IFC origin (georeferenced coordinates, ``large_offset.ifc``), single-precision physics would lose
millimetres, so :func:`choose_local_origin` picks a round origin near the model and every pose is
expressed relative to it; the manifest records the origin so nothing is lost.

SDF's ``<pose>`` is ``x y z roll pitch yaw`` with fixed-axis (extrinsic) x-y-z angles, i.e.
``R = Rz(yaw) · Ry(pitch) · Rx(roll)``, which is scipy's lower-case ``"xyz"`` convention. The conversions
are scipy's own algorithms (``Rotation.from_matrix``, ``as_euler``, ``as_matrix``) written out for one
rotation in numpy: importing ``scipy.spatial.transform`` costs ~0.3 s of every ``bimbot convert``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import ifcopenshell
import ifcopenshell.util.placement
import numpy as np

from bimbot.shared.manifest import Pose, Quat, Vec3

FAR_FROM_ORIGIN_M = 1000.0
ORTHONORMAL_TOLERANCE = 1e-9
GIMBAL_LOCK_RAD = 1e-7  # pitch within this of ±90°: roll and yaw are not unique (scipy's threshold)


@dataclass(frozen=True)
class RigidPlacement:
    """A placement split into its rigid part and what remains (scale/shear/mirror) to bake into the mesh."""

    rotation: np.ndarray  # (3, 3) proper rotation
    translation_m: np.ndarray  # (3,)
    residual: np.ndarray | None  # (3, 3) linear part to apply to local vertices, or None when rigid


def split_rigid(matrix: np.ndarray) -> RigidPlacement:
    """Split ``matrix`` (4×4) as ``T·R·S``: rigid ``T·R`` and a residual ``S`` (None when rigid)."""
    linear = np.asarray(matrix, dtype=float)[:3, :3]
    translation = np.asarray(matrix, dtype=float)[:3, 3].copy()
    if np.allclose(linear.T @ linear, np.eye(3), atol=ORTHONORMAL_TOLERANCE) and np.linalg.det(linear) > 0:
        return RigidPlacement(linear.copy(), translation, None)
    u, _, vt = np.linalg.svd(linear)
    rotation = u @ vt
    if np.linalg.det(rotation) < 0:  # mirrored placement: keep a proper rotation, mirror the mesh instead
        u[:, -1] *= -1
        rotation = u @ vt
    return RigidPlacement(rotation, translation, rotation.T @ linear)


def pose_from_rigid(rotation: np.ndarray, translation_m: np.ndarray, local_origin_m: np.ndarray) -> Pose:
    position = np.asarray(translation_m, dtype=float) - np.asarray(local_origin_m, dtype=float)
    quat = quat_from_matrix(rotation)  # x, y, z, w
    rpy = rpy_from_quat(quat)
    if quat[3] < 0:
        quat = -quat
    return Pose(position_m=vec3(position), quat_xyzw=quat_xyzw(quat), rpy_rad=vec3(rpy))


def vec3(values: Iterable[float]) -> Vec3:
    """The three values (an array of length 3) as a tuple of plain floats, for the manifest."""
    x, y, z = (float(v) for v in values)
    return x, y, z


def quat_xyzw(values: Iterable[float]) -> Quat:
    """The four values of a quaternion (x, y, z, w) as a tuple of plain floats, for the manifest."""
    x, y, z, w = (float(v) for v in values)
    return x, y, z, w


def quat_from_matrix(rotation: np.ndarray) -> np.ndarray:
    """Unit quaternion (x, y, z, w) of a rotation matrix (scipy's ``from_matrix``: a matrix that is not
    orthonormal to 1e-12 is first replaced by its nearest rotation)."""
    matrix = np.asarray(rotation, dtype=float)
    if not np.allclose(matrix @ matrix.T, np.eye(3), rtol=1e-5, atol=1e-12):
        u, _, vt = np.linalg.svd(matrix)
        matrix = u @ vt
    trace = matrix[0, 0] + matrix[1, 1] + matrix[2, 2]
    choice = int(np.argmax([matrix[0, 0], matrix[1, 1], matrix[2, 2], trace]))
    if choice == 3:
        quat = [
            matrix[2, 1] - matrix[1, 2],
            matrix[0, 2] - matrix[2, 0],
            matrix[1, 0] - matrix[0, 1],
            1 + trace,
        ]
    else:
        i, j, k = choice, (choice + 1) % 3, (choice + 2) % 3
        quat = [0.0, 0.0, 0.0, 0.0]
        quat[i] = 1 - trace + 2 * matrix[i, i]
        quat[j] = matrix[j, i] + matrix[i, j]
        quat[k] = matrix[k, i] + matrix[i, k]
        quat[3] = matrix[k, j] - matrix[j, k]
    result = np.array(quat, dtype=float)
    return result / math.sqrt(sum(float(v) * float(v) for v in result))


def rpy_from_quat(quat_xyzw: np.ndarray) -> np.ndarray:
    """Roll, pitch, yaw (extrinsic x-y-z, radians) of a unit quaternion, by scipy's ``as_euler("xyz")``
    algorithm (Bernardes & Viollet); at pitch ±90° (gimbal lock) yaw is set to 0."""
    x, y, z, w = (float(v) for v in quat_xyzw)
    # extrinsic x, y, z: axes i=0, j=1, k=2, not symmetric, sign = +1; libm's atan2 (math), as scipy's
    # compiled code uses: numpy's differs in the last bit, which turns a yaw of π into -π
    a, b, c, d = w - y, x + z, y + w, z - x
    half_sum, half_diff = math.atan2(b, a), math.atan2(d, c)
    pitch = 2.0 * math.atan2(math.hypot(c, d), math.hypot(a, b))
    if abs(pitch) <= GIMBAL_LOCK_RAD:
        roll, yaw = 2.0 * half_sum, 0.0
    elif abs(pitch - math.pi) <= GIMBAL_LOCK_RAD:
        roll, yaw = -2.0 * half_diff, 0.0
    else:
        roll, yaw = half_sum - half_diff, half_sum + half_diff
    angles = np.array([roll, pitch - math.pi / 2.0, yaw])
    angles[angles < -math.pi] += 2.0 * math.pi  # into [-π, π], keeping π as π (as scipy does)
    angles[angles > math.pi] -= 2.0 * math.pi
    return angles


def matrix_from_quat(quat_xyzw: Iterable[float]) -> np.ndarray:
    """3×3 rotation matrix of a quaternion (x, y, z, w), normalised first (scipy's ``as_matrix``)."""
    x, y, z, w = np.asarray(list(quat_xyzw), dtype=float) / np.linalg.norm(list(quat_xyzw))
    return np.array(
        [
            [x * x - y * y - z * z + w * w, 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), -x * x + y * y - z * z + w * w, 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), -x * x - y * y + z * z + w * w],
        ]
    )


def pose_matrix(pose: Pose) -> np.ndarray:
    """4×4 matrix of a pose (from its quaternion)."""
    matrix = np.eye(4)
    matrix[:3, :3] = matrix_from_quat(pose.quat_xyzw)
    matrix[:3, 3] = pose.position_m
    return matrix


def in_pose_frame(pose: Pose, points_world_m: np.ndarray) -> np.ndarray:
    """``points_world_m`` ``(n, 3)`` in the frame of ``pose`` (a component's target: its own box's frame)."""
    return (np.asarray(points_world_m, dtype=float) - np.asarray(pose.position_m)) @ matrix_from_quat(
        pose.quat_xyzw
    )


def axis2placement_matrix(placement: ifcopenshell.entity_instance) -> np.ndarray:
    """4×4 matrix of an IfcAxis2Placement (IFC length units): ifcopenshell's ``get_axis2placement``, except
    that a 2D placement's direction is widened without ``ndarray.resize``, which refuses to run (and failed
    the element) whenever a profiler or tracer holds a reference to the array."""
    if placement.is_a("IfcAxis2Placement2D"):
        ref = placement.RefDirection
        x = np.array((*ref.DirectionRatios[:2], 0.0)) if ref is not None else np.array((1.0, 0.0, 0.0))
        origin = (*placement.Location.Coordinates, 0.0)
        return np.asarray(ifcopenshell.util.placement.a2p(origin, np.array((0, 0, 1)), x), dtype=float)
    return np.asarray(ifcopenshell.util.placement.get_axis2placement(placement), dtype=float)


def choose_local_origin(points_world_m: np.ndarray, far_m: float = FAR_FROM_ORIGIN_M) -> np.ndarray:
    """A local origin for the model: zero near the IFC origin; else the rounded centre of the points.

    Per axis: if the centre of the model's extent is farther than ``far_m`` from zero, the origin on that
    axis is the centre rounded to whole metres (for z, the lowest point rounded down, so the model stays
    above the ground plane at z = 0 as it was meant to).
    """
    points = np.asarray(points_world_m, dtype=float).reshape(-1, 3)
    if len(points) == 0:
        return np.zeros(3)
    low, high = points.min(axis=0), points.max(axis=0)
    centre = (low + high) / 2.0
    origin = np.zeros(3)
    for axis in (0, 1):
        if abs(centre[axis]) > far_m:
            origin[axis] = float(np.round(centre[axis]))
    if abs(centre[2]) > far_m:
        origin[2] = float(np.floor(low[2]))
    return origin


def sdf_pose_text(pose: Pose) -> str:
    """``x y z roll pitch yaw`` with enough digits to round-trip doubles."""
    return " ".join(repr(float(v)) for v in (*pose.position_m, *pose.rpy_rad))
