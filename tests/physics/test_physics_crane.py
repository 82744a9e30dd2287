"""Tower crane kinematics (pure): a world point → slew, trolley and hoist within the crane's limits, and
back; where a hook holds a posed load."""

from __future__ import annotations

import math

import pytest
from scipy.spatial.transform import Rotation

from bimbot.services.physics.crane import (
    CraneJoints,
    hook_joints,
    hook_position,
    load_box,
    load_top,
    parked,
)
from bimbot.shared.fleet import default_fleet

SPEC = default_fleet().types["tower_crane"].crane
assert SPEC is not None
CRANE = (10.0, 3.0, math.pi)  # east of a building, its jib's rest heading towards it (−x)


@pytest.mark.parametrize(
    ("point", "slew", "trolley", "hoist"),
    [
        ((0.0, 3.0, 3.32), 0.0, 10.0, SPEC.jib_height_m - 3.32),  # straight along its heading
        ((10.0, 23.0, 0.0), -math.pi / 2, 20.0, SPEC.jib_height_m),  # north: a quarter turn right of west
        ((10.0, -17.0, 5.0), math.pi / 2, 20.0, SPEC.jib_height_m - 5.0),  # south
        ((25.0, 3.0, 1.0), -math.pi, 15.0, SPEC.jib_height_m - 1.0),  # behind it: half a turn
    ],
)
def test_the_hook_goes_above_a_point_and_back(
    point: tuple[float, float, float], slew: float, trolley: float, hoist: float
) -> None:
    joints = hook_joints(CRANE, point, SPEC)
    assert (joints.slew_rad, joints.trolley_m, joints.hoist_m) == pytest.approx((slew, trolley, hoist))
    assert -math.pi <= joints.slew_rad < math.pi
    assert hook_position(CRANE, joints, SPEC.jib_height_m) == pytest.approx(point, abs=1e-9)


def test_joint_values_are_clamped_to_the_cranes_limits() -> None:
    inside = hook_joints(CRANE, (9.0, 3.0, 2.0), SPEC)  # 1 m from the mast
    assert inside.trolley_m == SPEC.min_radius_m == 2.5 and inside.slew_rad == pytest.approx(0.0)
    beyond = hook_joints(CRANE, (10.0 - 65.0, 3.0, 2.0), SPEC)
    assert beyond.trolley_m == SPEC.max_radius_m == 60.0
    assert (
        hook_joints(CRANE, (0.0, 3.0, 50.0), SPEC).hoist_m == 0.0
    )  # above the jib (40 m): hook all the way up
    assert hook_joints(CRANE, (0.0, 3.0, -4.0), SPEC).hoist_m == SPEC.jib_height_m  # below ground
    above_mast = hook_joints(CRANE, (10.0, 3.0, 8.0), SPEC)
    assert (above_mast.slew_rad, above_mast.trolley_m) == (0.0, SPEC.min_radius_m)


def test_a_measured_jib_height_is_what_the_hoist_counts_from() -> None:
    joints = hook_joints(CRANE, (0.0, 3.0, 3.0), SPEC, jib_height_m=30.0)
    assert joints.hoist_m == pytest.approx(27.0)


def test_a_parked_crane_has_its_hook_up_at_the_innermost_radius() -> None:
    assert parked(SPEC) == CraneJoints(0.0, SPEC.min_radius_m, 0.0)
    assert parked(SPEC).by_name() == {"slew": 0.0, "trolley": SPEC.min_radius_m, "hoist": 0.0}


def test_a_hook_holds_a_load_above_the_centre_of_its_posed_box() -> None:
    # a 3 m beam, 0.08 m wide, 0.16 m deep, its frame at one end, turned a quarter about z, at 3.16 m
    low, high = (0.0, -0.04, 0.0), (3.0, 0.04, 0.16)
    quat = Rotation.from_euler("z", math.pi / 2).as_quat()
    assert load_top(low, high, (0.0, 0.0, 3.16), quat) == pytest.approx((0.0, 1.5, 3.32))
    box_low, box_high = load_box(low, high, (0.0, 0.0, 3.16), quat)
    assert box_low == pytest.approx((-0.04, 0.0, 3.16)) and box_high == pytest.approx((0.04, 3.0, 3.32))


def test_a_crane_lift_rises_to_its_peak_crosses_and_lowers_onto_the_target() -> None:
    from bimbot.services.physics.crane import lift_position

    start, end = (0.0, 0.0, 1.0), (10.0, 0.0, 3.0)
    assert lift_position(start, end, 0.0, 6.0) == start
    assert lift_position(start, end, 1.0, 6.0) == end
    # legs: up 5 m, across 10 m, down 3 m (18 m): the load is at the peak for the middle of the lift
    x, _, z = lift_position(start, end, 5.0 / 18.0 + 0.01, 6.0)
    assert z == pytest.approx(6.0) and 0.0 < x < 1.0
    x, _, z = lift_position(start, end, 0.5, 6.0)
    assert z == pytest.approx(6.0) and 0.0 < x < 10.0
    assert lift_position(start, end, 2.0 / 18.0, 6.0)[:2] == (0.0, 0.0)  # straight up first
