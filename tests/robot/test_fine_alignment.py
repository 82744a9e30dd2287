"""Fine alignment before a placement: from a filter estimate centimetres and a degree off, the robot's pose
matched to the exact outlines its laser sees comes back to within a millimetre, never on to the far face of
a member a section's depth away; a scan that matches nothing is not trusted and leaves the estimate as it
was."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bimbot.services.robot.fine_alignment import align, facing, outline_edges


def _box(x0: float, y0: float, x1: float, y1: float) -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """A box's edges, counter-clockwise: the outside on each edge's right, as the site map gives them."""
    corners = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
    return [(corners[i], corners[(i + 1) % 4]) for i in range(4)]


def _fence(x0: float, y0: float, x1: float, y1: float, thick: float = 0.2) -> list:
    """Four walls ``thick`` deep outside the inner edge (:func:`bimbot.shared.site_plan.fence_boxes`)."""
    return (
        _box(x0 - thick, y0 - thick, x1 + thick, y0)
        + _box(x0 - thick, y1, x1 + thick, y1 + thick)
        + _box(x0 - thick, y0, x0, y1)
        + _box(x1, y0, x1 + thick, y1)
    )


SITE = np.array(
    _fence(-12.0, -9.0, 14.0, 11.0)
    + _box(-0.05, -0.05, 0.05, 0.05)  # columns of a frame, 0.1 m square
    + _box(2.95, -0.05, 3.05, 0.05)
    + _box(-0.05, 2.95, 0.05, 3.05)
    + _box(-6.0, -7.0, -2.0, -6.8)  # a beam lying in the yard
)
# The site of the clean-clone failure it was found in: a 0.1 m column standing, a 160 mm beam lying in the
# yard 3.5 m away, the fence 10 m and more away; the robot stands by the next column's footing to place it.
YARD = np.array(
    _fence(-13.7, -10.3, 22.63, 7.0) + _box(-0.05, -0.05, 0.05, 0.05) + _box(-0.66, -7.3, -0.5, -4.3)
)
BY_THE_FOOTING = (2.6, -0.9, 1.07)


def _scan(
    pose: tuple[float, float, float], site: np.ndarray = SITE, beams: int = 180, range_max: float = 15.0
) -> np.ndarray:
    """Hits (robot frame) of a noiseless 2D laser at ``pose`` against ``site``: the nearest crossing per
    beam."""
    x, y, yaw = pose
    hits = []
    for angle in np.linspace(-math.pi, math.pi, beams, endpoint=False):
        d = np.array([math.cos(yaw + angle), math.sin(yaw + angle)])
        best = range_max
        for (ax, ay), (bx, by) in site:
            e = np.array([bx - ax, by - ay])
            denominator = d[0] * (-e[1]) - d[1] * (-e[0])
            if abs(denominator) < 1e-12:
                continue
            w = np.array([ax - x, ay - y])
            t = (w[0] * (-e[1]) - w[1] * (-e[0])) / denominator
            u = (d[0] * w[1] - d[1] * w[0]) / denominator
            if 0.0 < t < best and 0.0 <= u <= 1.0:
                best = t
        if best < range_max:
            hits.append((best * math.cos(angle), best * math.sin(angle)))
    return np.array(hits)


@pytest.mark.parametrize("error", [(0.04, -0.03, math.radians(1.0)), (-0.12, 0.08, math.radians(-2.5))])
def test_an_estimate_centimetres_off_is_aligned_to_within_a_millimetre(
    error: tuple[float, float, float],
) -> None:
    truth = (1.2, -0.9, 0.4)
    hits = _scan(truth)
    estimate = np.add(truth, error)
    result = align(estimate, hits, SITE)
    assert result.trusted and result.hits > 100
    assert math.hypot(*(result.pose_xy_yaw[:2] - truth[:2])) < 0.001
    assert abs(result.pose_xy_yaw[2] - truth[2]) < math.radians(0.05)
    assert result.shift_m == pytest.approx(math.hypot(*error[:2]), abs=0.002)


def test_a_noisy_laser_leaves_a_millimetre_or_two() -> None:
    truth = (1.2, -0.9, 0.4)
    rng = np.random.default_rng(3)
    hits = _scan(truth)
    ranges = np.hypot(*hits.T)
    noisy = hits * ((ranges + rng.normal(0.0, 0.01, len(ranges))) / ranges)[:, None]  # 1 cm, 1 sigma
    result = align(np.add(truth, (0.03, 0.02, 0.01)), noisy, SITE)
    assert result.trusted and math.hypot(*(result.pose_xy_yaw[:2] - truth[:2])) < 0.003


def test_a_scan_that_matches_nothing_is_not_trusted_and_the_estimate_stands() -> None:
    estimate = np.array([1.2, -0.9, 0.4])
    far_off = _scan((1.2, -0.9, 0.4)) + np.array([0.0, 2.0])  # the map does not explain it
    result = align(estimate, far_off, SITE)
    assert not result.trusted and np.array_equal(result.pose_xy_yaw, estimate)
    assert not align(estimate, np.empty((0, 2)), SITE).trusted


def test_a_long_wall_whose_ends_are_out_of_range_still_aligns_the_robot() -> None:
    """A fence wall 100 m long passes 3 m from the robot though both its ends lie 50 m away."""
    corridor = np.array(
        [  # two walls, each given by its one face towards the robot (outside on the right)
            ((-50.0, 3.0), (50.0, 3.0)),
            ((50.0, -4.0), (-50.0, -4.0)),
            *_box(2.0, -0.5, 2.1, -0.4),
            *_box(-3.0, 1.0, -2.9, 1.1),
            *_box(6.0, -2.0, 6.5, -1.5),
        ]
    )
    truth = (0.3, 0.2, 0.1)
    result = align(np.add(truth, (0.03, -0.02, 0.01)), _scan(truth, corridor), corridor)
    assert result.trusted and math.hypot(*(result.pose_xy_yaw[:2] - truth[:2])) < 0.001


@pytest.mark.parametrize("error", [(-0.15, 0.0, 0.0), (-0.18, 0.05, 0.01), (0.12, -0.1, -0.02)])
def test_an_estimate_off_towards_a_far_face_is_not_aligned_on_to_it(
    error: tuple[float, float, float],
) -> None:
    """Matched against both faces of each outline, a scan of the near faces fitted the far ones a section's
    depth away (160 mm beam, 100 mm column, 0.2 m fence) with a sub-millimetre residual, trusted: a column
    was placed 161 mm off three times. Only the faces the robot can see are matched now."""
    hits = _scan(BY_THE_FOOTING, YARD, beams=360, range_max=10.0)
    result = align(np.add(BY_THE_FOOTING, error), hits, YARD)
    assert result.trusted
    assert math.hypot(*(result.pose_xy_yaw[:2] - BY_THE_FOOTING[:2])) < 0.001


def test_outline_edges_wind_counter_clockwise_and_only_faces_towards_a_point_are_seen() -> None:
    clockwise = np.array([(0.0, 0.0), (0.0, 1.0), (2.0, 1.0), (2.0, 0.0)])
    edges = outline_edges([clockwise, clockwise[::-1], np.array([(5.0, 5.0)])])
    assert len(edges) == 8 and np.array_equal(edges[:4], edges[4:])
    assert np.allclose(edges[0], [(2.0, 0.0), (2.0, 1.0)])  # counter-clockwise from the reversed start
    seen = edges[:4][facing(edges[:4], np.array([3.0, 0.5]))]
    assert np.allclose(seen, [[(2.0, 0.0), (2.0, 1.0)]])  # from the right: only the right-hand face
    assert facing(edges[:4], np.array([1.0, 0.5])).sum() == 0  # from inside: nothing
