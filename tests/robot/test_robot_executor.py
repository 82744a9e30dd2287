"""The executor through whole tasks with fake physics and fake component states: the protocol's event order,
the paper's state order, a command for every clock step, at-least-once events, refusals, withdrawals."""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
import pytest
from fake_site import DT, make_site, run_task
from frames import convert_small_frame
from wall_clock import speed_factor

from bimbot.services.robot.protocol import EventQueue, injected
from bimbot.services.robot.task_machine import PAPER_ORDER
from bimbot.shared.manifest import Manifest, read_manifest
from bimbot.shared.messages import (
    ClockMsg,
    CmdVelMsg,
    ComponentEvent,
    ComponentEventMsg,
    ComponentState,
    PlaceRequest,
    RobotState,
    RobotStateMsg,
    TaskStatus,
)


@pytest.fixture(scope="module")
def frame(tmp_path_factory: pytest.TempPathFactory) -> Manifest:
    return read_manifest(convert_small_frame(tmp_path_factory.mktemp("frame")))


def test_one_task_runs_the_protocol_in_order_and_answers_every_clock_step(frame: Manifest) -> None:
    site, released, task = make_site(frame)
    run_task(site, released, task)
    assert site.executor.done == [(task.guid, ComponentState.CONSTRUCTED)]
    assert site.applied == [
        ComponentEvent.PICK,
        ComponentEvent.ATTACH,
        ComponentEvent.ARRIVE,
        ComponentEvent.PLACE,
    ]
    assert tuple(site.robot_states) == PAPER_ORDER
    assert [c.step for c in site.commands] == list(range(1, site.step + 1)), "one cmd_vel per clock step"
    last = site.executor.tick(
        ClockMsg(sim_time_s=site.step * DT, step=site.step + 1, real_time_factor=1.0), 0.0
    )
    assert isinstance(last[-1], CmdVelMsg) and last[-1].step == site.step + 1, "the command comes last"
    assert all(c.v_mps == 0.0 and c.w_radps == 0.0 for c in site.commands[-5:])
    kinds = [r.kind for r in site.requests]
    assert kinds == ["attach", "place"]
    place = site.requests[-1].message
    assert isinstance(place, PlaceRequest)
    np.testing.assert_allclose(place.pose.position_m, task.target_pose.position_m)
    factor = speed_factor()  # wall seconds: a busy machine stretches every tick alike
    assert max(site.tick_s) < 0.5 * factor and float(np.median(site.tick_s)) < 0.02 * factor, (
        "a tick never waits on anything"
    )


def test_events_are_repeated_with_the_same_id_until_the_component_applies_them(frame: Manifest) -> None:
    site, released, task = make_site(frame, resend_s=0.3)
    site.drop_first = {ComponentEvent.PICK, ComponentEvent.ARRIVE}
    run_task(site, released, task)
    picks = [e for e in site.events if e.event is ComponentEvent.PICK]
    assert len(picks) >= 2 and len({e.event_id for e in picks}) == 1
    assert site.applied == [
        ComponentEvent.PICK,
        ComponentEvent.ATTACH,
        ComponentEvent.ARRIVE,
        ComponentEvent.PLACE,
    ]


def test_an_event_whose_confirmation_was_lost_is_confirmed_by_the_twin(frame: Manifest) -> None:
    """The agent applied ``pick`` and its state message was lost (a router restarted): the agent ignores
    the repeats, so only the twin can tell the robot, which asks it once the event has gone unconfirmed for
    ``confirm_ask_s``, and goes on with the task instead of waiting for its no-progress bound."""
    site, released, task = make_site(frame, confirm_ask_s=5.0)
    site.lose_state = {ComponentState.PICKING}
    run_task(site, released, task)
    assert site.executor.done == [(task.guid, ComponentState.CONSTRUCTED)]
    # the twin asked twice: about the lost confirmation, and about the verdict (a terminal claim, as always)
    assert site.applied.count(ComponentEvent.PICK) == 1 and site.twin_questions == [task.guid] * 2
    picks = [e for e in site.events if e.event is ComponentEvent.PICK]
    assert picks[-1].sim_time_s - picks[0].sim_time_s < 5.0 + 2.0  # asked at 5 s, answered a step later


def test_a_refused_attach_sends_the_robot_to_another_approach_and_tries_again(frame: Manifest) -> None:
    site, released, task = make_site(frame)
    site.refuse_attach = 1
    run_task(site, released, task)
    assert [r.kind for r in site.requests] == ["attach", "attach", "place"]
    assert site.executor.done == [(task.guid, ComponentState.CONSTRUCTED)]


def test_a_placement_told_to_wait_for_a_robot_in_the_way_asks_again_later_without_using_a_try(
    frame: Manifest,
) -> None:
    """Physics says another robot stands where the load goes (``wait_s``): the robot stays at its stand-point
    and asks again after that much sim time; more waits than ``max_tries`` still end in the placement."""
    site, released, task = make_site(frame, max_tries=2)
    site.wait_place, site.wait_s = 4, 5.0
    run_task(site, released, task)
    places = [r for r in site.requests if r.kind == "place"]
    assert len(places) == 5 and site.executor.done == [(task.guid, ComponentState.CONSTRUCTED)]
    asked_s = [
        step * DT for step, r in zip(site.request_steps, site.requests, strict=True) if r.kind == "place"
    ]
    assert all(later - earlier >= 5.0 for earlier, later in itertools.pairwise(asked_s))


def test_physics_measuring_the_robot_farther_than_it_believes_makes_it_relocalise(
    frame: Manifest, caplog: pytest.LogCaptureFixture
) -> None:
    site, released, task = make_site(frame)
    site.refuse_attach, site.refuse_distance_m = 1, 4.0  # the robot stands within reach, it believes
    with caplog.at_level("WARNING"):
        run_task(site, released, task)
    assert "localisation off by" in caplog.text and "re-localising" in caplog.text
    cloud = site.executor.navigator.localiser.particles.poses_xy_yaw[:, :2].std(axis=0).max()
    assert cloud < 0.1  # the wide cloud narrowed again on the laser while the robot drove on
    assert site.executor.done == [(task.guid, ComponentState.CONSTRUCTED)]
    site2, released2, task2 = make_site(frame)
    site2.refuse_attach = 1  # a refusal without a measured distance: no doubt about the localisation
    with caplog.at_level("WARNING"):
        caplog.clear()
        run_task(site2, released2, task2)
    assert "re-localising" not in caplog.text


def test_too_many_refusals_give_the_task_up_with_abandon(frame: Manifest) -> None:
    site, released, task = make_site(frame, max_tries=2)
    site.refuse_attach = 10
    site.executor.handle(released)
    site.executor.handle(task)
    site.run(3000, until=lambda s: s.executor.machine.state is RobotState.IDLE and s.step > 5)
    assert site.applied == [ComponentEvent.PICK, ComponentEvent.ABANDON]
    assert site.states[task.guid] is ComponentState.RELEASED
    assert site.executor.task is None


def test_a_task_given_back_after_refusals_that_measured_the_robot_far_off_says_its_localisation_was_off(
    frame: Manifest,
) -> None:
    """On the Revit hub a carrier lost its localisation by 7–19 m: each attach was refused as out of reach
    and the task given back saying only "8.26 m from …, reach is 1.8 m". The reason now says the robot's
    belief was wrong and what gives a robot position fixes."""
    site, released, task = make_site(frame, max_tries=2)
    site.refuse_attach, site.refuse_distance_m = 10, 8.0  # the robot believes it stands within reach
    site.executor.handle(released)
    site.executor.handle(task)
    site.run(3000, until=lambda s: s.executor.machine.state is RobotState.IDLE and s.step > 5)
    abandon = next(e for e in site.events if e.event is ComponentEvent.ABANDON)
    assert abandon.reason is not None and abandon.reason.code.value == "physics_refused"
    assert "localisation was off by" in abandon.reason.message
    assert "--total-station-mm" in abandon.reason.message


def test_an_injected_error_offsets_only_the_first_attempt(frame: Manifest) -> None:
    site, released, task = make_site(frame, placement_error_m=0.05)
    run_task(site, released, task)
    assert site.executor.done == [(task.guid, ComponentState.MISPLACED)]
    place = site.requests[-1].message
    assert place.pose.position_m[0] == pytest.approx(task.target_pose.position_m[0] + 0.05)
    spec = {"error_m": 0.05, "fraction": 0.0, "seed": 0}
    assert not injected(task.guid, 1, guids=frozenset(), **spec)
    assert injected(task.guid, 0, guids=frozenset({task.guid}), **spec)
    assert not injected(task.guid, 0, guids=frozenset({"other"}), **spec)
    share = np.mean(
        [injected(f"g{i}", 0, error_m=0.05, guids=frozenset(), fraction=0.3, seed=1) for i in range(1000)]
    )
    assert 0.25 < share < 0.35


def test_a_task_given_to_another_robot_is_dropped(frame: Manifest) -> None:
    site, released, task = make_site(frame)
    site.executor.handle(released)
    site.executor.handle(task)
    site.run(30)
    assert site.executor.machine.state is RobotState.PICK_UP
    site.executor.handle(task.model_copy(update={"robot_id": "r2"}))
    site.run(2)
    assert site.executor.machine.state is RobotState.IDLE and site.executor.task is None


def test_an_assignment_waits_for_the_components_release(frame: Manifest) -> None:
    site, released, task = make_site(frame)
    planned = released.model_copy(
        update={"state": ComponentState.PLANNED, "previous": None, "event": "start"}
    )
    site.executor.handle(planned)
    site.executor.handle(task)
    site.run(5)
    assert site.executor.machine.state is RobotState.IDLE
    site.executor.handle(released)
    site.run(2)
    assert site.executor.machine.state is not RobotState.IDLE


def test_event_queue_sends_the_oldest_unconfirmed_event_only() -> None:
    queue = EventQueue(resend_s=1.0)
    make = lambda event: ComponentEventMsg(  # noqa: E731
        guid="g", event=event, source="r1", event_id=event.value, sim_time_s=0, wall_time_s=0
    )
    queue.push(make(ComponentEvent.PICK))
    queue.push(make(ComponentEvent.ATTACH))
    assert queue.due(0.0).event is ComponentEvent.PICK
    assert queue.due(0.5) is None and queue.due(1.0).event is ComponentEvent.PICK
    queue.confirm(ComponentState.PICKING)
    assert queue.due(1.1).event is ComponentEvent.ATTACH, "the next goes out at once"
    queue.confirm(ComponentState.CONSTRUCTED)
    assert not queue and queue.queued == {ComponentEvent.PICK, ComponentEvent.ATTACH}


def test_a_task_given_back_and_assigned_again_is_taken_again(frame: Manifest) -> None:
    site, released, task = make_site(frame, max_tries=2)
    site.refuse_attach = 2
    site.executor.handle(released)
    site.executor.handle(task)
    site.run(3000, until=lambda s: ComponentEvent.ABANDON in s.applied and s.executor.task is None)
    assert site.states[task.guid] is ComponentState.RELEASED
    site.executor.handle(task)  # a late repeat of the old assignment: not a new one
    site.run(3)
    assert site.executor.task is None
    site.executor.handle(task.model_copy(update={"wall_time_s": 5.0}))  # the planner assigns it again
    site.run(3)
    assert site.executor.task is not None and site.executor.machine.state is RobotState.PICK_UP


def test_a_placement_without_a_trusted_alignment_says_so_with_its_place_event(frame: Manifest) -> None:
    """Nothing mapped for the fine alignment to match (as inside a large empty site): the robot places from
    its filter's estimate and its place event says so, for the agent's verdict."""
    site, released, task = make_site(frame)
    site.executor.navigator.site_map.laser_segments = lambda: np.empty((0, 2, 2))  # type: ignore[method-assign]
    run_task(site, released, task)
    place = next(e for e in site.events if e.event is ComponentEvent.PLACE)
    assert "could not align to what its laser sees" in place.note and "0 laser hits" in place.note


def test_an_idle_robot_says_so_at_once_when_a_task_is_released_not_at_its_next_periodic_state(
    frame: Manifest,
) -> None:
    """The planner assigns a released task to a robot it has heard say idle. The periodic state is 1 s of
    wall time: on an idle site that was up to 90 s of sim time before the first task began."""
    site, _, task = make_site(frame)
    executor = site.executor
    first = [m for m in executor.poll(10.0) if isinstance(m, RobotStateMsg)]
    assert first and first[0].state is RobotState.IDLE
    assert not [m for m in executor.poll(10.1) if isinstance(m, RobotStateMsg)]  # within the period: quiet
    executor.handle(task.model_copy(update={"status": TaskStatus.RELEASED, "robot_id": None}))
    again = [m for m in executor.poll(10.2) if isinstance(m, RobotStateMsg)]
    assert again and again[0].state is RobotState.IDLE


def test_an_idle_robot_that_cannot_reach_its_depot_says_once_why_and_where_it_stays_and_tries_again_later(
    frame: Manifest, caplog: pytest.LogCaptureFixture
) -> None:
    """On the Revit hub a carrier idle inside the structure could not drive to its depot: it was sent there,
    the goal cancelled, and sent again every period (14,000 log lines). A failed parking drive (its
    recoveries spent) is tried again after park_retry_s; in the house a robot walled in failed every try
    alike, and each logged the same lines (parking, recoveries, the navigator's failure, a warning). The
    first failure says why and where it stays; after it only the 2nd, 4th, 8th, … in a row, with the count;
    the tries themselves go to debug. The robot's state message says why it stands where it is."""
    site, released, task = make_site(frame, park_after_s=2.0, park_retry_s=1.0)
    run_task(site, released, task)
    assert site.executor.done == [(task.guid, ComponentState.CONSTRUCTED)]
    site.frozen = True  # its wheels turn no more: wherever it goes, it stays
    with caplog.at_level("DEBUG", logger="bimbot.services.robot"):
        site.run(int(150.0 / DT))
    records = caplog.records
    tries = [r for r in records if "idle, parking at the depot" in r.getMessage()]
    said = [r.getMessage() for r in records if r.levelname == "WARNING" and "to the depot" in r.getMessage()]
    assert 3 <= len(tries) <= 10, caplog.text[-3000:]  # again and again, not every period
    assert [r.levelname for r in tries].count("INFO") == 1  # the first try; the others at debug
    assert "stays at (" in said[0] and "tries again every 1 s: " in said[0], said[0]
    assert said[1:] and all("tries in a row" in line for line in said[1:]), said
    counts = [int(line.split("(")[1].split(" tries")[0]) for line in said[1:]]
    assert counts == [2, 4, 8][: len(counts)] and len(said) < len(tries), said  # not one per failure
    parking = records[records.index(tries[0]) :]  # (leaving the structure failed too, before)
    failed = [r for r in parking if r.levelname == "WARNING" and "navigation to" in r.getMessage()]
    assert len(failed) == 1, [r.getMessage() for r in failed]  # the navigator said the first failure only
    state = site.executor.state_message(0.0)
    assert state.state is RobotState.IDLE, state
    assert state.activity.startswith("waits at (") and state.activity.endswith(" m from its depot")
    assert len(state.activity) <= 60, "whole on the run's progress line (MAX_ACTIVITY_CHARS)"
    assert state.walled_in_since_s is None, "its wheels are stuck, but a way is free: it is not walled in"


def test_a_robot_holding_a_part_it_set_does_not_choose_its_stand_point_again(frame: Manifest) -> None:
    """Physics answers a placement when the part's connection is made (a hold of minutes). Meanwhile the
    robot's map has the part standing: on the Revit house with three carriers r2, holding a partition
    panel it had set from a stand-point found close enough, asked again where to set it from, found the
    panel now closed the room, and gave the standing panel back. While a placement is in flight the robot
    does not drive nor choose a stand-point."""
    site, released, task = make_site(frame)
    driving = site.executor.getting_there
    drive = driving.drive
    while_placing: list[int] = []

    def watched(task_: Any, footprint: Any) -> bool:
        request = task_.request
        if request is not None and request.kind == "place":
            while_placing.append(site.step)
        return drive(task_, footprint)

    driving.drive = watched  # type: ignore[method-assign]
    run_task(site, released, task)
    assert [r.kind for r in site.requests] == ["attach", "place"]
    assert site.executor.done == [(task.guid, ComponentState.CONSTRUCTED)]
    assert while_placing == []
