"""The recovery chain and the watchdogs: a robot that cannot move runs every recovery once, in order, and then
fails in bounded sim time with a reason; a robot parked inside the inflation plans its way out; the
diagnosis tells trapped, unreachable and no progress apart."""

from __future__ import annotations

import math

import numpy as np
import pytest
from frames import convert_small_frame
from test_robot_navigator import DT, World, start_of

from bimbot.services.robot.navigator import Navigator, NavStatus
from bimbot.services.robot.recovery import (
    RECOVERY_CHAIN,
    ProgressWatchdog,
    Recovery,
    diagnose,
    next_recovery,
    plan_start,
)
from bimbot.services.robot.site_map import SiteMap
from bimbot.shared.footprint import posed_footprint
from bimbot.shared.manifest import Manifest, read_manifest
from bimbot.shared.messages import ComponentPoseMsg, PoseMsg
from bimbot.shared.occupancy_grid import from_footprints, inflate
from bimbot.shared.reasons import ReasonCode
from bimbot.shared.site_layout import plan_site


@pytest.fixture(scope="module")
def frame(tmp_path_factory: pytest.TempPathFactory) -> Manifest:
    return read_manifest(convert_small_frame(tmp_path_factory.mktemp("frame")))


@pytest.fixture
def site(frame: Manifest) -> SiteMap:
    return SiteMap(plan_site(frame.components, robots=1), frame.components)


def test_the_watchdog_expires_only_without_progress_on_either_distance() -> None:
    watchdog = ProgressWatchdog(window_s=10.0, min_progress_m=0.3)
    watchdog.reset(0.0)
    assert not watchdog.expired(10.0, 12.0, 0.0)
    assert not watchdog.expired(10.5, 11.5, 8.0), "a detour: the path left still shrinks"
    assert not watchdog.expired(10.4, 11.4, 17.0)
    assert watchdog.expired(10.4, 11.4, 18.1), "10 s since the path left last shrank by 0.3 m"
    watchdog.reset(20.0)
    assert not watchdog.expired(10.4, 11.4, 29.0), "a reset gives the full window again"


def test_the_chain_runs_in_order_and_skips_a_back_up_with_no_room_behind() -> None:
    assert RECOVERY_CHAIN == (Recovery.CLEAR_MARKS, Recovery.ROTATE, Recovery.BACK_UP, Recovery.PLAN_OUT)
    assert next_recovery(0, clear_behind=True) == (Recovery.CLEAR_MARKS, 1)
    assert next_recovery(2, clear_behind=True) == (Recovery.BACK_UP, 3)
    assert next_recovery(2, clear_behind=False) == (Recovery.PLAN_OUT, 4)
    assert next_recovery(4, clear_behind=True) == (None, 4)


def test_diagnose_tells_trapped_unreachable_and_no_progress_apart() -> None:
    pen = [(4.0, 4.0, 8.0, 4.2), (4.0, 7.8, 8.0, 8.0), (4.0, 4.0, 4.2, 8.0), (7.8, 4.0, 8.0, 8.0)]
    grid = inflate(from_footprints((0.0, 0.0, 20.0, 20.0), 0.1, boxes_xy_m=pen), 0.75)
    spec = {"robot_id": "r1", "why": "found no path in 20 s", "tried": tuple(RECOVERY_CHAIN)}
    unreachable = diagnose(grid, (1.0, 1.0), (6.0, 6.0), trapped_area_m2=2.0, **spec)
    assert unreachable.code is ReasonCode.UNREACHABLE
    assert unreachable.message.startswith(
        "the goal (6.00, 6.00) is cut off from r1 at (1.00, 1.00) (7.1 m apart)"
    )
    trapped = diagnose(grid, (6.0, 6.0), (1.0, 1.0), trapped_area_m2=5.0, **spec)
    assert trapped.code is ReasonCode.ROBOT_TRAPPED, trapped.message
    assert "m² of free space around it, less than 5.0 m²" in trapped.message
    assert "clear_marks, rotate, back_up, plan_out" in trapped.message
    stuck = diagnose(grid, (1.0, 1.0), (15.0, 1.0), trapped_area_m2=2.0, **spec)
    assert stuck.code is ReasonCode.NO_PROGRESS and "14.0 m from its goal (15.00, 1.00)" in stuck.message


def test_a_robot_that_cannot_move_runs_every_recovery_then_fails_with_a_reason(site: SiteMap) -> None:
    start = start_of(site)
    navigator = Navigator(site, start, robot_id="r1")
    navigator.set_goal((start[0] + 8.0, start[1]), None, 0.0)
    world = World(site.laser_grid(), start)
    for _ in range(1200):  # the wheels never turn: the world does not move
        world.sense(navigator)
        navigator.step(world.sim_s)
        if navigator.status is NavStatus.FAILED:
            break
        world.sim_s += DT
    assert navigator.status is NavStatus.FAILED, "bounded: it gives up"
    assert world.sim_s < 60.0
    assert [kind for _, kind in navigator.recoveries] == list(RECOVERY_CHAIN)
    assert navigator.failure is not None and navigator.failure.code is ReasonCode.NO_PROGRESS
    assert "moved less than 0.20 m in 6 s" in navigator.failure.message


def test_a_goal_cut_off_fails_unreachable_after_the_chain(site: SiteMap) -> None:
    start = start_of(site)
    slot = next(iter(site.layout.slots.values())).footprint
    inside = np.add(slot.min_xy, slot.max_xy) / 2  # the middle of a yard stack: no way in
    navigator = Navigator(site, start, robot_id="r1")
    navigator.set_goal(inside, None, 0.0)
    world = World(site.laser_grid(), start)
    status = world.drive(navigator, max_steps=600)
    assert status is NavStatus.FAILED and world.sim_s < 35.0
    assert navigator.failure is not None and navigator.failure.code is ReasonCode.UNREACHABLE


def _corridor(site: SiteMap, frame_manifest: Manifest) -> tuple[float, float]:
    """The two longest components laid 1.3 m apart in the building's footprint: a corridor narrower than
    the robot's inflation, longer than the navigator's usual start snap. Returns its middle."""
    beams = sorted(
        frame_manifest.components, key=lambda c: -max(np.subtract(c.bbox_local.max_m, c.bbox_local.min_m))
    )[:2]
    building = site.layout.building
    middle = ((building.min_xy[0] + building.max_xy[0]) / 2, (building.min_xy[1] + building.max_xy[1]) / 2)
    for beam, side in zip(beams, (-1, 1), strict=True):
        slot = site.layout.slots[beam.guid]
        lying = posed_footprint(beam, slot.position_m, slot.quat_xyzw)
        width = float(np.ptp(lying.polygon_xy_m[:, 0]))
        offset = np.array(middle) + np.array([side * (0.65 + width / 2), 0.0]) - lying.centre_xy_m
        position = (slot.position_m[0] + offset[0], slot.position_m[1] + offset[1], slot.position_m[2])
        site.observe_pose(
            ComponentPoseMsg(
                guid=beam.guid, pose=PoseMsg(position_m=position, quat_xyzw=slot.quat_xyzw), sim_time_s=0
            )
        )
    return middle


def test_a_robot_parked_inside_the_inflation_plans_its_way_out(site: SiteMap, frame: Manifest) -> None:
    middle = _corridor(site, frame)
    grid = site.planning_grid()
    assert not grid.is_free(*middle)
    assert plan_start(grid, middle, 1.0) is None, "the usual start snap finds no free cell"
    assert plan_start(grid, middle, 4.0) is not None
    start = np.array([middle[0], middle[1], math.pi / 2])  # facing along the corridor
    goal = (middle[0] + 4.0, middle[1])
    navigator = Navigator(site, start, robot_id="r1")
    navigator.set_goal(goal, None, 0.0)
    world = World(site.laser_grid(), start)
    assert world.drive(navigator, max_steps=1500) is NavStatus.REACHED, navigator.failure
    assert Recovery.PLAN_OUT in [kind for _, kind in navigator.recoveries]
    assert math.dist(world.pose[:2], goal) < 0.5
    assert world.sim_s < 90.0


def test_a_robot_that_cannot_get_on_names_the_components_beside_it(site: SiteMap) -> None:
    """A robot boxed in by a beam that fell beside it said only "found no path": its reason now names what
    lies within a metre of it, nearest first, so a user can see what holds it up."""
    slot_guid, slot = next(iter(site.layout.slots.items()))
    name = site._components[slot_guid].name or slot_guid
    box = slot.footprint
    start = np.array([box.min_xy[0] - 0.7, (box.min_xy[1] + box.max_xy[1]) / 2.0, 0.0])
    assert site.components_near(start[:2], 1.0)[0] == (name, pytest.approx(0.7, abs=0.05))
    assert site.components_near(start[:2], 0.5) == []
    navigator = Navigator(site, start, robot_id="r1")
    navigator.set_goal((start[0] - 8.0, start[1]), None, 0.0)
    world = World(site.laser_grid(), start)
    for _ in range(1200):  # the wheels never turn: it stays beside the yard item
        world.sense(navigator)
        navigator.step(world.sim_s)
        if navigator.status is NavStatus.FAILED:
            break
        world.sim_s += DT
    assert navigator.failure is not None, "bounded: it gives up"
    assert f"; beside it: {name} (0.7 m)" in navigator.failure.message, navigator.failure.message


def test_a_reason_names_at_most_three_components_beside_the_robot() -> None:
    grid = from_footprints((0.0, 0.0, 20.0, 20.0), 0.1)
    beside = [("Beam A1-A2", 0.24), ("Column A1", 0.61), ("Footing A1", 0.8), ("Footing A2", 0.95)]
    spec = {"robot_id": "r1", "why": "found no path in 13 s", "tried": tuple(RECOVERY_CHAIN)}
    reason = diagnose(grid, (5.0, 5.0), (15.0, 5.0), trapped_area_m2=2.0, beside=beside, **spec)
    assert reason.message.endswith("; beside it: Beam A1-A2 (0.2 m), Column A1 (0.6 m), Footing A1 (0.8 m)")
    assert "beside" not in diagnose(grid, (5.0, 5.0), (15.0, 5.0), trapped_area_m2=2.0, **spec).message
