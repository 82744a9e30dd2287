"""A failed component whose body lies in the robots' way is carried back to its yard slot by one robot that
can carry it (a clear-away task); one that lies where it does no harm (its yard slot, at its target, on a
floor above the robots) gets none; one no robot can carry is said so, and every wait is bounded."""

from __future__ import annotations

import itertools

import pytest
from planner_builders import component, portal_manifest, robot_msg, state_msg

from bimbot.services.planner.capability import SiteRobot
from bimbot.services.planner.obstruction import can_clear, obstruction
from bimbot.services.planner.records import PlannerLimits
from bimbot.services.planner.scheduler import PlannerCore
from bimbot.services.planner.sources import plan_from_sequence
from bimbot.shared.fleet import default_fleet
from bimbot.shared.manifest import BoundingBox, Component, Manifest, Pose
from bimbot.shared.messages import (
    ClearOutcome,
    ComponentPoseMsg,
    ComponentState,
    PoseMsg,
    RobotState,
    TaskKind,
    TaskMsg,
    TaskStatus,
)
from bimbot.shared.reasons import Reason, ReasonCode
from bimbot.shared.site_plan import Rect, YardSlot
from bimbot.shared.support_graph import derive_sequence

S = ComponentState
FLEET = default_fleet().types
CARRIER, HUSKY, CRANE = FLEET["carrier"], FLEET["husky"], FLEET["tower_crane"]
LEDGER = "ledger"
LEDGER_SLOT = YardSlot(LEDGER, (2.0, -20.0, 0.1), (0, 0, 0, 1), Rect((-0.1, -20.2), (4.1, -19.8)), 0.2)
IDENTITY = (0.0, 0.0, 0.0, 1.0)


def _ledger(mass_kg: float = 900.0) -> Component:
    """A 4 m ledger (its frame at its centre) whose target is 3 m up, between two columns."""
    item = component(LEDGER, "IfcBeam", (0.0, -0.05, 3.0), (4.0, 0.05, 3.2))
    local = BoundingBox(min_m=(-2.0, -0.05, -0.1), max_m=(2.0, 0.05, 0.1))
    target = Pose(position_m=(2.0, 0.0, 3.1), quat_xyzw=IDENTITY, rpy_rad=(0, 0, 0))
    return item.model_copy(update={"bbox_local": local, "target_pose_world": target, "mass_kg": mass_kg})


def _manifest(mass_kg: float = 900.0) -> Manifest:
    manifest = portal_manifest()
    return manifest.model_copy(update={"components": [*manifest.components, _ledger(mass_kg)]})


def _core(
    robots: list[SiteRobot], *, mass_kg: float = 900.0, limits: PlannerLimits | None = None
) -> PlannerCore:
    manifest = _manifest(mass_kg)
    plan = plan_from_sequence(derive_sequence(manifest.components), manifest.components, "test")
    counter = itertools.count(1)
    core = PlannerCore(
        manifest,
        plan,
        new_id=lambda: f"ev{next(counter)}",
        robots=robots,
        slots={LEDGER: LEDGER_SLOT},
        limits=limits,
    )
    for robot in robots:
        core.robot_liveliness(robot.robot_id, True)
        core.observe_robot_state(robot_msg(robot.robot_id, robot.home_xy_yaw[:2]))
    return core


def _fails_at(core: PlannerCore, position_m: tuple[float, float, float], sim_time_s: float = 100.0) -> None:
    """The ledger fails and its body rests at ``position_m`` (lying as at its target, turned by nothing)."""
    pose = PoseMsg(position_m=position_m, quat_xyzw=IDENTITY)
    core.observe_component_pose(ComponentPoseMsg(guid=LEDGER, pose=pose, sim_time_s=sim_time_s, fixed=True))
    reason = Reason(code=ReasonCode.UNSTABLE, message="it moved 4.2 m after it was released")
    core.observe_component_state(state_msg(LEDGER, S.FAILED, sim_time_s=sim_time_s, reason=reason))


def _clear_tasks(out: list) -> list[TaskMsg]:
    return [m for m in out if isinstance(m, TaskMsg) and m.kind is TaskKind.CLEAR]


# --- which bodies obstruct (pure) -----------------------------------------------------------------------


def test_a_body_fallen_to_the_ground_off_its_target_obstructs() -> None:
    found = obstruction(_ledger(), ((2.0, 3.0, 0.1), IDENTITY), slot=LEDGER_SLOT)
    assert found is not None
    assert found.area_m2 > 0.3  # about its 4 m × 0.1 m on the ground (and the cells its outline crosses)
    assert found.centre_xy_m == (2.0, 3.0)


def test_a_body_where_it_does_no_harm_does_not_obstruct() -> None:
    ledger = _ledger()
    assert obstruction(ledger, ((2.012, 0.0, 3.1), IDENTITY), slot=LEDGER_SLOT) is None, "12 mm off target"
    assert obstruction(ledger, ((2.0, 3.0, 3.1), IDENTITY), slot=LEDGER_SLOT) is None, "above the robots"
    assert obstruction(ledger, ((2.0, -20.0, 0.1), IDENTITY), slot=LEDGER_SLOT) is None, "in its yard slot"
    staging = [Rect((0.0, 2.0), (5.0, 5.0))]
    assert obstruction(ledger, ((2.0, 3.0, 0.1), IDENTITY), slot=None, staging=staging) is None


def test_who_can_clear_a_body_is_said_by_capabilities_and_payload() -> None:
    ledger = _ledger()
    assert can_clear(CARRIER, ledger)  # drives, carries, 3 t
    assert not can_clear(HUSKY, ledger), "75 kg payload"
    assert not can_clear(CRANE, ledger), "it does not drive"
    assert can_clear(HUSKY, _ledger(mass_kg=50.0))


# --- the planner's decision ---------------------------------------------------------------------------


def test_a_failed_body_in_the_way_is_given_to_an_idle_robot_that_can_carry_it_to_its_yard_slot() -> None:
    core = _core([SiteRobot("r1", HUSKY, (0.0, 5.0, 0.0)), SiteRobot("r2", CARRIER, (30.0, 5.0, 0.0))])
    _fails_at(core, (2.0, 3.0, 0.1))
    tasks = _clear_tasks(core.step(1.0))
    assert len(tasks) == 1
    task = tasks[0]
    assert task.status is TaskStatus.ASSIGNED and task.robot_id == "r2", "the Husky is nearer, too weak"
    assert task.guid == LEDGER and task.task_id.endswith("-c")
    assert task.put_down_xy_m == pytest.approx((2.0, -20.0))  # the centre of its yard slot
    assert core.phase(LEDGER).value == "failed", "it stays failed: it is still not built"
    assert not core.done, "a body being carried away holds the end of the build"
    assert _clear_tasks(core.step(10.0)) != [], "re-sent until r2 says it works on it"


def test_a_failed_body_that_is_not_in_the_way_gets_no_clear_away() -> None:
    core = _core([SiteRobot("r2", CARRIER, (30.0, 5.0, 0.0))])
    _fails_at(core, (2.0, -20.0, 0.1))  # failed before it was ever picked: in its yard slot
    assert _clear_tasks(core.step(1.0)) == []
    assert core.clear_aways.records == {}


def test_a_body_no_robot_can_carry_is_not_cleared_and_says_why_at_once() -> None:
    core = _core([SiteRobot("r1", HUSKY, (0.0, 5.0, 0.0)), SiteRobot("r3", CRANE, (10.0, 10.0, 0.0))])
    _fails_at(core, (2.0, 3.0, 0.1))
    tasks = _clear_tasks(core.step(1.0))
    assert [task.status for task in tasks] == [TaskStatus.FAILED]
    reason = tasks[0].reason
    assert reason is not None and reason.code is ReasonCode.TOO_HEAVY
    assert "900 kg" in reason.message and "75 kg" in reason.message
    assert not core.clear_aways.open()


def test_the_robots_word_ends_the_clear_away_once_and_frees_the_robot() -> None:
    core = _core([SiteRobot("r2", CARRIER, (30.0, 5.0, 0.0))])
    _fails_at(core, (2.0, 3.0, 0.1))
    (task,) = _clear_tasks(core.step(1.0))
    working = robot_msg("r2", (2.0, 4.0), state=RobotState.PICK_UP, task_id=task.task_id, sim_time_s=150.0)
    core.observe_robot_state(working)
    outcome = ClearOutcome(task_id=task.task_id, guid=LEDGER, ok=True, sim_time_s=260.0)
    idle = robot_msg("r2", (2.0, -18.0), sim_time_s=260.0).model_copy(update={"cleared": outcome})
    core.observe_robot_state(idle)
    core.observe_robot_state(idle)  # repeated on every state message: applied once
    done = _clear_tasks(core.step(2.0))
    assert [(m.status, m.robot_id) for m in done] == [(TaskStatus.DONE, "r2")]
    record = core.clear_aways.records[LEDGER]
    assert record.phase.value == "cleared" and record.ended_s == 260.0
    assert _clear_tasks(core.step(3.0)) == []
    assert core.clear_aways.in_flight() is False


def test_a_clear_away_no_robot_works_on_ends_after_the_task_timeout() -> None:
    core = _core([SiteRobot("r2", CARRIER, (30.0, 5.0, 0.0))], limits=PlannerLimits(task_timeout_s=300.0))
    _fails_at(core, (2.0, 3.0, 0.1))
    core.step(1.0)
    core.observe_clock(100.0 + 301.0)
    tasks = _clear_tasks(core.step(2.0))
    assert [task.status for task in tasks] == [TaskStatus.FAILED]
    assert tasks[0].reason is not None and "said nothing of it for 300 s" in tasks[0].reason.message


def test_what_was_given_back_unreachable_waits_for_the_clear_away_and_then_gets_a_fresh_try() -> None:
    robots = [SiteRobot("r2", CARRIER, (30.0, 5.0, 0.0)), SiteRobot("r3", HUSKY, (10.0, -5.0, 0.0))]
    core = _core(robots, limits=PlannerLimits(max_give_backs=1))
    _fails_at(core, (2.0, 3.0, 0.1))
    (task,) = _clear_tasks(core.step(1.0))
    assert task.robot_id == "r2"
    core.observe_component_state(state_msg("foot_c", S.RELEASED, event="release", sim_time_s=100.0))
    cut_off = Reason(code=ReasonCode.UNREACHABLE, message="cut off from r1", robot_id="r1")
    core.observe_component_state(state_msg("foot_c", S.PICKING, robot_id="r1", sim_time_s=101.0))
    core.observe_component_state(
        state_msg("foot_c", S.RELEASED, event="abandon", sim_time_s=102.0, reason=cut_off)
    )
    assert core.phase("foot_c").value == "released", "at the bound of 1 give-back, but a body is in the way"
    core.step(1.5)
    assert core.robot_of("foot_c") is None, "it waits for the clear-away (r3 is idle and could take it)"
    outcome = ClearOutcome(task_id=task.task_id, guid=LEDGER, ok=True, sim_time_s=200.0)
    core.observe_robot_state(
        robot_msg("r2", (2.0, -18.0), sim_time_s=200.0).model_copy(update={"cleared": outcome})
    )
    core.step(2.0)
    assert core.robot_of("foot_c") is not None, "a fresh try once the way is clear"
