"""Where a placement really puts a component: the robot's belief about itself carried into the world, and
the hand's precision turning the component about its centre (not about a frame origin far from it)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bimbot.services.physics.placement_error import guided_yaw_std_rad, physical_placement
from bimbot.services.physics.scene import Frame, rotate
from bimbot.shared.manifest import Manifest

REVIT_CENTRE = (-17.1, 101.3, 1.6)  # a Revit column's centre in its frame: the frame sits at the model origin


def _centre(frame: Frame, centre_local: tuple[float, float, float]) -> np.ndarray:
    return np.asarray(frame[0]) + np.asarray(rotate(frame[1], centre_local))


def _yaw(frame: Frame) -> float:
    x, y, z, w = frame[1]
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def test_the_hands_turn_is_about_the_components_centre_so_a_far_frame_origin_does_not_swing_it() -> None:
    commanded: Frame = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
    rng = np.random.default_rng(3)
    placed = physical_placement(
        commanded,
        None,
        (0.0, 0.0, 0.0),
        precision_m=0.0,
        precision_yaw_rad=math.radians(0.2),
        rng=rng,
        centre_local_m=REVIT_CENTRE,
    )
    assert abs(_yaw(placed)) > 1e-4, "the hand turned it"
    moved = np.linalg.norm(_centre(placed, REVIT_CENTRE) - _centre(commanded, REVIT_CENTRE))
    assert moved == pytest.approx(0.0, abs=1e-9), "about its centre: the centre stays where it was set"
    assert math.dist(placed[0], commanded[0]) > 0.01, "the far frame origin moves instead"


def test_a_robot_that_believes_itself_3_cm_east_places_3_cm_west() -> None:
    target: Frame = ((20.0, 5.0, 0.5), (0.0, 0.0, 0.0, 1.0))
    placed = physical_placement(
        target,
        (10.03, 5.0, 0.0),  # where it believes it stands
        (10.0, 5.0, 0.0),  # where it stands
        precision_m=0.0,
        precision_yaw_rad=0.0,
        rng=np.random.default_rng(0),
        centre_local_m=REVIT_CENTRE,
    )
    assert placed[0] == pytest.approx((19.97, 5.0, 0.5))
    assert _yaw(placed) == pytest.approx(0.0, abs=1e-12)


def test_a_guided_long_loads_ends_land_within_the_precision_a_free_turn_swings_them_cm() -> None:
    # a 30 m beam hung from a crane (0.2° free turn, 4 mm precision): each end is guided onto its seat
    half_span_m, precision_m, free_rad = 15.0, 0.004, math.radians(0.2)
    guided_rad = guided_yaw_std_rad(free_rad, precision_m, half_span_m)
    assert half_span_m * math.tan(free_rad) > 0.05, "free, an end swings 52 mm (1σ)"
    assert half_span_m * math.tan(guided_rad) == pytest.approx(precision_m), "guided, it lands within 4 mm"
    assert guided_yaw_std_rad(free_rad, precision_m, 0.5) == free_rad, "a short load keeps the hook's turn"
    ends = [
        half_span_m
        * abs(
            _yaw(
                physical_placement(
                    ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)),
                    None,
                    (0.0, 0.0, 0.0),
                    precision_m=0.0,
                    precision_yaw_rad=guided_rad,
                    rng=np.random.default_rng(seed),
                )
            )
        )
        for seed in range(200)
    ]
    assert float(np.percentile(ends, 95)) < 3 * precision_m


def test_a_components_placement_error_is_drawn_for_it_and_its_attempt_whoever_placed_what_before(
    frame_manifest: Manifest,
) -> None:
    """Common random numbers: the same component's first (second…) placement draws the same standard
    errors whatever its robot placed before, so two fleets or two orders differ by what they do, not by
    re-rolled errors (a per-robot stream re-rolled every later draw of the Janesville restaurant when its
    robots were assigned other tasks). The error scales with the placing type's precision."""
    from types import SimpleNamespace

    from bimbot.services.physics.placing import Placing
    from bimbot.shared.robot_description import DEFAULT_ROBOT

    first, second, *_ = frame_manifest.components
    commanded = ((1.0, 2.0, 0.5), (0.0, 0.0, 0.0, 1.0))

    def robot(precision_scale: float) -> SimpleNamespace:
        description = DEFAULT_ROBOT.model_copy(
            update={
                "placement_precision_m": 0.004 * precision_scale,
                "placement_precision_yaw_deg": 0.2 * precision_scale,
                "placement_guided_ends": False,
            }
        )
        return SimpleNamespace(
            description=description, drives=False, pose_xy_yaw=lambda _cid: (0.0, 0.0, 0.0)
        )

    def offset(frame: Frame) -> np.ndarray:
        return np.asarray(frame[0]) - np.asarray(commanded[0])

    alone = Placing(SimpleNamespace(client_id=0), None, seed=3)  # type: ignore[arg-type]
    after_another = Placing(SimpleNamespace(client_id=0), None, seed=3)  # type: ignore[arg-type]
    after_another._where_it_goes(robot(1.0), commanded, None, second)  # its robot placed another before
    drawn = offset(alone._where_it_goes(robot(1.0), commanded, None, first))
    assert np.allclose(drawn, offset(after_another._where_it_goes(robot(1.0), commanded, None, first)))
    assert np.abs(drawn[:2]).max() > 0.0
    again = offset(alone._where_it_goes(robot(1.0), commanded, None, first))  # its second attempt
    assert not np.allclose(again, drawn)
    coarse = Placing(SimpleNamespace(client_id=0), None, seed=3)  # type: ignore[arg-type]
    assert np.allclose(offset(coarse._where_it_goes(robot(2.0), commanded, None, first))[:2], 2.0 * drawn[:2])
