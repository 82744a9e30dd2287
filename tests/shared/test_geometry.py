"""Angle wrapping: one definition for floats and arrays."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bimbot.shared.geometry import wrap_angle


@pytest.mark.parametrize(
    ("angle", "wrapped"),
    [
        (0.0, 0.0),
        (math.pi, -math.pi),
        (-math.pi, -math.pi),
        (3 * math.pi / 2, -math.pi / 2),
        (7.0, 7.0 - 2 * math.pi),
    ],
)
def test_a_float_is_wrapped_into_minus_pi_to_pi_and_stays_a_float(angle: float, wrapped: float) -> None:
    result = wrap_angle(angle)
    assert type(result) is float
    assert result == pytest.approx(wrapped, abs=1e-12)


def test_an_array_is_wrapped_element_wise_like_its_floats() -> None:
    angles = np.linspace(-20.0, 20.0, 401)
    result = wrap_angle(angles)
    assert isinstance(result, np.ndarray) and result.shape == angles.shape
    assert np.all((result >= -math.pi) & (result < math.pi))
    assert result == pytest.approx([wrap_angle(float(a)) for a in angles], abs=1e-12)
    assert np.allclose(np.cos(result), np.cos(angles)) and np.allclose(np.sin(result), np.sin(angles))
    assert isinstance(wrap_angle([0.0, 4.0]), np.ndarray)
