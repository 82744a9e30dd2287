"""The stall watchdog core: a site where nothing changes for N sim seconds is stalled, a busy one never is,
and a clock that stops is caught by the wall-time bound; the stall details name each robot and open task."""

from __future__ import annotations

from bimbot.run.watchdog import PLANNER_NOT_READY, StallWatchdog, stall_details
from bimbot.shared.messages import (
    ComponentState,
    PoseMsg,
    PreparingMsg,
    RobotState,
    RobotStateMsg,
    TaskMsg,
    TaskStatus,
)


def test_nothing_changing_for_the_bound_in_sim_time_is_a_stall_naming_the_numbers() -> None:
    watchdog = StallWatchdog(stall_after_s=600.0, clock_stall_wall_s=300.0, confirm_wall_s=0.0)
    watchdog.observe(changes=4, sim_time_s=768.0, wall_s=0.0)
    watchdog.observe(changes=4, sim_time_s=1367.0, wall_s=60.0)
    assert watchdog.verdict() is None
    watchdog.observe(changes=4, sim_time_s=1368.0, wall_s=61.0)
    verdict = watchdog.verdict()
    assert (
        verdict is not None and "600 s of sim time" in verdict and "768.0" in verdict and "1368.0" in verdict
    )


def test_a_change_on_the_site_restarts_the_count() -> None:
    watchdog = StallWatchdog(stall_after_s=100.0)
    for step in range(100):  # a change every 50 sim s, for 5,000 sim s
        watchdog.observe(changes=step // 1, sim_time_s=step * 50.0, wall_s=step * 1.0)
        assert watchdog.verdict() is None


def test_a_slow_clock_is_no_stall_in_wall_time() -> None:
    """At 0.1× real time, 600 sim s take 6,000 wall s: only sim time counts while the clock moves."""
    watchdog = StallWatchdog(stall_after_s=600.0, clock_stall_wall_s=300.0)
    for second in range(0, 5000, 10):
        watchdog.observe(changes=1, sim_time_s=second * 0.1, wall_s=float(second))
        assert watchdog.verdict() is None


def test_a_clock_that_stands_still_ends_the_run_after_the_wall_bound() -> None:
    watchdog = StallWatchdog(stall_after_s=600.0, clock_stall_wall_s=300.0)
    watchdog.observe(changes=1, sim_time_s=42.0, wall_s=1000.0)
    watchdog.observe(changes=2, sim_time_s=42.0, wall_s=1299.0)
    assert watchdog.verdict() is None
    watchdog.observe(changes=2, sim_time_s=42.0, wall_s=1300.0)
    verdict = watchdog.verdict()
    assert verdict is not None and "clock stood still at 42.0 s" in verdict and "300 s" in verdict


def test_zero_turns_each_bound_off() -> None:
    watchdog = StallWatchdog(stall_after_s=0.0, clock_stall_wall_s=0.0)
    watchdog.observe(changes=0, sim_time_s=0.0, wall_s=0.0)
    watchdog.observe(changes=0, sim_time_s=1e6, wall_s=1e6)
    assert watchdog.verdict() is None


def test_stall_details_say_what_each_robot_and_open_task_was_doing() -> None:
    robots = {
        "r1": RobotStateMsg(
            robot_id="r1",
            state=RobotState.PICK_UP,
            task_id="T0004",
            guid="2O2Fr$t4X7Zf8NOew3FLOH",
            pose_xy_yaw=(1.0, 2.0, 0.0),
            sim_time_s=768.0,
            wall_time_s=0.0,
            activity="no path to [-0.05, -0.83] yet: waiting",
        ),
        "r2": RobotStateMsg(
            robot_id="r2", state=RobotState.IDLE, pose_xy_yaw=(0, 0, 0), sim_time_s=5, wall_time_s=0
        ),
    }
    pose = PoseMsg(position_m=(0.0, 0.0, 0.0), quat_xyzw=(0.0, 0.0, 0.0, 1.0))
    tasks = {
        "T0004": TaskMsg(
            task_id="T0004",
            guid="2O2Fr$t4X7Zf8NOew3FLOH",
            component_key="k",
            status=TaskStatus.ASSIGNED,
            robot_id="r1",
            attempt=1,
            target_pose=pose,
            sim_time_s=700.0,
            wall_time_s=0.0,
        ),
        "T0001": TaskMsg(
            task_id="T0001",
            guid="0aaaaaaaaaaaaaaaaaaaaa",
            component_key="k0",
            status=TaskStatus.DONE,
            target_pose=pose,
            sim_time_s=100.0,
            wall_time_s=0.0,
        ),
    }
    states = {
        "2O2Fr$t4X7Zf8NOew3FLOH": ComponentState.PICKING,
        "0aaaaaaaaaaaaaaaaaaaaa": ComponentState.CONSTRUCTED,
    }
    names = {"2O2Fr$t4X7Zf8NOew3FLOH": "Column A1", "0aaaaaaaaaaaaaaaaaaaaa": "Footing A1"}
    lines = stall_details(robots, tasks, states, names)
    assert lines[0] == (
        "robot r1: pick_up task T0004 on Column A1 (2O2Fr$t4X7Zf8NOew3FLOH): no path to [-0.05, -0.83] yet: "
        "waiting (at sim 768.0 s)"
    )
    assert lines[1].startswith("robot r2: idle")
    assert lines[2] == (
        "task T0004 (Column A1 (2O2Fr$t4X7Zf8NOew3FLOH)): assigned to r1, attempt 1, component picking"
    )
    assert len(lines) == 3  # the done task and the constructed component are not open


def test_timed_work_and_curing_scheduled_ahead_are_not_a_stall() -> None:
    """A site that skipped its clock over a pour and a 3-day cure changed nothing for that long, as
    scheduled: it stalls only once the scheduled time has passed by the bound."""
    dog = StallWatchdog(stall_after_s=100.0, confirm_wall_s=0.0)
    dog.observe(5, 10.0, 0.0)
    cure_ends_s = 10.0 + 72 * 3600.0
    dog.observe(5, cure_ends_s - 1.0, 1.0, awaited_sim_s=cure_ends_s)
    assert dog.verdict() is None
    dog.observe(5, cure_ends_s + 99.0, 2.0)  # the awaited time stays known once heard
    assert dog.verdict() is None
    dog.observe(5, cure_ends_s + 101.0, 3.0)
    verdict = dog.verdict()
    assert verdict is not None and "for 101 s of sim time" in verdict


def test_a_robot_that_never_came_up_is_named_in_the_stall_details() -> None:
    """The restaurant's carrier r2 hung while starting (an empty log): the run stalled at sim 0 after its
    wall bound, and its details listed the five robots that were up, not the one that was not."""
    robots = {
        "r1": RobotStateMsg(
            robot_id="r1", state=RobotState.IDLE, pose_xy_yaw=(0, 0, 0), sim_time_s=0, wall_time_s=0
        )
    }
    lines = stall_details(robots, {}, {}, {}, expected=["r1", "r2"])
    assert lines[0] == (
        "robot r2: never said it was up (no state on the bus): its process hung or failed while starting; "
        "see logs/robot-r2.log"
    )
    assert lines[1].startswith("robot r1: idle") and len(lines) == 2


def test_a_planner_still_preparing_at_the_stall_is_named_first_with_what_to_do() -> None:
    """The restaurant on a loaded machine: the planner's plan-time access check ran past the wall bound, the
    robots idled at sim 0, and the details named only the robots."""
    robots = {
        "r1": RobotStateMsg(
            robot_id="r1", state=RobotState.IDLE, pose_xy_yaw=(0, 0, 0), sim_time_s=0, wall_time_s=0
        )
    }
    lines = stall_details(robots, {}, {}, {}, planner_ready=False)
    assert lines[0] == PLANNER_NOT_READY and "--stall-wall-s" in lines[0]
    assert lines[1].startswith("robot r1: idle")
    assert PLANNER_NOT_READY not in stall_details(robots, {}, {}, {})


def test_a_planner_that_reports_its_preparation_is_no_stall_one_that_falls_silent_is() -> None:
    """The clock waits at 0 while the planner checks a large building's access: each report of its
    preparation restarts the wall bound; once the reports stop, the bound ends the run as before."""
    watchdog = StallWatchdog(stall_after_s=600.0, clock_stall_wall_s=300.0)
    heard = 0
    for wall_s in range(0, 1200, 10):  # 20 minutes of preparation, a report every 10 s
        heard += 1
        watchdog.observe(changes=0, sim_time_s=0.0, wall_s=float(wall_s), preparing_heard=heard)
        assert watchdog.verdict() is None, wall_s
    watchdog.observe(changes=0, sim_time_s=0.0, wall_s=1190.0 + 299.0, preparing_heard=heard)
    assert watchdog.verdict() is None
    watchdog.observe(changes=0, sim_time_s=0.0, wall_s=1190.0 + 300.0, preparing_heard=heard)
    verdict = watchdog.verdict()
    assert verdict is not None and "clock stood still at 0.0 s" in verdict


def test_the_stall_details_give_the_planners_last_word_on_its_preparation() -> None:
    said = PreparingMsg(stage="access check, mended 3 time(s)", done=120, total=468)
    lines = stall_details({}, {}, {}, {}, planner_ready=False, preparing=said)
    assert lines[0] == PLANNER_NOT_READY
    assert lines[1] == "the planner's last word: access check, mended 3 time(s), 120 of 468"
    assert len(stall_details({}, {}, {}, {}, planner_ready=True, preparing=said)) == 0


def test_a_clock_that_jumped_before_the_news_of_its_cure_arrived_is_no_stall() -> None:
    """The Revit hub, seed 0, on a loaded machine: the foundation slab was built at sim 857,983 s and the
    walls waited for its 3-day cure; physics jumped its clock to the cure's end, and the run heard the
    clock before the planner's progress naming the cure: 259,200 s 'without a change', a stall, and a
    healthy build ended with 9 of 115. A stall in sim time now stands once the planner's progress, said
    past the bound, confirms it; the news said before it has arrived by then."""
    built_s, cure_ends_s = 857_983.1, 857_983.1 + 72 * 3600.0
    dog = StallWatchdog(stall_after_s=1500.0, confirm_wall_s=60.0)
    dog.observe(changes=40, sim_time_s=built_s, wall_s=100.0, planner_sim_s=built_s)
    dog.observe(changes=40, sim_time_s=cure_ends_s, wall_s=100.1, planner_sim_s=built_s)  # clock first
    assert dog.verdict() is None  # the planner has not said anything past the bound
    dog.observe(41, cure_ends_s, 101.5, awaited_sim_s=cure_ends_s, planner_sim_s=built_s)  # its progress
    for wall_s in (105.0, 120.0, 200.0):
        dog.observe(changes=41, sim_time_s=cure_ends_s + 0.2, wall_s=wall_s, planner_sim_s=cure_ends_s)
        assert dog.verdict() is None
    # nothing happens after the cure: the planner's progress past the bound confirms the stall at once
    dog.observe(changes=41, sim_time_s=cure_ends_s + 1600.0, wall_s=201.0, planner_sim_s=cure_ends_s + 1400.0)
    assert dog.verdict() is None
    dog.observe(changes=41, sim_time_s=cure_ends_s + 1601.0, wall_s=201.5, planner_sim_s=cure_ends_s + 1600.0)
    verdict = dog.verdict()
    assert verdict is not None and "nothing on the site changed for 1601 s of sim time" in verdict


def test_without_a_word_from_the_planner_a_stall_stands_after_the_wall_confirmation() -> None:
    dog = StallWatchdog(stall_after_s=100.0, confirm_wall_s=60.0)
    dog.observe(changes=3, sim_time_s=10.0, wall_s=0.0)
    dog.observe(changes=3, sim_time_s=200.0, wall_s=10.0)
    assert dog.verdict() is None
    dog.observe(changes=3, sim_time_s=900.0, wall_s=69.0)
    assert dog.verdict() is None
    dog.observe(changes=3, sim_time_s=905.0, wall_s=70.0)  # past the bound for 60 s of wall time
    verdict = dog.verdict()
    assert verdict is not None and "for 895 s of sim time" in verdict
