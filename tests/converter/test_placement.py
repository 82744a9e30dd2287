"""Placement matrices → SDF poses: rigid split, roll-pitch-yaw convention, local origin for far models."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from bimbot.services.converter.placement import choose_local_origin, pose_from_rigid, pose_matrix, split_rigid


def _matrix(rpy: tuple[float, float, float], xyz: tuple[float, float, float]) -> np.ndarray:
    matrix = np.eye(4)
    matrix[:3, :3] = Rotation.from_euler("xyz", rpy).as_matrix()
    matrix[:3, 3] = xyz
    return matrix


def _sdf_rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """SDF's definition, written out: R = Rz(yaw) · Ry(pitch) · Rx(roll)."""
    cr, sr, cp, sp, cy, sy = (
        np.cos(roll),
        np.sin(roll),
        np.cos(pitch),
        np.sin(pitch),
        np.cos(yaw),
        np.sin(yaw),
    )
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


@pytest.mark.parametrize(
    "rpy", [(0.0, 0.0, np.pi / 2), (0.3, -0.4, 2.5), (np.pi / 2, 0.0, 0.0), (0.1, 1.2, -3.0)]
)
def test_pose_rpy_follows_sdf_convention_and_quaternion_agrees(rpy: tuple[float, float, float]) -> None:
    matrix = _matrix(rpy, (1.0, -2.0, 3.5))
    rigid = split_rigid(matrix)
    assert rigid.residual is None
    pose = pose_from_rigid(rigid.rotation, rigid.translation_m, np.zeros(3))
    np.testing.assert_allclose(_sdf_rpy_matrix(*pose.rpy_rad), matrix[:3, :3], atol=1e-12)
    np.testing.assert_allclose(pose_matrix(pose), matrix, atol=1e-12)
    assert pose.position_m == (1.0, -2.0, 3.5)
    assert pose.quat_xyzw[3] >= 0


def test_local_origin_is_subtracted_from_the_position() -> None:
    pose = pose_from_rigid(
        np.eye(3), np.array([500_010.25, 4_000_020.5, 3.0]), np.array([500_000.0, 4_000_000.0, 0.0])
    )
    assert pose.position_m == pytest.approx((10.25, 20.5, 3.0))


def test_scaled_placement_is_split_into_rotation_and_residual() -> None:
    matrix = _matrix((0.0, 0.0, 0.7), (1.0, 2.0, 3.0))
    matrix[:3, :3] = matrix[:3, :3] @ np.diag([2.0, 1.0, 1.0])
    rigid = split_rigid(matrix)
    assert rigid.residual is not None
    np.testing.assert_allclose(rigid.rotation @ rigid.residual, matrix[:3, :3], atol=1e-12)
    assert np.linalg.det(rigid.rotation) == pytest.approx(1.0)


def test_mirrored_placement_keeps_a_proper_rotation() -> None:
    matrix = np.diag([-1.0, 1.0, 1.0, 1.0])
    rigid = split_rigid(matrix)
    assert np.linalg.det(rigid.rotation) == pytest.approx(1.0)
    np.testing.assert_allclose(rigid.rotation @ rigid.residual, matrix[:3, :3], atol=1e-12)


def test_model_near_origin_keeps_the_ifc_origin() -> None:
    points = np.array([[-20.0, -5.0, -1.0], [30.0, 40.0, 12.0]])
    np.testing.assert_array_equal(choose_local_origin(points), np.zeros(3))


def test_model_far_from_origin_gets_a_round_local_origin_near_it() -> None:
    points = np.array([[458_650.2, 5_438_220.7, 113.0], [458_670.9, 5_438_245.1, 125.0]])
    origin = choose_local_origin(points)
    assert origin[2] == 0.0  # heights of ~100 m are fine in float32 at mm resolution
    assert np.all(origin[:2] == np.round(origin[:2]))
    assert np.all(np.abs((points - origin)[:, :2]) < 50.0)


def test_gimbal_lock_pose_still_reproduces_the_rotation_without_warning(
    recwarn: pytest.WarningsRecorder,
) -> None:
    matrix = _matrix((0.4, np.pi / 2, 0.0), (0.0, 0.0, 0.0))
    pose = pose_from_rigid(matrix[:3, :3], matrix[:3, 3], np.zeros(3))
    np.testing.assert_allclose(_sdf_rpy_matrix(*pose.rpy_rad), matrix[:3, :3], atol=1e-9)
    assert not [w for w in recwarn if issubclass(w.category, UserWarning)]
