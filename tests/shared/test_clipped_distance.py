"""The clipped distance field kept current around changes equals the whole transform, cell for cell."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from bimbot.shared.clipped_distance import ClippedDistanceField

RESOLUTION_M = 0.05
BOUND_M = 0.4


def whole(occupied: np.ndarray) -> np.ndarray:
    if not occupied.any():
        return np.full(occupied.shape, BOUND_M)
    return np.minimum(ndimage.distance_transform_edt(~occupied, sampling=RESOLUTION_M), BOUND_M)


def test_random_local_changes_give_the_whole_transform_exactly() -> None:
    rng = np.random.default_rng(7)
    occupied = rng.random((120, 90)) < 0.01
    field = ClippedDistanceField(occupied.shape, RESOLUTION_M, BOUND_M, lambda r, c: occupied[r, c])
    assert np.array_equal(field.distance_m, whole(occupied))
    for round_number in range(40):
        changed = []
        for _ in range(rng.integers(1, 4)):  # a few boxes appear or vanish, anywhere, borders included
            r, c = int(rng.integers(0, 120)), int(rng.integers(0, 90))
            h, w = int(rng.integers(1, 12)), int(rng.integers(1, 12))
            occupied[r : r + h, c : c + w] = bool(round_number % 2)
            rr, cc = np.mgrid[r : min(120, r + h), c : min(90, c + w)]
            changed.append(np.stack([rr.ravel(), cc.ravel()], axis=1))
        for cells in changed:
            field.touch(cells)
        assert np.array_equal(field.distance_m, whole(occupied)), f"round {round_number}"


def test_an_untouched_change_is_not_seen_and_the_field_is_read_only() -> None:
    occupied = np.zeros((40, 40), bool)
    field = ClippedDistanceField(occupied.shape, RESOLUTION_M, BOUND_M, lambda r, c: occupied[r, c])
    assert (field.distance_m == BOUND_M).all(), "nothing occupied: everything at the bound"
    occupied[20, 20] = True
    assert (field.distance_m == BOUND_M).all(), "the owner did not say the cell changed"
    field.touch(np.array([[20, 20]]))
    assert field.distance_m[20, 20] == 0.0 and field.distance_m[20, 22] == pytest.approx(0.1)
    with pytest.raises(ValueError):
        field.distance_m[0, 0] = 1.0
