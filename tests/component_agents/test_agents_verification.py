"""Self-verification: position and angle errors against the BIM target, with explicit tolerances."""

from __future__ import annotations

import math

import numpy as np
import pytest
from agent_builders import quat_z
from scipy.spatial.transform import Rotation

from bimbot.shared.messages import PoseMsg
from bimbot.shared.verification import (
    Tolerances,
    angle_error_rad,
    is_valid_pose,
    position_error_m,
    verify,
)


def pose(position: tuple[float, float, float], quat: tuple[float, float, float, float]) -> PoseMsg:
    return PoseMsg(position_m=position, quat_xyzw=quat)


def quat_x(angle_rad: float) -> tuple[float, float, float, float]:
    return (math.sin(angle_rad / 2), 0.0, 0.0, math.cos(angle_rad / 2))


def test_position_error_is_the_euclidean_distance_in_metres() -> None:
    assert position_error_m((1.0, 2.0, 3.0), (1.003, 2.004, 3.0)) == pytest.approx(0.005)
    assert position_error_m((0.0, 0.0, 0.0), (0.0, 0.0, 0.0)) == 0.0


@pytest.mark.parametrize("angle", [1e-7, 1e-4, math.radians(1.0), 0.5, 2.0, math.pi])
def test_angle_error_is_the_rotation_angle_between_orientations(angle: float) -> None:
    assert angle_error_rad(quat_z(0.2 + angle), quat_z(0.2)) == pytest.approx(angle, rel=1e-9, abs=1e-15)
    assert angle_error_rad(quat_x(angle), (0.0, 0.0, 0.0, 1.0)) == pytest.approx(angle, rel=1e-9, abs=1e-15)


def test_angle_error_ignores_the_quaternion_sign() -> None:
    q = quat_z(0.7)
    minus_q = tuple(-c for c in q)
    assert angle_error_rad(minus_q, q) == pytest.approx(0.0, abs=1e-12)
    assert angle_error_rad(tuple(-c for c in quat_z(0.7 + 0.01)), q) == pytest.approx(0.01, rel=1e-9)


def test_angle_error_takes_the_short_way_round() -> None:
    # 350° about Z is 10° away from 0°, not 350°.
    assert angle_error_rad(quat_z(math.radians(350)), quat_z(0.0)) == pytest.approx(math.radians(10))


def test_angle_error_normalises_quaternions() -> None:
    q = quat_z(0.3)
    assert angle_error_rad(tuple(5 * c for c in q), q) == pytest.approx(0.0, abs=1e-12)


def test_degenerate_quaternions_are_refused() -> None:
    with pytest.raises(ValueError, match="no orientation"):
        angle_error_rad((0.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
    assert not is_valid_pose((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 0.0))
    assert not is_valid_pose((math.nan, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
    assert not is_valid_pose((0.0, 0.0, 0.0), (math.inf, 0.0, 0.0, 1.0))
    assert is_valid_pose((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 2.0))


def test_default_tolerances_are_one_centimetre_and_one_degree() -> None:
    assert Tolerances() == Tolerances(position_m=0.01, angle_rad=math.radians(1.0))


def test_verify_accepts_both_errors_within_tolerance_inclusive() -> None:
    tol = Tolerances(position_m=0.01, angle_rad=0.02)
    target = pose((1.0, 2.0, 3.0), quat_z(0.5))
    verdict = verify(pose((1.0, 2.0, 3.0 + 0.01), quat_z(0.5 + 0.02 * (1 - 1e-9))), target, tol)
    assert verdict.ok
    assert verdict.position_error_m == pytest.approx(0.01)
    assert verdict.angle_error_rad == pytest.approx(0.02)


@pytest.mark.parametrize(
    ("offset_m", "yaw_rad"), [((0.0101, 0.0, 0.0), 0.0), ((0.0, 0.0, 0.0), 0.0201), ((0.02, 0.0, 0.0), 0.05)]
)
def test_verify_rejects_position_or_angle_beyond_tolerance(
    offset_m: tuple[float, float, float], yaw_rad: float
) -> None:
    tol = Tolerances(position_m=0.01, angle_rad=0.02)
    target = pose((1.0, 2.0, 3.0), quat_z(0.5))
    current = pose(
        tuple(a + b for a, b in zip((1.0, 2.0, 3.0), offset_m, strict=True)), quat_z(0.5 + yaw_rad)
    )
    verdict = verify(current, target, tol)
    assert not verdict.ok
    assert verdict.position_error_m == pytest.approx(math.hypot(*offset_m))
    assert verdict.angle_error_rad == pytest.approx(yaw_rad)


@pytest.mark.parametrize(
    ("position_m", "angle_rad"), [(-0.001, 0.01), (0.01, -1.0), (math.nan, 0.01), (0.01, math.inf)]
)
def test_tolerances_must_be_finite_and_not_negative(position_m: float, angle_rad: float) -> None:
    with pytest.raises(ValueError, match="tolerance"):
        Tolerances(position_m=position_m, angle_rad=angle_rad)


def test_angle_error_matches_scipy_rotation_magnitude() -> None:
    """The hand-written quaternion product (kept so the agents' process does not load scipy) is scipy's."""
    rng = np.random.default_rng(7)
    for current, target in zip(Rotation.random(200, rng=rng), Rotation.random(200, rng=rng), strict=True):
        expected = (target.inv() * current).magnitude()
        got = angle_error_rad(tuple(current.as_quat()), tuple(-target.as_quat()))
        assert got == pytest.approx(expected, rel=1e-9, abs=1e-12)


def test_the_position_error_is_the_components_centre_not_its_frame_origin_far_from_it() -> None:
    """A Revit element whose frame sits at the model origin, 100 m from its geometry (the structural hub's
    concrete columns): turned by 0.01° about its centre it is where it should be, although the frame origin
    moved 17 mm; shifted by 5 mm it is 5 mm off; tipped over, its centre — not the origin 100 m away —
    says how far."""
    centre_local = (-17.1, 101.3, 1.6)
    target = PoseMsg(position_m=(0.0, 0.0, 0.0), quat_xyzw=(0.0, 0.0, 0.0, 1.0))
    tolerances = Tolerances()

    def about_centre(rotation: Rotation, shift_m: tuple[float, float, float]) -> PoseMsg:
        origin = np.asarray(centre_local) - rotation.apply(centre_local) + np.asarray(shift_m)
        return PoseMsg(position_m=tuple(origin), quat_xyzw=tuple(rotation.as_quat()))

    turned = about_centre(Rotation.from_euler("z", 0.01, degrees=True), (0.0, 0.0, 0.0))
    assert position_error_m(turned.position_m, target.position_m) > 0.017, "the frame origin moved"
    check = verify(turned, target, tolerances, reference_local_m=centre_local)
    assert check.ok and check.position_error_m == pytest.approx(0.0, abs=1e-9)
    shifted = about_centre(Rotation.identity(), (0.003, 0.004, 0.0))
    assert verify(
        shifted, target, tolerances, reference_local_m=centre_local
    ).position_error_m == pytest.approx(0.005)
    tipped = about_centre(Rotation.from_euler("x", 90.0, degrees=True), (0.0, 0.0, 0.0))
    check = verify(tipped, target, tolerances, reference_local_m=centre_local)
    assert not check.ok and check.position_error_m == pytest.approx(0.0, abs=1e-9)
    assert check.angle_error_rad == pytest.approx(math.pi / 2), "the tolerance on the angle catches it"
