"""The hand-written frame maths of the physics step loop (kept for speed, see scene.py) agree with scipy."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from bimbot.services.physics.scene import compose, invert, quat_multiply, rotate, yaw_of

RNG = np.random.default_rng(11)
ROTATIONS = Rotation.random(50, rng=RNG)
POINTS = RNG.uniform(-5.0, 5.0, size=(50, 3))


def _same_rotation(quat_xyzw: tuple[float, ...], expected: Rotation) -> None:
    assert (Rotation.from_quat(quat_xyzw) * expected.inv()).magnitude() == pytest.approx(0.0, abs=1e-12)


def test_quat_multiply_and_rotate_are_scipys_product_and_apply() -> None:
    for a, b, v in zip(ROTATIONS, ROTATIONS[::-1], POINTS, strict=True):
        _same_rotation(quat_multiply(tuple(a.as_quat()), tuple(b.as_quat())), a * b)
        assert rotate(tuple(a.as_quat()), tuple(v)) == pytest.approx(a.apply(v), abs=1e-12)


def test_compose_and_invert_are_scipys_rigid_transforms() -> None:
    for a, b, pa, pb in zip(ROTATIONS, ROTATIONS[::-1], POINTS, POINTS[::-1], strict=True):
        position, quat = compose((tuple(pa), tuple(a.as_quat())), (tuple(pb), tuple(b.as_quat())))
        assert position == pytest.approx(pa + a.apply(pb), abs=1e-12)
        _same_rotation(quat, a * b)
        back_position, back_quat = invert((tuple(pa), tuple(a.as_quat())))
        assert back_position == pytest.approx(-a.inv().apply(pa), abs=1e-12)
        _same_rotation(back_quat, a.inv())


def test_yaw_of_is_scipys_z_of_the_zyx_euler_angles() -> None:
    for rotation in ROTATIONS:
        assert yaw_of(tuple(rotation.as_quat())) == pytest.approx(rotation.as_euler("ZYX")[0], abs=1e-9)
