"""The planner ends every task: feasibility before the build, bounded give-backs, the no-progress watchdog,
blocked dependents with a reason, and access-aware plans on the generated site model."""

from __future__ import annotations

import itertools
from dataclasses import replace
from pathlib import Path

import pytest
from planner_builders import one_robot_site_info, portal_manifest, robot_msg, state_msg
from site_models import ROOM_WALLS

from bimbot.services.planner.access_plan import _stand_only, access_plan
from bimbot.services.planner.capability import SiteRobot
from bimbot.services.planner.feasibility import component_feasibility, infeasible
from bimbot.services.planner.scheduler import Phase, PlannerCore, PlannerLimits
from bimbot.services.planner.sources import PlanError, PlanSource, SourceKind, load_plan, plan_from_sequence
from bimbot.shared.construction_methods import ConstructionMethod
from bimbot.shared.fleet import default_fleet
from bimbot.shared.manifest import MassSource, read_manifest
from bimbot.shared.messages import (
    ComponentEvent,
    ComponentEventMsg,
    ComponentState,
    RobotState,
    TaskMsg,
)
from bimbot.shared.reasons import Reason, ReasonCode
from bimbot.shared.robot_description import DEFAULT_ROBOT
from bimbot.shared.sequence import sequence_from_predecessors
from bimbot.shared.site_access import AccessConfig, SiteAccess
from bimbot.shared.site_layout import plan_site
from bimbot.shared.support_graph import derive_sequence, support_predecessors

S = ComponentState


def _core(limits: PlannerLimits | None = None) -> PlannerCore:
    manifest = portal_manifest()
    plan = plan_from_sequence(derive_sequence(manifest.components), manifest.components, "test")
    counter = itertools.count(1)
    return PlannerCore(manifest, plan, new_id=lambda: f"ev{next(counter)}", limits=limits or PlannerLimits())


def _events(out: list, event: ComponentEvent) -> list[ComponentEventMsg]:
    return [m for m in out if isinstance(m, ComponentEventMsg) and m.event is event]


def _assigned_to_r1(core: PlannerCore, guid: str) -> None:
    core.robot_liveliness("r1", True)
    core.observe_robot_state(robot_msg("r1", (0.0, 0.0)))
    core.step(0.0)
    core.observe_component_state(state_msg(guid, S.RELEASED, event="release"))
    core.step(0.1)
    assert core.phase(guid) is Phase.ASSIGNED and core.robot_of(guid) == "r1"


def test_a_component_no_robot_can_carry_fails_before_release_and_blocks_what_rests_on_it() -> None:
    core = _core()
    too_heavy = Reason(code=ReasonCode.TOO_HEAVY, message="5,760 kg exceeds the payload of 1,000 kg")
    core.fail_at_start({"foot_a": too_heavy})
    out = core.step(0.0)
    [fail] = _events(out, ComponentEvent.FAIL)
    assert fail.guid == "foot_a" and fail.reason == too_heavy
    blocked = {m.guid: m.reason for m in _events(out, ComponentEvent.BLOCK)}
    assert set(blocked) == {"col_a", "beam"}  # col_a rests on foot_a, the beam on col_a
    assert all(r.code is ReasonCode.BLOCKED_BY and r.guid == "foot_a" for r in blocked.values())
    assert {m.guid for m in _events(out, ComponentEvent.RELEASE)} == {"foot_b", "foot_c"}
    progress = core.progress()
    assert progress.reasons["foot_a"].code is ReasonCode.TOO_HEAVY
    assert progress.reasons["beam"].code is ReasonCode.BLOCKED_BY
    failed_task = next(m for m in out if isinstance(m, TaskMsg) and m.guid == "foot_a")
    assert failed_task.reason == too_heavy


def test_in_a_chained_schedule_a_failure_blocks_only_what_rests_on_it_and_the_rest_goes_on() -> None:
    manifest = portal_manifest()
    chain = ("foot_a", "col_a", "foot_b", "col_b", "foot_c", "post_c", "beam")
    preds = {guid: {chain[i - 1]} for i, guid in enumerate(chain) if i}
    sequence = sequence_from_predecessors(chain, preds, source="ifc_schedule")
    plan = plan_from_sequence(sequence, manifest.components, "chain")
    assert plan.predecessors["foot_b"] == frozenset({"col_a"})  # the schedule's order, not a support
    core = PlannerCore(manifest, plan)
    core.fail_at_start({"foot_a": Reason(code=ReasonCode.TOO_HEAVY, message="too heavy")})
    out = core.step(0.0)
    assert {m.guid for m in _events(out, ComponentEvent.BLOCK)} == {"col_a", "beam"}  # they rest on it
    assert [m.guid for m in _events(out, ComponentEvent.RELEASE)] == ["foot_b"]  # the schedule goes on
    for guid, then in (("foot_b", "col_b"), ("col_b", "foot_c")):
        core.observe_component_state(state_msg(guid, S.CONSTRUCTED, event="verified"))
        assert [m.guid for m in _events(core.step(1.0), ComponentEvent.RELEASE)] == [then]
    assert core.phase("beam") is Phase.BLOCKED


def test_in_a_chained_schedule_what_follows_a_blocked_component_waits_for_what_came_before_it() -> None:
    """A blocked or failed component counts as done for the schedule, but only once everything before it
    is out of the way: the beam after a blocked post waited for no column at all and was placed on a
    column still being set up (and fell off it, in the simulation)."""
    manifest = portal_manifest()
    chain = ("foot_a", "foot_b", "foot_c", "col_a", "col_b", "post_c", "beam")
    preds = {guid: {chain[i - 1]} for i, guid in enumerate(chain) if i}
    plan = plan_from_sequence(
        sequence_from_predecessors(chain, preds, source="ifc_schedule"), manifest.components, "chain"
    )
    core = PlannerCore(manifest, plan)
    core.fail_at_start({"foot_c": Reason(code=ReasonCode.TOO_HEAVY, message="too heavy")})
    assert [m.guid for m in _events(core.step(0.0), ComponentEvent.RELEASE)] == ["foot_a"]
    core.observe_component_state(state_msg("foot_a", S.CONSTRUCTED, event="verified"))
    assert [m.guid for m in _events(core.step(1.0), ComponentEvent.RELEASE)] == ["foot_b"]
    core.observe_component_state(state_msg("foot_b", S.CONSTRUCTED, event="verified"))
    released = [m.guid for m in _events(core.step(2.0), ComponentEvent.RELEASE)]
    assert released == ["col_a"]  # foot_c failed: the schedule goes on; post_c (on foot_c) is blocked
    assert core.phase("post_c") is Phase.BLOCKED and core.phase("beam") is Phase.WAITING  # col_b first
    core.observe_component_state(state_msg("col_a", S.CONSTRUCTED, event="verified"))
    assert [m.guid for m in _events(core.step(3.0), ComponentEvent.RELEASE)] == ["col_b"]
    core.observe_component_state(state_msg("col_b", S.CONSTRUCTED, event="verified"))
    assert [m.guid for m in _events(core.step(4.0), ComponentEvent.RELEASE)] == ["beam"]


def test_a_component_given_back_max_times_fails_with_the_last_robots_reason() -> None:
    core = _core(PlannerLimits(max_give_backs=3, hold_after_give_backs=10))  # (holds: the next test)
    for attempt in range(3):
        if attempt:
            core.observe_robot_state(robot_msg("r1", (0.0, 0.0)))
            core.step(1.0 + attempt)
            assert core.phase("foot_b") is Phase.ASSIGNED
        else:
            _assigned_to_r1(core, "foot_b")
        core.observe_component_state(
            state_msg("foot_b", S.PICKING, event="pick", robot_id="r1", sim_time_s=attempt)
        )
        why = Reason(code=ReasonCode.UNREACHABLE, message=f"target cut off ({attempt})", robot_id="r1")
        core.observe_component_state(
            state_msg(
                "foot_b", S.RELEASED, event="abandon", robot_id="r1", sim_time_s=attempt + 0.5, reason=why
            )
        )
    out = core.step(10.0)
    [fail] = _events(out, ComponentEvent.FAIL)
    assert fail.guid == "foot_b" and fail.reason is not None
    assert fail.reason.code is ReasonCode.UNREACHABLE
    assert "given back 3 times" in fail.reason.message and "(2)" in fail.reason.message
    assert core.phase("foot_b") is Phase.FAILED
    assert core.phase("col_b") is Phase.BLOCKED


def test_a_task_without_progress_is_taken_back_after_its_bound_of_sim_time() -> None:
    core = _core(PlannerLimits(task_timeout_s=100.0, max_give_backs=2))
    _assigned_to_r1(core, "foot_b")
    core.observe_clock(99.0)
    core.step(1.0)
    assert core.phase("foot_b") is Phase.ASSIGNED
    core.observe_clock(101.0)
    out = core.step(2.0)
    statuses = [m.status for m in out if isinstance(m, TaskMsg) and m.guid == "foot_b"]
    assert statuses[0] == "released"  # taken back ...
    assert core.phase("foot_b") is Phase.ASSIGNED  # ... and handed out again (r1 is the only robot)
    core.observe_clock(200.0)
    core.step(3.0)
    assert core.phase("foot_b") is Phase.ASSIGNED  # the watchdog's clock restarted at the new assignment
    core.observe_clock(202.0)
    core.step(4.0)
    assert core.phase("foot_b") is Phase.FAILED
    reason = core.reason_of("foot_b")
    assert (
        reason is not None
        and reason.code is ReasonCode.NO_PROGRESS
        and "given back 2 times" in reason.message
    )


def test_a_component_a_placement_cuts_off_fails_naming_that_placement_and_what_to_do() -> None:
    """The restaurant's glazed panel, cut off once its door stood, failed 'cut off' with no word of why
    or what to do, while the plan's warning at the start had named the door."""
    manifest = portal_manifest()
    plan = plan_from_sequence(derive_sequence(manifest.components), manifest.components, "test")
    counter = itertools.count(1)
    core = PlannerCore(
        manifest, replace(plan, cut_off_by={"col_a": "foot_b"}), new_id=lambda: f"ev{next(counter)}"
    )
    cut_off = Reason(code=ReasonCode.UNREACHABLE, message="col_a is cut off from r1")
    core.fail_at_start({"col_a": cut_off, "foot_a": cut_off.model_copy(update={"message": "foot_a too"})})
    reason = core.reason_of("col_a")
    assert reason is not None and reason.message.startswith("col_a is cut off from r1; ")
    assert "placing IfcFooting (foot_b) cuts it off" in reason.message
    assert "--sequence" in reason.message and "crane" in reason.message
    assert core.reason_of("foot_a") == cut_off.model_copy(update={"message": "foot_a too"})  # none named
    heavy = Reason(code=ReasonCode.TOO_HEAVY, message="too heavy")
    core = PlannerCore(
        manifest, replace(plan, cut_off_by={"col_a": "foot_b"}), new_id=lambda: f"ev{next(counter)}"
    )
    core.fail_at_start({"col_a": heavy})
    assert core.reason_of("col_a") == heavy  # another cause: no access advice


def test_feasibility_names_the_mass_and_the_height_against_the_robot_limits() -> None:
    manifest = portal_manifest()
    beam = next(c for c in manifest.components if c.guid == "beam")
    heavy = beam.model_copy(update={"mass_kg": 5760.0})
    ground = [SiteRobot("r1", DEFAULT_ROBOT, (0.0, 0.0, 0.0))]
    verdict = component_feasibility(heavy, ground)
    assert verdict.capable_types == () and verdict.reason is not None
    assert verdict.reason.code is ReasonCode.TOO_HEAVY and "5,760 kg" in verdict.reason.message
    # a mass the converter estimated is said to be one (a user may know the real weight); a stated one not
    for source, estimated in ((MassSource.DEFAULT_DENSITY, True), (MassSource.QUANTITY_WEIGHT, False)):
        verdict = component_feasibility(heavy.model_copy(update={"mass_source": source}), ground)
        assert verdict.reason is not None
        assert (
            "the mass is an estimate, its mesh volume × a default density" in verdict.reason.message
        ) is estimated
    low_robot = DEFAULT_ROBOT.model_copy(update={"max_place_height_m": 1.0})
    verdict = component_feasibility(beam, [SiteRobot("r1", low_robot, (0.0, 0.0, 0.0))])
    assert verdict.reason is not None and verdict.reason.code is ReasonCode.OUT_OF_REACH
    assert component_feasibility(beam, ground).capable_types == ("default",)
    assert infeasible(manifest.components, ground, {}) == {}


def test_a_given_sequence_that_walls_in_a_column_fails_it_before_the_build_naming_the_wall(
    walls_first_build: Path,
) -> None:
    manifest = read_manifest(walls_first_build)
    names = {c.guid: c.name for c in manifest.components}
    guid = {name: g for g, name in names.items()}
    plan = load_plan(manifest, walls_first_build, PlanSource(SourceKind.BUILD))
    outcome = access_plan(plan, manifest, one_robot_site_info(manifest), adjust=plan.derived)
    assert outcome.plan.order == plan.order  # a given sequence is checked, never changed
    assert set(outcome.unreachable) == {guid["Column R1"]}
    reason = outcome.unreachable[guid["Column R1"]]
    assert reason.code is ReasonCode.UNREACHABLE and reason.guid in {guid[w] for w in ROOM_WALLS}
    assert any(guid["Column R1"] in w and "cuts off" in w for w in outcome.warnings)
    assert outcome.plan.cut_off_by[guid["Column R1"]] in {guid[w] for w in ROOM_WALLS}
    with pytest.raises(PlanError, match="cut off"):
        access_plan(plan, manifest, one_robot_site_info(manifest), adjust=False, strict=True)


def test_a_column_cast_in_place_inside_the_walls_is_reached_by_a_boom_not_failed_unreachable(
    walls_first_build: Path,
) -> None:
    manifest = read_manifest(walls_first_build)
    column = next(c.guid for c in manifest.components if c.name == "Column R1")
    cast = manifest.model_copy(
        update={
            "components": [
                c.model_copy(update={"method": ConstructionMethod.CAST_IN_PLACE}) if c.guid == column else c
                for c in manifest.components
            ]
        }
    )
    plan = load_plan(cast, walls_first_build, PlanSource(SourceKind.BUILD))
    outcome = access_plan(plan, cast, one_robot_site_info(cast), adjust=plan.derived)
    assert outcome.unreachable == {}
    assert not any(column in warning for warning in outcome.warnings)


def test_a_derived_sequence_builds_the_column_before_the_wall_that_would_close_the_room(
    walls_first_build: Path,
) -> None:
    manifest = read_manifest(walls_first_build)
    guid = {c.name: c.guid for c in manifest.components}
    assert load_plan(manifest, walls_first_build, PlanSource(SourceKind.DERIVE)).derived
    # a derived plan (support-graph precedences only) that happens to put the four walls first
    given = load_plan(manifest, walls_first_build, PlanSource(SourceKind.BUILD))
    support = support_predecessors(manifest.components)
    plan = replace(given, predecessors={g: frozenset(support[g]) for g in given.order}, derived=True)
    assert plan.order.index(guid["Column R1"]) > max(plan.order.index(guid[w]) for w in ROOM_WALLS)
    outcome = access_plan(plan, manifest, one_robot_site_info(manifest), adjust=True)
    assert outcome.unreachable == {} and outcome.warnings == () and outcome.added >= 1
    order = outcome.plan.order
    last_wall = max(ROOM_WALLS, key=lambda w: order.index(guid[w]))
    assert order.index(guid["Column R1"]) < order.index(guid[last_wall])
    # the release of the ready set keeps it too: the closing wall waits for the column
    assert guid["Column R1"] in outcome.plan.predecessors[guid[last_wall]]


def test_every_component_no_robot_can_carry_is_named_too_heavy_even_when_it_rests_on_another() -> None:
    core = _core()
    heavy = Reason(code=ReasonCode.TOO_HEAVY, message="too heavy")
    core.fail_at_start({"foot_a": heavy, "col_a": heavy})  # col_a rests on foot_a: both too heavy
    out = core.step(0.0)
    assert {m.guid for m in _events(out, ComponentEvent.FAIL)} == {"foot_a", "col_a"}
    assert core.reason_of("col_a") == heavy
    beam = core.reason_of("beam")  # rests on col_a (failed itself) and col_b
    assert beam is not None and beam.code is ReasonCode.BLOCKED_BY and beam.guid in {"foot_a", "col_a"}


def test_a_blocked_component_resting_on_the_failed_one_through_another_names_both() -> None:
    core = _core()
    core.fail_at_start({"foot_a": Reason(code=ReasonCode.TOO_HEAVY, message="too heavy")})
    core.step(0.0)
    column, beam = core.reason_of("col_a"), core.reason_of("beam")
    assert column is not None
    assert column.message == "it rests on IfcFooting (foot_a), which was not built (too_heavy)"
    assert beam is not None and beam.guid == "foot_a"
    assert (
        beam.message
        == "it rests on IfcColumn (col_a), which stands on IfcFooting (foot_a), not built (too_heavy)"
    )


def test_a_task_given_back_goes_to_another_robot_first_and_back_only_when_none_other_is_alive() -> None:
    core = _core()
    _assigned_to_r1(core, "foot_b")
    core.robot_liveliness("r2", True)
    core.observe_robot_state(robot_msg("r2", (0.0, 0.0), state=RobotState.PICK_UP, task_id="other"))
    why = Reason(code=ReasonCode.UNREACHABLE, message="cut off from r1", robot_id="r1")
    core.observe_component_state(state_msg("foot_b", S.PICKING, event="pick", robot_id="r1", sim_time_s=1.0))
    core.observe_component_state(  # as agents send it: the released state names no robot, the reason does
        state_msg("foot_b", S.RELEASED, event="abandon", robot_id=None, sim_time_s=2.0, reason=why)
    )
    core.observe_robot_state(robot_msg("r1", (4.0, 0.0)))  # r1 idle beside it, r2 busy elsewhere
    core.step(1.0)
    assert core.phase("foot_b") is Phase.RELEASED  # r2 may take it once free: r1 does not get it again
    core.observe_robot_state(robot_msg("r2", (30.0, 0.0)))
    core.step(2.0)
    assert core.robot_of("foot_b") == "r2"
    core.observe_component_state(state_msg("foot_b", S.PICKING, event="pick", robot_id="r2", sim_time_s=3.0))
    core.observe_component_state(
        state_msg("foot_b", S.RELEASED, event="abandon", robot_id="r2", sim_time_s=4.0, reason=why)
    )
    core.robot_liveliness("r2", False)
    core.step(3.0)
    assert core.robot_of("foot_b") == "r1"  # every alive robot has given it back: r1 again, bounded


def test_a_robot_that_gives_back_task_after_task_is_held_and_the_others_build() -> None:
    """Boxed in, a robot gives back whatever it is handed (on the 988-component site one gave back 320
    tasks, each counting towards its component's failure): after two in a row it gets no task for 60 s of
    sim time, after the next one 120 s, and meanwhile the other robots get the work."""
    core = _core(PlannerLimits(max_give_backs=10, hold_after_give_backs=2, hold_s=60.0))
    core.robot_liveliness("r1", True)
    core.observe_robot_state(robot_msg("r1", (0.0, 0.0)))
    core.step(0.0)
    footings = ("foot_a", "foot_b")
    for guid in footings:
        core.observe_component_state(state_msg(guid, S.RELEASED, event="release"))
    boxed_in = Reason(code=ReasonCode.UNREACHABLE, message="no free approach", robot_id="r1")

    def r1_task() -> str | None:
        return next(
            (g for g in footings if core.robot_of(g) == "r1" and core.phase(g) is Phase.ASSIGNED), None
        )

    def at(now_s: float) -> None:  # sim time from the clock, the step's wall time alongside
        core.observe_clock(now_s)
        core.step(now_s)

    def r1_gives_back(now_s: float) -> None:
        at(now_s)
        guid = r1_task()
        assert guid is not None, f"r1 got no task at {now_s} s"
        core.observe_component_state(
            state_msg(guid, S.RELEASED, event="abandon", sim_time_s=now_s, reason=boxed_in)
        )
        core.observe_robot_state(robot_msg("r1", (0.0, 0.0), sim_time_s=now_s))

    r1_gives_back(0.1)
    r1_gives_back(1.0)
    at(30.0)
    assert r1_task() is None, "held for 60 s after two give-backs in a row"
    r1_gives_back(62.0)  # the hold is over; a third give-back in a row: 120 s
    at(150.0)
    assert r1_task() is None
    core.robot_liveliness("r2", True)
    core.observe_robot_state(robot_msg("r2", (10.0, 0.0), sim_time_s=150.0))
    at(151.0)
    assert "r2" in {core.robot_of(g) for g in footings if core.phase(g) is Phase.ASSIGNED}
    at(183.0)  # 62 + 120: r1 may work again
    assert r1_task() is not None


def test_one_fine_grid_serves_every_doubt_standing_exactly_each_components_ancestors(
    walls_first_build: Path,
) -> None:
    """The fine check keeps one grid and moves only what differs: after the four walls stood for one doubt,
    the next doubt, with one wall as its only ancestor, sees the column's target open again."""
    manifest = read_manifest(walls_first_build)
    guid = {c.name: c.guid for c in manifest.components}
    info = one_robot_site_info(manifest)
    fine = SiteAccess(list(manifest.components), info.layout, DEFAULT_ROBOT, AccessConfig(resolution_m=0.1))
    order = [c.guid for c in manifest.components]
    walls = {guid[w] for w in ROOM_WALLS}
    _stand_only(fine, walls, order)
    assert fine.placed == walls and not fine.target_accessible(guid["Column R1"])
    one = {guid[ROOM_WALLS[0]]}
    _stand_only(fine, one, order)
    assert fine.placed == one and fine.target_accessible(guid["Column R1"])


def test_a_component_walled_in_by_existing_work_says_so_not_what_the_plan_built_before_it(
    walls_first_build: Path,
) -> None:
    """The room's four walls in place before the robots come (existing work): the column inside is
    unreachable because of them, and the reason says so instead of naming what the plan builds first."""
    manifest = read_manifest(walls_first_build)
    walls = [c for c in manifest.components if c.name in ROOM_WALLS]
    existing = manifest.model_copy(
        update={
            "components": [c for c in manifest.components if c.name not in ROOM_WALLS],
            "in_place": [w.model_copy(update={"method": ConstructionMethod.IN_PLACE}) for w in walls],
        }
    )
    column = next(c.guid for c in existing.components if c.name == "Column R1")
    plan = plan_from_sequence(derive_sequence(existing.components), existing.components, "test")
    outcome = access_plan(plan, existing, one_robot_site_info(existing), adjust=True)
    reason = outcome.unreachable[column]
    assert reason.message.endswith("with the work in place before the robots come"), reason.message
    assert reason.guid is None


def test_a_column_walled_in_at_its_turn_goes_to_a_crane_on_site_not_failed_unreachable(
    walls_first_build: Path,
) -> None:
    """The given sequence closes the room before its column, as above; with a tower crane on site the
    column is set from above: not failed before the build, listed for the crane first."""
    manifest = read_manifest(walls_first_build)
    column = next(c.guid for c in manifest.components if c.name == "Column R1")
    crane = default_fleet().types["tower_crane"]
    layout = plan_site(manifest.components, fleet=[DEFAULT_ROBOT, crane])
    info = one_robot_site_info(manifest).model_copy(
        update={
            "robot_ids": ["r1", "r2"],
            "robot_starts_xy_yaw": list(layout.robot_starts),
            "layout": layout,
            "robot_type_of": {"r1": DEFAULT_ROBOT.name, "r2": crane.name},
            "robot_types": {DEFAULT_ROBOT.name: DEFAULT_ROBOT, crane.name: crane},
        }
    )
    plan = load_plan(manifest, walls_first_build, PlanSource(SourceKind.BUILD))
    outcome = access_plan(plan, manifest, info, adjust=plan.derived)
    assert outcome.unreachable == {}
    assert outcome.plan.from_above == frozenset({column})
