"""A robot never waits for ever: a target cut off, a load it cannot deliver, a task that stalls — each ends in
bounded sim time with ``abandon`` carrying a reason with the numbers (the carried load put down first)."""

from __future__ import annotations

import numpy as np
import pytest
from fake_site import DT, FakeSite, construct_named, make_site, run_task
from frames import convert_small_frame
from site_models import ROOM_WALLS

from bimbot.services.robot import give_back
from bimbot.shared.manifest import Manifest, read_manifest
from bimbot.shared.messages import (
    ComponentEvent,
    ComponentEventMsg,
    ComponentState,
    DropRequest,
    RobotState,
)
from bimbot.shared.reasons import ReasonCode


@pytest.fixture(scope="module")
def frame(tmp_path_factory: pytest.TempPathFactory) -> Manifest:
    return read_manifest(convert_small_frame(tmp_path_factory.mktemp("frame")))


def _abandon(site: FakeSite) -> ComponentEventMsg:
    abandons = [e for e in site.events if e.event is ComponentEvent.ABANDON]
    assert abandons, f"no abandon after {site.step * DT:.0f} s in {site.executor.machine.state}"
    assert abandons[0].reason is not None, "every abandon says why"
    return abandons[0]


def _given_back(site: FakeSite) -> bool:
    return ComponentEvent.ABANDON in site.applied and site.executor.task is None


def test_a_column_walled_in_by_its_room_is_given_back_unreachable_before_it_is_picked(room: Manifest) -> None:
    site, released, task = make_site(room, "Column R1")
    construct_named(site, room, ROOM_WALLS)
    site.run(3)  # the walls' twins answer
    assert set(site.twin_questions) == {c.guid for c in room.components if c.name in ROOM_WALLS}
    site.executor.handle(released)
    site.executor.handle(task)
    site.run(200, until=_given_back)
    reason = _abandon(site).reason
    assert reason.code is ReasonCode.UNREACHABLE, reason
    assert f"the target of Column R1 ({task.guid})" in reason.message and "cut off from r1" in reason.message
    assert reason.robot_id == "r1"
    assert site.requests == [], "nothing carried to a target cut off already"
    assert (
        site.states[task.guid] is ComponentState.RELEASED and site.executor.machine.state is RobotState.IDLE
    )


def test_a_carrying_robot_that_cannot_reach_its_target_puts_the_load_down_and_gives_it_back(
    room: Manifest,
) -> None:
    site, released, task = make_site(room, "Column R1")
    site.executor.handle(released)
    site.executor.handle(task)
    site.run(3000, until=lambda s: s.executor.machine.state is RobotState.IDENTIFY_TARGET_LOCATION)
    assert site.carried == task.guid
    closed_s = site.step * DT
    construct_named(site, room, ROOM_WALLS)  # the room closes while the column rides on the robot
    site.run(3000, until=_given_back)
    assert [r.kind for r in site.requests] == ["attach", "drop"]
    drop = site.requests[-1].message
    assert isinstance(drop, DropRequest) and drop.guid == task.guid and drop.robot_id == "r1"
    assert site.carried is None, "the load is on the ground, free for any robot"
    abandon = _abandon(site)
    assert abandon.reason.code is ReasonCode.UNREACHABLE, abandon.reason
    assert "Column R1" in abandon.reason.message
    assert abandon.sim_time_s - closed_s < 120.0, "a bounded wait, in sim time"
    assert site.states[task.guid] is ComponentState.RELEASED
    assert site.executor.given_back == [(task.guid, abandon.reason)]


@pytest.mark.parametrize("carrying", [False, True])
def test_the_task_watchdog_gives_back_a_task_whose_state_stalls(frame: Manifest, carrying: bool) -> None:
    site, released, task = make_site(frame, task_timeout_s=15.0)
    site.executor.handle(released)
    site.executor.handle(task)
    if carrying:
        site.run(3000, until=lambda s: s.executor.machine.state is RobotState.IDENTIFY_TARGET_LOCATION)
    stuck_s = site.step * DT
    site.frozen = True  # the wheels stop turning: the task state no longer changes
    site.run(400, until=_given_back)
    abandon = _abandon(site)
    assert abandon.reason.code is ReasonCode.NO_PROGRESS, abandon.reason
    assert "task watchdog allows 15 s" in abandon.reason.message
    assert abandon.sim_time_s - stuck_s < 20.0
    assert [r.kind for r in site.requests] == (["attach", "drop"] if carrying else [])


def test_after_a_task_the_robot_leaves_the_structure(frame: Manifest) -> None:
    site, released, task = make_site(frame)
    run_task(site, released, task)
    building = site.executor.site_map.layout.building.grown(site.executor.config.leave_margin_m)
    inside = building.min_xy[0] < site.pose[0] < building.max_xy[0]
    inside = inside and building.min_xy[1] < site.pose[1] < building.max_xy[1]
    site.run(300)
    (x0, y0), (x1, y1) = building.min_xy, building.max_xy
    assert not (x0 + 0.3 < site.pose[0] < x1 - 0.3 and y0 + 0.3 < site.pose[1] < y1 - 0.3), (
        f"still inside the structure (started inside: {inside})"
    )


def test_reasons_name_the_numbers() -> None:
    stalled = give_back.stalled("r1", RobotState.PICK_UP, 912.4, 900.0)
    assert stalled.code is ReasonCode.NO_PROGRESS
    assert stalled.message == "r1 stayed in pick up for 912 s of sim time (the task watchdog allows 900 s)"
    refused = give_back.physics_refused(
        "r2", "attach", "Beam B1 (g)", 4, "robot r2 is 1.62 m from g, reach is 1.5 m"
    )
    assert refused.code is ReasonCode.PHYSICS_REFUSED and refused.message.endswith("reach is 1.5 m")
    assert "4 times" in refused.message


def test_a_task_withdrawn_while_the_robot_carries_it_puts_the_load_down_first(frame: Manifest) -> None:
    site, released, task = make_site(frame)
    site.executor.handle(released)
    site.executor.handle(task)
    site.run(3000, until=lambda s: s.executor.machine.state is RobotState.IDENTIFY_TARGET_LOCATION)
    site.executor.handle(task.model_copy(update={"robot_id": "r2"}))  # the planner gave it to another robot
    site.run(100, until=lambda s: s.executor.task is None)
    assert [r.kind for r in site.requests] == ["attach", "drop"]
    assert site.carried is None and site.executor.machine.state is RobotState.IDLE
    assert ComponentEvent.ABANDON not in [e.event for e in site.events], "not ours to give back any more"


def _ring(centre_xy: tuple[float, float], radius_m: float, count: int) -> list[tuple[float, float]]:
    angles = np.linspace(0.0, 2.0 * np.pi, count, endpoint=False)
    return [(centre_xy[0] + radius_m * np.cos(a), centre_xy[1] + radius_m * np.sin(a)) for a in angles]


def _walled_in_by_traffic(site: FakeSite) -> list[tuple[float, float]]:
    """Other robots standing shoulder to shoulder in a ring 3 m around this one: the laser sees the whole
    ring, so no stand-point anywhere is reachable on the robot's planning grid, while the site plan has
    its way free."""
    return _ring((float(site.pose[0]), float(site.pose[1])), 3.0, 64)


def _picking(site: FakeSite) -> bool:
    return site.carried is not None


def test_a_stand_point_blocked_by_traffic_is_waited_for_and_taken_once_it_clears(
    frame: Manifest, caplog: pytest.LogCaptureFixture
) -> None:
    site, released, task = make_site(frame)
    site.traffic_xy_m = _walled_in_by_traffic(site)
    site.executor.handle(released)
    site.executor.handle(task)
    with caplog.at_level("INFO", logger="bimbot.services.robot.driving"):
        site.run(900, until=_given_back)  # 90 s of sim time: more than ten looks, less than the traffic wait
    assert "is blocked by traffic: waiting" in caplog.text
    assert not [e for e in site.events if e.event is ComponentEvent.ABANDON], (
        "no give-back while traffic lasts"
    )
    site.traffic_xy_m = []  # the others drive on
    site.run(3000, until=_picking)
    assert site.carried == task.guid and not [e for e in site.events if e.event is ComponentEvent.ABANDON]


def test_traffic_that_does_not_clear_ends_the_wait_with_a_reason_that_says_so(frame: Manifest) -> None:
    site, released, task = make_site(frame, traffic_wait_s=30.0)
    site.traffic_xy_m = _walled_in_by_traffic(site)
    site.executor.handle(released)
    site.executor.handle(task)
    site.run(3000, until=_given_back)
    abandon = _abandon(site)
    assert abandon.sim_time_s >= 30.0 and abandon.sim_time_s < 60.0, "the bound, in sim time"
    assert abandon.reason.code in (
        ReasonCode.UNREACHABLE,
        ReasonCode.NO_APPROACH_POSE,
        ReasonCode.ROBOT_TRAPPED,
    )
    assert (
        "other robots" in abandon.reason.message
        and "on the site plan there is a way" in abandon.reason.message
    )
    assert site.requests == [], "nothing picked"
