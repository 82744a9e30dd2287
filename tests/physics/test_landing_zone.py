"""A load is not set down where another robot stands: the place request is refused for now (``wait_s``,
no failed try) until the robot moved off, and goes anyway after the bound."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest
from physics_builders import idle, pose, west_of

from bimbot.services.physics.landing_zone import ASK_AGAIN_S, Bystander, LandingWaits, in_the_way
from bimbot.services.physics.scene import footprint
from bimbot.services.physics.simulation import Simulation
from bimbot.shared.footprint import Footprint
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import AttachRequest, PlaceRequest

SQUARE = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]])


def _robot(xy: tuple[float, float], z_low: float = 0.0, z_high: float = 0.8, name: str = "r2") -> Bystander:
    return Bystander(name, xy, 0.6, z_low, z_high)


def test_a_robot_within_its_radius_of_the_outline_is_in_the_way_and_one_beyond_it_is_not() -> None:
    wall = Footprint(SQUARE, 0.0, 3.0)
    found = in_the_way(wall, [_robot((2.4, 1.0))])
    assert found is not None and found[0].robot_id == "r2" and found[1] == pytest.approx(0.2)
    assert in_the_way(wall, [_robot((2.7, 1.0))]) is None
    inside = in_the_way(wall, [_robot((5.0, 5.0), name="r3"), _robot((1.0, 1.0))])
    assert inside is not None and inside[0].robot_id == "r2" and inside[1] == pytest.approx(0.6)


def test_a_part_above_a_robots_body_is_not_in_its_way() -> None:
    beam = Footprint(SQUARE, 3.0, 3.4)
    assert in_the_way(beam, [_robot((1.0, 1.0))]) is None
    lintel_over_a_door = Footprint(SQUARE, 0.0, 3.0, parts=(Footprint(SQUARE, 2.1, 3.0),))
    assert in_the_way(lintel_over_a_door, [_robot((1.0, 1.0))]) is None


def test_a_load_waits_at_most_the_bound_then_goes_and_a_clear_zone_resets_the_wait() -> None:
    waits = LandingWaits(wait_max_s=100.0)
    found = (_robot((1.0, 1.0)), 0.6)
    first = waits.refusal("g", "Wall 1", found, 10.0)
    assert first is not None and "r2 at (1.00, 1.00) stands where Wall 1 goes" in first
    assert waits.refusal("g", "Wall 1", found, 60.0) is not None
    assert waits.refusal("g", "Wall 1", found, 110.0) is None  # waited 100 s: goes anyway
    assert waits.refusal("g", "Wall 1", found, 111.0) is not None  # a new wait begins
    assert waits.refusal("g", "Wall 1", None, 112.0) is None
    assert waits.refusal("g", "Wall 1", found, 300.0) is not None and waits.since_s["g"] == 300.0


def test_physics_refuses_for_now_a_column_over_another_robot_and_places_it_once_that_robot_moved_off(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    sim = make_sim(robots=2)
    column = next(  # a column whose yard slot faces its aisle on the west side
        c
        for c in frame_manifest.components
        if c.ifc_class == "IfcColumn" and sim.layout.slots[c.guid].aisle_side < 0
    )
    slot = sim.layout.slots[column.guid].footprint
    sim.teleport_robot("r1", west_of(slot, 0.8))
    assert sim.attach(AttachRequest(robot_id="r1", guid=column.guid)).ok
    idle(sim, 1.2)
    target = column.target_pose_world
    spot = footprint(column, (target.position_m, target.quat_xyzw))
    sim.teleport_robot("r1", west_of(spot, 0.8))
    centre = ((spot.min_xy[0] + spot.max_xy[0]) / 2.0, (spot.min_xy[1] + spot.max_xy[1]) / 2.0)
    sim.teleport_robot("r2", (centre[0], centre[1], math.pi / 2))
    request = PlaceRequest(
        robot_id="r1", guid=column.guid, pose=pose(target.position_m, target.quat_xyzw), duration_s=1.0
    )
    reply = sim.place(request)
    assert reply is not None and not reply.ok and reply.wait_s == ASK_AGAIN_S
    assert reply.reason.startswith("r2 at (") and f"stands where {column.name} goes" in reply.reason
    assert sim.handling.carrying.get("r1") == column.guid  # still carried: nothing started
    sim.teleport_robot("r2", (centre[0], centre[1] + 8.0, math.pi / 2))
    assert sim.place(request) is None  # the zone is clear: placed
