"""PlannerCore: ready set, nearest idle robot, retry, failure blocking, robot loss, progress, resends."""

from __future__ import annotations

import itertools
from pathlib import Path

import pytest
from planner_builders import PORTAL, portal_manifest, robot_msg, state_msg, twin_msg

from bimbot.services.planner.records import PlannerLimits
from bimbot.services.planner.scheduler import Phase, PlannerCore
from bimbot.services.planner.sources import PlanSource, SourceKind, load_plan, plan_from_sequence
from bimbot.shared.manifest import read_manifest
from bimbot.shared.messages import (
    ComponentEvent,
    ComponentEventMsg,
    ComponentPoseMsg,
    ComponentState,
    PoseMsg,
    RobotState,
    TaskMsg,
    TaskStatus,
)
from bimbot.shared.support_graph import derive_sequence

S = ComponentState


def _core(resend_s: float = 2.0, limits: PlannerLimits | None = None) -> PlannerCore:
    manifest = portal_manifest()
    plan = plan_from_sequence(derive_sequence(manifest.components), manifest.components, "test")
    counter = itertools.count(1)
    return PlannerCore(
        manifest,
        plan,
        resend_s=resend_s,
        new_id=lambda: f"ev{next(counter)}",
        limits=limits or PlannerLimits(),
    )


def _events(out: list, event: ComponentEvent | None = None) -> list[ComponentEventMsg]:
    return [m for m in out if isinstance(m, ComponentEventMsg) and (event is None or m.event is event)]


def _tasks(out: list, status: TaskStatus | None = None) -> list[TaskMsg]:
    return [m for m in out if isinstance(m, TaskMsg) and (status is None or m.status is status)]


def _construct(core: PlannerCore, guid: str, sim_time_s: float = 0.0) -> None:
    core.observe_component_state(state_msg(guid, S.CONSTRUCTED, event="verified", sim_time_s=sim_time_s))


def _release(core: PlannerCore, *guids: str) -> None:
    for guid in guids:
        core.observe_component_state(state_msg(guid, S.RELEASED, event="release"))


def _robots(core: PlannerCore, **where: tuple[float, float]) -> None:
    for robot_id, xy in where.items():
        core.robot_liveliness(robot_id, True)
        core.observe_robot_state(robot_msg(robot_id, xy))


def test_first_step_releases_every_footing_of_the_frame_at_once(frame_build: Path) -> None:
    manifest = read_manifest(frame_build)
    plan = load_plan(manifest, frame_build, PlanSource(SourceKind.DERIVE))
    out = PlannerCore(manifest, plan).step(0.0)
    footings = {item.guid for item in manifest.components if item.ifc_class == "IfcFooting"}
    assert {m.guid for m in _events(out, ComponentEvent.RELEASE)} == footings
    assert {m.guid for m in _tasks(out, TaskStatus.RELEASED)} == footings
    assert len(_events(out)) == 9


def test_successor_is_released_only_when_all_its_predecessors_are_constructed() -> None:
    core = _core()
    assert {m.guid for m in _events(core.step(0.0))} == {"foot_a", "foot_b", "foot_c"}
    for guid in ("foot_a", "foot_b"):
        _construct(core, guid)
    assert {m.guid for m in _events(core.step(0.1), ComponentEvent.RELEASE)} == {"col_a", "col_b"}
    _construct(core, "col_a")
    assert _events(core.step(0.2), ComponentEvent.RELEASE) == []
    assert core.phase("beam") is Phase.WAITING
    _construct(core, "col_b")
    assert [m.guid for m in _events(core.step(0.3), ComponentEvent.RELEASE)] == ["beam"]


def test_released_task_goes_to_the_nearest_idle_robot() -> None:
    core = _core()
    _robots(core, far=(20.0, 0.0), near=(4.5, 0.0))
    core.step(0.0)
    _release(core, "foot_b")  # target at (4, 0)
    assigned = _tasks(core.step(0.1), TaskStatus.ASSIGNED)
    assert [(m.guid, m.robot_id) for m in assigned] == [("foot_b", "near")]
    assert assigned[0].task_id and assigned[0].component_key == "foot_b"


def test_component_last_pose_decides_distance_over_its_target() -> None:
    core = _core()
    _robots(core, yard=(30.0, 0.0), site=(4.5, 0.0))
    core.step(0.0)
    pose = PoseMsg(position_m=(29.0, 0.0, 0.0), quat_xyzw=(0, 0, 0, 1))
    core.observe_component_pose(ComponentPoseMsg(guid="foot_b", pose=pose, sim_time_s=0.0))
    _release(core, "foot_b")
    assert [m.robot_id for m in _tasks(core.step(0.1), TaskStatus.ASSIGNED)] == ["yard"]


def test_task_is_assigned_only_once_its_component_reports_released() -> None:
    core = _core()
    _robots(core, r1=(0.0, 0.0))
    assert _tasks(core.step(0.0), TaskStatus.ASSIGNED) == []
    _release(core, "foot_a")
    assert [m.guid for m in _tasks(core.step(0.1), TaskStatus.ASSIGNED)] == ["foot_a"]


def test_busy_robot_gets_nothing_until_its_part_is_done_and_it_is_idle() -> None:
    core = _core()
    _robots(core, r1=(0.0, 0.0))
    core.step(0.0)
    _release(core, "foot_a", "foot_b")
    assert [m.guid for m in _tasks(core.step(0.1), TaskStatus.ASSIGNED)] == ["foot_a"]
    assert _tasks(core.step(0.2), TaskStatus.ASSIGNED) == []
    core.observe_robot_state(robot_msg("r1", (0.0, 0.0), RobotState.ASSEMBLE))
    core.observe_component_state(state_msg("foot_a", S.VERIFYING, event="place", robot_id="r1"))
    assert _tasks(core.step(0.3), TaskStatus.ASSIGNED) == []  # robot still reports assemble
    core.observe_robot_state(robot_msg("r1", (0.0, 0.0)))
    assert [(m.guid, m.robot_id) for m in _tasks(core.step(0.4), TaskStatus.ASSIGNED)] == [("foot_b", "r1")]


def test_robot_without_liveliness_is_never_assigned() -> None:
    core = _core()
    core.observe_robot_state(robot_msg("ghost", (0.0, 0.0)))
    core.step(0.0)
    _release(core, "foot_a")
    assert _tasks(core.step(0.1), TaskStatus.ASSIGNED) == []


def test_misplaced_component_gets_retry_and_is_assigned_again() -> None:
    core = _core()
    _robots(core, r1=(0.0, 0.0))
    core.step(0.0)
    _release(core, "foot_a")
    core.step(0.1)
    core.observe_component_state(state_msg("foot_a", S.VERIFYING, event="place", robot_id="r1"))
    core.observe_component_state(state_msg("foot_a", S.MISPLACED, event="verify", attempt=1))
    out = core.step(0.2)
    assert [m.guid for m in _events(out, ComponentEvent.RETRY)] == ["foot_a"]
    assert [m.attempt for m in _tasks(out, TaskStatus.RELEASED)] == [1]
    assert core.phase("foot_a") is Phase.RELEASED
    core.observe_component_state(state_msg("foot_a", S.RELEASED, event="retry", attempt=1))
    again = _tasks(core.step(0.3), TaskStatus.ASSIGNED)
    assert [(m.guid, m.robot_id, m.attempt) for m in again] == [("foot_a", "r1", 1)]


def test_failed_component_blocks_its_dependents_and_independent_work_goes_on() -> None:
    core = _core()
    core.step(0.0)
    core.observe_component_state(state_msg("foot_a", S.FAILED, event="verify", attempt=3))
    out = core.step(0.1)
    assert {m.guid for m in _tasks(out, TaskStatus.BLOCKED)} == {"col_a", "beam"}
    assert [m.guid for m in _tasks(out, TaskStatus.FAILED)] == ["foot_a"]
    for guid in ("foot_b", "foot_c"):
        _construct(core, guid)
    released = {m.guid for m in _events(core.step(0.2), ComponentEvent.RELEASE)}
    assert released == {"col_b", "post_c"}
    for guid in ("col_b", "post_c"):
        _construct(core, guid)
    assert _events(core.step(0.3), ComponentEvent.RELEASE) == []  # beam never released
    assert core.done
    progress = core.progress()
    assert progress.failed == ["foot_a"] and set(progress.blocked) == {"col_a", "beam"} and progress.done


GRACE_S = 20.0  # a site across hosts (bimbot run --routers 2 gives 30 s)
WITH_GRACE = PlannerLimits(lost_grace_wall_s=GRACE_S)


def test_lost_robot_task_is_abandoned_and_reassigned() -> None:
    core = _core(limits=WITH_GRACE)
    _robots(core, r1=(0.0, 0.0), r2=(9.0, 0.0))
    core.step(0.0)
    _release(core, "foot_a")
    assert [m.robot_id for m in _tasks(core.step(0.1), TaskStatus.ASSIGNED)] == ["r1"]
    core.observe_component_state(state_msg("foot_a", S.PICKING, event="pick", robot_id="r1"))
    core.robot_liveliness("r1", False)
    assert _events(core.step(0.1 + GRACE_S / 2), ComponentEvent.ABANDON) == []  # within the grace
    out = core.step(0.2 + GRACE_S)
    abandon = _events(out, ComponentEvent.ABANDON)
    assert [(m.guid, m.robot_id) for m in abandon] == [("foot_a", "r1")]
    assert _tasks(out, TaskStatus.ASSIGNED) == []  # not before the component is released again
    core.observe_component_state(state_msg("foot_a", S.RELEASED, event="abandon"))
    assert [m.robot_id for m in _tasks(core.step(0.3), TaskStatus.ASSIGNED)] == ["r2"]


def test_robot_lost_before_picking_has_its_task_reassigned_without_abandon() -> None:
    core = _core()
    _robots(core, r1=(0.0, 0.0), r2=(9.0, 0.0))
    core.step(0.0)
    _release(core, "foot_a")
    core.step(0.1)
    core.robot_liveliness("r1", False)
    out = core.step(0.2)  # no grace by default (one host: a lost robot is a dead process)
    assert _events(out, ComponentEvent.ABANDON) == []
    assert [m.robot_id for m in _tasks(out, TaskStatus.ASSIGNED)] == ["r2"]


def test_a_robot_cut_off_for_less_than_the_grace_that_still_reports_its_task_keeps_it() -> None:
    """A router restart takes a live robot off the bus for seconds: nothing is given back or reassigned."""
    core = _core(limits=WITH_GRACE)
    _robots(core, r1=(0.0, 0.0), r2=(9.0, 0.0))
    core.step(0.0)
    _release(core, "foot_a")
    (task,) = _tasks(core.step(0.1), TaskStatus.ASSIGNED)
    core.observe_component_state(state_msg("foot_a", S.TRANSPORTING, event="attach", robot_id="r1"))
    core.robot_liveliness("r1", False)
    core.step(5.0)
    core.robot_liveliness("r1", True)
    core.observe_robot_state(robot_msg("r1", (1.0, 0.0), RobotState.PICK_UP, task_id=task.task_id))
    out = core.step(0.2 + 2 * GRACE_S)
    assert _events(out, ComponentEvent.ABANDON) == [] and _tasks(out, TaskStatus.ASSIGNED) == []
    assert core.robot_of("foot_a") == "r1" and core.phase("foot_a") is Phase.ASSIGNED


def test_a_robot_back_within_the_grace_without_its_task_restarted_and_its_task_is_given_back() -> None:
    core = _core(limits=WITH_GRACE)
    _robots(core, r1=(0.0, 0.0), r2=(9.0, 0.0))
    core.step(0.0)
    _release(core, "foot_a")
    core.step(0.1)
    core.observe_component_state(state_msg("foot_a", S.PICKING, event="pick", robot_id="r1"))
    core.robot_liveliness("r1", False)
    core.step(2.0)
    core.robot_liveliness("r1", True)
    core.observe_robot_state(robot_msg("r1", (0.0, 0.0)))  # idle, no task: a new process
    abandon = _events(core.step(3.0), ComponentEvent.ABANDON)
    assert [(m.guid, m.robot_id) for m in abandon] == [("foot_a", "r1")]


def test_progress_counts_percent_and_finish_estimate() -> None:
    core = _core()
    _robots(core, r1=(0.0, 0.0), r2=(4.0, 0.0))
    core.step(0.0)
    first = core.progress()
    assert first.total == 7 and first.counts["planned"] == 7 and first.percent_constructed == 0.0
    assert first.estimated_finish_sim_time_s is None and not first.done
    core.observe_clock(100.0)
    _release(core, "foot_a")
    core.step(0.1)  # assigned at sim 100 s
    _construct(core, "foot_a", sim_time_s=130.0)
    progress = core.progress()
    assert progress.counts["constructed"] == 1 and progress.counts["planned"] == 6
    assert progress.percent_constructed == pytest.approx(100 / 7)
    # mean task 30 s × 6 remaining / 2 robots after sim 130 s
    assert progress.estimated_finish_sim_time_s == pytest.approx(130.0 + 30.0 * 6 / 2)


def test_unobserved_release_is_resent_with_the_same_event_id() -> None:
    core = _core(resend_s=2.0)
    first = {m.guid: m.event_id for m in _events(core.step(0.0))}
    assert _events(core.step(1.0)) == []
    _release(core, "foot_a")
    again = {m.guid: m.event_id for m in _events(core.step(2.5))}
    assert again == {"foot_b": first["foot_b"], "foot_c": first["foot_c"]}
    _release(core, "foot_b", "foot_c")
    assert _events(core.step(10.0)) == []


def test_unacknowledged_assignment_is_resent_until_the_robot_reports_it() -> None:
    core = _core(resend_s=1.0)
    _robots(core, r1=(0.0, 0.0))
    core.step(0.0)
    _release(core, "foot_a")
    (assigned,) = _tasks(core.step(0.1), TaskStatus.ASSIGNED)
    assert _tasks(core.step(1.5), TaskStatus.ASSIGNED) == [assigned]
    core.observe_robot_state(
        robot_msg("r1", (0.0, 0.0), RobotState.DETECT_COMPONENT_POSITION, assigned.task_id)
    )
    assert _tasks(core.step(5.0), TaskStatus.ASSIGNED) == []


def test_twin_sync_never_releases_constructed_components_again() -> None:
    core = _core()
    for guid in ("foot_a", "foot_b"):
        core.observe_twin(twin_msg(guid, S.CONSTRUCTED, placed_at_s=5.0))
    core.finish_sync()
    released = {m.guid for m in _events(core.step(0.0), ComponentEvent.RELEASE)}
    assert released == {"foot_c", "col_a", "col_b"}
    assert core.phase("foot_a") is Phase.DONE


def test_a_stale_twin_answer_never_takes_a_constructed_component_back() -> None:
    """The twin refresh asks an in-flight component's agent for its record; the answer can arrive after the
    state messages of later transitions (a different route over the bus). A bench build stalled for 1,500 s
    when an answer saying "assembling" overwrote a column's "constructed": its beam was never released."""
    core = _core()
    core.step(0.0)
    for guid in ("foot_a", "foot_b"):
        _construct(core, guid)
    core.step(0.1)
    assembling = state_msg("col_a", S.ASSEMBLING, event="arrive", previous=S.TRANSPORTING, wall_time_s=9.0)
    core.observe_component_state(assembling)
    core.observe_component_state(
        state_msg("col_a", S.CONSTRUCTED, event="verified", previous=S.VERIFYING, wall_time_s=10.0)
    )
    core.observe_twin(twin_msg("col_a", S.ASSEMBLING, history=[assembling]))  # asked at wall 9, late
    core.observe_component_state(assembling)  # a late repeat of the old message
    assert core.progress().counts["constructed"] == 3
    _construct(core, "col_b")
    assert [m.guid for m in _events(core.step(0.3), ComponentEvent.RELEASE)] == ["beam"]


def test_a_twin_answer_newer_than_the_last_message_still_applies() -> None:
    """The refresh exists for messages that went missing: a twin whose last transition is newer wins."""
    core = _core()
    core.step(0.0)
    core.observe_component_state(state_msg("foot_a", S.RELEASED, event="release", wall_time_s=1.0))
    verified = state_msg("foot_a", S.CONSTRUCTED, event="verified", previous=S.VERIFYING, wall_time_s=5.0)
    core.observe_twin(twin_msg("foot_a", S.CONSTRUCTED, history=[verified]))
    assert core.phase("foot_a") is Phase.DONE


def test_done_only_when_every_task_is_done_failed_or_blocked() -> None:
    core = _core()
    for guid in PORTAL[:-1]:
        _construct(core, guid)
        core.step(0.0)
        assert not core.done
    _construct(core, "beam")
    core.step(0.1)
    assert core.done and core.progress().percent_constructed == 100.0


def test_in_flight_names_the_released_and_assigned_components_whose_twins_to_ask() -> None:
    core = _core()
    assert core.in_flight() == []
    core.step(0.0)  # releases the footings
    assert set(core.in_flight()) == {"foot_a", "foot_b", "foot_c"}
    _construct(core, "foot_a")
    core.step(1.0)
    assert "foot_a" not in core.in_flight()
