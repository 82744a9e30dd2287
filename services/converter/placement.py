"""Element placements (4×4 matrices, metres) → SDF poses in the simulation world frame.

The simulation world frame is the IFC world frame moved by a *local origin*: when a model sits far from
the IFC origin (georeferenced coordinates, ``large_offset.ifc``), single-precision physics would lose
millimetres, so :func:`choose_local_origin` picks a round origin near the model and every pose is
expressed relative to it; the manifest records the origin so nothing is lost.

SDF's ``<pose>`` is ``x y z roll pitch yaw`` with fixed-axis (extrinsic) x-y-z angles, i.e.
``R = Rz(yaw) · Ry(pitch) · Rx(roll)``, which is scipy's lower-case ``"xyz"`` convention.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from bimbot.shared.manifest import Pose, Quat, Vec3

FAR_FROM_ORIGIN_M = 1000.0
ORTHONORMAL_TOLERANCE = 1e-9


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
    rot = Rotation.from_matrix(rotation)
    position = np.asarray(translation_m, dtype=float) - np.asarray(local_origin_m, dtype=float)
    quat = rot.as_quat()  # x, y, z, w
    if quat[3] < 0:
        quat = -quat
    return Pose(position_m=vec3(position), quat_xyzw=quat_xyzw(quat), rpy_rad=vec3(_sdf_rpy(rot)))


def vec3(values: Iterable[float]) -> Vec3:
    """The three values (an array of length 3) as a tuple of plain floats, for the manifest."""
    x, y, z = (float(v) for v in values)
    return x, y, z


def quat_xyzw(values: Iterable[float]) -> Quat:
    """The four values of a quaternion (x, y, z, w) as a tuple of plain floats, for the manifest."""
    x, y, z, w = (float(v) for v in values)
    return x, y, z, w


def _sdf_rpy(rotation: Rotation) -> np.ndarray:
    """Roll-pitch-yaw; at pitch ±90° (gimbal lock) scipy sets yaw to 0 and warns: expected, so silenced."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return rotation.as_euler("xyz")


def pose_matrix(pose: Pose) -> np.ndarray:
    """4×4 matrix of a pose (from its quaternion)."""
    matrix = np.eye(4)
    matrix[:3, :3] = Rotation.from_quat(pose.quat_xyzw).as_matrix()
    matrix[:3, 3] = pose.position_m
    return matrix


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
