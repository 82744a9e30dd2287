"""Quiet-site skips: the planner's core says until when nothing can happen (curing, timed work, a held
robot, its own watchdog) and says nothing while anything moves or could start; the skip requests are paced."""

from __future__ import annotations

import itertools

from planner_builders import PUMP, portal_manifest, robot_msg, state_msg, with_methods

from bimbot.services.planner.capability import SiteRobot
from bimbot.services.planner.quiet import Skip
from bimbot.services.planner.scheduler import PlannerCore, PlannerLimits
from bimbot.services.planner.skip_requests import SkipAnswer, Skipper
from bimbot.services.planner.sources import plan_from_sequence
from bimbot.shared.construction_methods import ConstructionMethod
from bimbot.shared.fleet import default_fleet
from bimbot.shared.messages import ComponentState, PhysicsReply, RobotState, SkipRequest
from bimbot.shared.support_graph import derive_sequence

S = ComponentState
CARRIER = default_fleet().types["carrier"]
CURED_AT_S = 100.0 + 86400.0  # foot_a constructed at 100 s, cured a day later (planner_builders)
DONE_AT_100 = ("foot_a", "foot_b", "foot_c", "col_b", "post_c")


def _core(limits: PlannerLimits | None = None) -> PlannerCore:
    """The portal with foot_a cast in place; a carrier r1 and a pump r4, alive and idle."""
    manifest = with_methods(portal_manifest(), foot_a=ConstructionMethod.CAST_IN_PLACE)
    plan = plan_from_sequence(derive_sequence(manifest.components), manifest.components, "test")
    robots = [SiteRobot("r1", CARRIER, (0.0, -5.0, 0.0)), SiteRobot("r4", PUMP, (20.0, 0.0, 0.0))]
    counter = itertools.count(1)
    core = PlannerCore(
        manifest, plan, new_id=lambda: f"ev{next(counter)}", robots=robots, slots={}, limits=limits
    )
    for robot in robots:
        core.robot_liveliness(robot.robot_id, True)
        core.observe_robot_state(robot_msg(robot.robot_id, robot.home_xy_yaw[:2]))
    return core


def _curing_site(*, except_for: tuple[str, ...] = (), limits: PlannerLimits | None = None) -> PlannerCore:
    """All but col_a and the beam constructed at 100 s: col_a waits for foot_a to cure, the beam for col_a."""
    core = _core(limits)
    core.step(0.0)
    for guid in DONE_AT_100:
        if guid not in except_for:
            core.observe_component_state(state_msg(guid, S.CONSTRUCTED, event="verified", sim_time_s=100.0))
    core.step(1.0)
    return core


def test_a_site_waiting_only_for_curing_may_skip_to_the_end_of_the_cure() -> None:
    skip = _curing_site().quiet_until()
    assert skip is not None and skip.to_sim_s == CURED_AT_S
    assert skip.why == "curing of IfcFooting (foot_a) (holds IfcColumn (col_a)) until 86500 s"


def test_a_robot_on_the_move_or_a_component_carried_or_verifying_keeps_the_site_from_skipping() -> None:
    core = _curing_site()
    core.observe_robot_state(robot_msg("r1", (3.0, -5.0), RobotState.PICK_UP, sim_time_s=101.0))
    assert core.quiet_until() is None
    for state in (S.TRANSPORTING, S.VERIFYING):
        core = _curing_site(except_for=("post_c",))
        core.observe_component_state(
            state_msg("post_c", state, event="test", robot_id="r1", sim_time_s=100.0)
        )
        core.observe_robot_state(robot_msg("r1", (3.0, -5.0), sim_time_s=101.0))  # even if r1 says idle
        core.step(2.0)
        assert core.quiet_until() is None, state


def test_a_release_on_its_way_or_a_task_an_idle_robot_could_take_keeps_the_site_from_skipping() -> None:
    core = _core()
    core.step(0.0)  # the footings released: the events are on their way, the agents have not answered
    assert core.quiet_until() is None
    core = _curing_site(except_for=("post_c",))  # post_c released, and the idle carrier can build it
    core.observe_component_state(state_msg("post_c", S.RELEASED, event="release", sim_time_s=100.0))
    core.step(2.0)
    assert core.robot_of("post_c") == "r1"
    assert core.quiet_until() is None  # the assignment is on its way


def test_a_released_task_whose_only_robot_is_held_makes_the_hold_end_the_next_event() -> None:
    limits = PlannerLimits(hold_after_give_backs=1, hold_s=500.0)
    core = _curing_site(except_for=("post_c",), limits=limits)
    core.observe_component_state(state_msg("post_c", S.RELEASED, event="release", sim_time_s=100.0))
    core.step(2.0)
    core.observe_component_state(
        state_msg("post_c", S.PICKING, event="pick", robot_id="r1", sim_time_s=100.0)
    )
    given_back = state_msg("post_c", S.RELEASED, event="abandon", robot_id="r1", sim_time_s=100.0)
    core.observe_component_state(given_back.model_copy(update={"previous": S.PICKING}))
    core.step(3.0)
    assert core.robot_of("post_c") is None  # r1 gave it back and is held; the pump cannot build it
    assert core.quiet_until() == Skip(600.0, "the hold of r1 after its give-backs until 600 s")


def test_a_robot_placing_its_component_may_be_holding_it_so_physics_is_asked_naming_it() -> None:
    """Set down, a member is held while its crew connects it: only physics knows whether it is held and
    until when, so the skip names the robot (physics refuses unless it holds its load) and goes as far as
    the task's no-progress bound (physics stops it at the hold's end)."""
    core = _curing_site(except_for=("post_c",))
    core.observe_component_state(state_msg("post_c", S.RELEASED, event="release", sim_time_s=100.0))
    core.step(2.0)
    assert core.robot_of("post_c") == "r1"
    placing = robot_msg("r1", (3.0, -5.0), RobotState.ASSEMBLE, task_id="T0005", sim_time_s=120.0)
    core.observe_robot_state(placing.model_copy(update={"guid": "post_c"}))
    for state in (S.PICKING, S.TRANSPORTING):  # on its way: no skip
        core.observe_component_state(state_msg("post_c", state, event="e", robot_id="r1", sim_time_s=110.0))
        core.step(3.0)
        assert core.quiet_until() is None, state
    core.observe_component_state(
        state_msg("post_c", S.ASSEMBLING, event="assemble", robot_id="r1", sim_time_s=120.0)
    )
    core.step(4.0)
    skip = core.quiet_until()
    assert skip is not None and skip.holding == ("r1",)
    assert skip.to_sim_s == min(CURED_AT_S, 120.0 + 1200.0) and "no-progress bound" in skip.why
    core.observe_component_state(
        state_msg("post_c", S.VERIFYING, event="verify", robot_id="r1", sim_time_s=125.0)
    )
    core.step(5.0)
    assert core.quiet_until() is None, "verifying: the agents are about to answer"


def _pouring_site(busy_until_s: float | None) -> PlannerCore:
    """foot_a being formed by the pump r4 (since 10 s), which says it is busy until ``busy_until_s``."""
    core = _core()
    core.step(0.0)
    for guid in ("foot_b", "foot_c"):
        core.observe_component_state(state_msg(guid, S.CONSTRUCTED, event="verified", sim_time_s=5.0))
    core.observe_component_state(state_msg("foot_a", S.RELEASED, event="release", sim_time_s=5.0))
    core.step(1.0)
    assert core.robot_of("foot_a") == "r4"
    core.observe_component_state(state_msg("foot_a", S.FORMING, event="form", robot_id="r4", sim_time_s=10.0))
    work = robot_msg("r4", (20.0, 0.0), RobotState.WORK_IN_PLACE, task_id="T0001", sim_time_s=10.0)
    core.observe_robot_state(work.model_copy(update={"busy_until_s": busy_until_s}))
    for guid in ("col_b", "post_c"):  # the carrier built what it could: only the pour is going on
        core.observe_component_state(state_msg(guid, S.CONSTRUCTED, event="verified", sim_time_s=10.0))
    core.step(2.0)
    return core


def test_a_site_where_only_timed_work_goes_on_may_skip_to_its_end_but_not_past_the_watchdog() -> None:
    skip = _pouring_site(3610.0).quiet_until()
    assert skip is not None and skip.to_sim_s == 3610.0 and "r4 at work on IfcFooting (foot_a)" in skip.why
    # a robot that says it is busy for longer than its work's bound: the skip stops at the planner's bound
    skip = _pouring_site(100_000.0).quiet_until()
    assert skip is not None and skip.to_sim_s == 10.0 + 1200.0 + 3600.0 + 1800.0
    assert "no-progress bound of T0001" in skip.why


def test_timed_work_without_an_end_or_past_it_keeps_the_site_from_skipping() -> None:
    assert _pouring_site(None).quiet_until() is None
    core = _pouring_site(3610.0)
    core.observe_clock(3610.0)
    assert core.quiet_until() is None  # its end has come: the robot is about to report


def test_a_skip_shorter_than_the_minimum_or_without_the_robots_types_is_not_asked_for() -> None:
    core = _curing_site()
    core.observe_clock(CURED_AT_S - 0.5)
    assert core.quiet_until(min_skip_s=1.0) is None
    near = core.quiet_until(min_skip_s=0.1)
    assert near is not None and near.to_sim_s == CURED_AT_S
    manifest = with_methods(portal_manifest(), foot_a=ConstructionMethod.CAST_IN_PLACE)
    plan = plan_from_sequence(derive_sequence(manifest.components), manifest.components, "test")
    assert PlannerCore(manifest, plan).quiet_until() is None


def test_skip_requests_go_one_at_a_time_and_a_refused_one_is_asked_again_only_after_the_pause() -> None:
    sent: list[SkipRequest] = []
    skipper = Skipper(sent.append, retry_s=2.0, timeout_s=5.0, check_s=0.5)
    skip = Skip(500.0, "curing of foot_a until 500 s")
    assert skipper.tick(lambda: None, 0.0) is None and sent == []
    assert skipper.tick(lambda: skip, 0.1) is None  # the site was looked at 0.1 s ago
    assert skipper.tick(lambda: skip, 0.5) == SkipRequest(to_sim_s=500.0, why=skip.why)
    assert skipper.tick(lambda: skip, 3.0) is None  # the first is still unanswered
    refused = PhysicsReply(ok=False, reason="r1 is moving", sim_time_s=101.0)
    skipper.answered(SkipAnswer(sent[0], refused))
    assert skipper.tick(lambda: skip, 3.0) is not None and len(sent) == 2
    skipper.answered(SkipAnswer(sent[1], None, "no reply (timeout)"))
    assert skipper.tick(lambda: skip, 4.5) is None  # within the pause after the last question
    assert skipper.tick(lambda: skip, 5.0) is not None
    skipper.answered(SkipAnswer(sent[2], PhysicsReply(ok=True, sim_time_s=500.0)))
    assert (skipper.accepted, skipper.refused) == (1, 2)
    assert skipper.tick(lambda: skip, 20.0) is not None  # a lost answer does not stop it for good
    assert skipper.tick(lambda: skip, 27.0) is not None


def test_a_lock_step_skip_request_names_the_participant_whose_answer_counts_it() -> None:
    """Physics waits for a request the planner's answer to a step announced (``StepDoneMsg.requests``):
    the request says who asked, so physics can count it in when it comes."""
    sent: list[SkipRequest] = []
    skipper = Skipper(sent.append, retry_s=25, timeout_s=100, check_s=5, participant="planner")
    asked = skipper.tick(lambda: Skip(500.0, "curing"), 40.0, step=40)
    assert asked == SkipRequest(to_sim_s=500.0, why="curing", step=40, participant="planner")
    assert sent == [asked]
    held = Skipper(sent.append, retry_s=25, timeout_s=100, check_s=5, participant="planner")
    asked = held.tick(lambda: Skip(500.0, "bound", ("r1", "r2")), 40.0, step=40)
    assert asked is not None and asked.holding == ["r1", "r2"], "the robots physics must see holding"
