"""Work in place in the planner: a cast component goes only to a machine that pours and whose boom covers it,
a laid one only to one that lays; none on site, or a boom too short, is a reason with the numbers before the
build; bids are the work's own duration; tasks carry their method; the watchdog allows the work's time."""

from __future__ import annotations

import itertools

import pytest
from planner_builders import LAYER, PUMP, portal_manifest, robot_msg, state_msg, with_methods

from bimbot.services.planner.assignment import ready_s
from bimbot.services.planner.capability import SiteRobot, Where, task_estimate_s
from bimbot.services.planner.feasibility import component_feasibility
from bimbot.services.planner.records import RobotRecord
from bimbot.services.planner.scheduler import Phase, PlannerCore, PlannerLimits
from bimbot.services.planner.sources import plan_from_sequence
from bimbot.services.planner.work_in_place import blocks_needed, work_s
from bimbot.shared.construction_methods import ConstructionMethod
from bimbot.shared.fleet import default_fleet
from bimbot.shared.manifest import Component, Manifest
from bimbot.shared.messages import (
    ComponentEvent,
    ComponentEventMsg,
    ComponentState,
    RobotState,
    TaskMsg,
    TaskStatus,
)
from bimbot.shared.reasons import ReasonCode
from bimbot.shared.support_graph import derive_sequence

S = ComponentState
M = ConstructionMethod
TYPES = default_fleet().types
HUSKY, CARRIER, CRANE = TYPES["husky"], TYPES["carrier"], TYPES["tower_crane"]
LIFTERS = [
    SiteRobot("r1", HUSKY, (0.0, -3.0, 0.0)),
    SiteRobot("r2", CARRIER, (-5.0, -3.0, 0.0)),
    SiteRobot("r3", CRANE, (2.0, 12.0, -1.5708)),
]


def _part(manifest: Manifest, guid: str, **update: object) -> Component:
    return manifest.component(guid).model_copy(update=update)


def _cast_footing(mass_kg: float = 50_000.0) -> Component:
    """foot_a (0.6 m square at the origin, top at 0 m), cast in place, far heavier than any payload."""
    return _part(with_methods(portal_manifest(), foot_a=M.CAST_IN_PLACE), "foot_a", mass_kg=mass_kg)


def test_a_cast_footing_is_built_only_by_a_pump_whose_boom_covers_it_and_is_never_too_heavy() -> None:
    pump = SiteRobot("r4", PUMP, (20.0, 0.0, 0.0))
    row = component_feasibility(_cast_footing(), [*LIFTERS, pump])
    assert row.reason is None
    assert row.routes == ("concrete_pump (r4)",)  # no ground robot, no crane, no hand-off
    light = component_feasibility(_cast_footing(mass_kg=40.0), [*LIFTERS, pump])
    assert light.routes == ("concrete_pump (r4)",)  # a husky could lift 40 kg: a cast footing is not lifted


def test_without_a_pump_a_cast_footing_fails_saying_no_robot_can_pour_and_what_to_add() -> None:
    row = component_feasibility(_cast_footing(mass_kg=40.0), LIFTERS)
    assert row.reason is not None and row.routes == ()
    assert row.reason.code is ReasonCode.NO_CAPABLE_ROBOT
    message = row.reason.message
    assert "cast in place" in message and "no robot on site can pour concrete" in message
    assert "capability pour" in message and "add a concrete pump to the fleet" in message
    assert "carrier, husky, tower_crane" in message  # the types on site


def test_a_pump_boom_too_short_names_the_footprint_span_and_the_reach_of_the_nearest_pump() -> None:
    far_pumps = [SiteRobot("r4", PUMP, (40.0, 0.0, 0.0)), SiteRobot("r5", PUMP, (0.0, 60.0, 0.0))]
    row = component_feasibility(_cast_footing(), [*LIFTERS, *far_pumps])
    assert row.reason is not None and row.reason.code is ReasonCode.OUT_OF_REACH
    assert row.reason.robot_id == "r4"
    assert "its footprint spans 39.7–40.3 m from concrete_pump r4, whose boom reaches 32.0 m" in (
        row.reason.message
    )
    assert "the nearest of 2 robots that can pour concrete" in row.reason.message
    # one step nearer and the boom covers it
    assert component_feasibility(_cast_footing(), [SiteRobot("r4", PUMP, (31.5, 0.0, 0.0))]).reason is None


def test_a_cast_beam_above_the_pump_boom_height_is_out_of_reach_with_both_heights() -> None:
    beam = _part(with_methods(portal_manifest(), beam=M.CAST_IN_PLACE), "beam")
    low_pump = PUMP.model_copy(update={"max_place_height_m": 2.0})
    row = component_feasibility(beam, [SiteRobot("r4", low_pump, (5.0, 0.0, 0.0))])
    assert row.reason is not None and row.reason.code is ReasonCode.OUT_OF_REACH
    assert "its top at 3.20 m is above the concrete_pump r4's working height of 2.00 m" in row.reason.message


def test_a_laid_post_goes_only_to_a_block_layer_within_its_boom_and_none_on_site_says_so() -> None:
    post = _part(with_methods(portal_manifest(), post_c=M.LAID), "post_c")
    layer = SiteRobot("r5", LAYER, (12.0, 0.0, 0.0))
    assert component_feasibility(post, [*LIFTERS, layer]).routes == ("block_layer (r5)",)
    pump = SiteRobot("r4", PUMP, (12.0, 0.0, 0.0))
    row = component_feasibility(post, [*LIFTERS, pump])  # a pump cannot lay
    assert row.reason is not None and row.reason.code is ReasonCode.NO_CAPABLE_ROBOT
    assert "laid masonry" in row.reason.message and "lay masonry" in row.reason.message
    assert "add a block-laying robot to the fleet" in row.reason.message


def test_a_driven_pile_goes_only_to_a_piling_rig_for_its_pitch_and_drive_and_none_on_site_says_so() -> None:
    pile = _part(with_methods(portal_manifest(), post_c=M.DRIVEN), "post_c")  # 3.0 m long
    rig = SiteRobot("r6", TYPES["piling_rig"], (12.0, 0.0, 0.0))
    assert component_feasibility(pile, [*LIFTERS, rig]).routes == ("piling_rig (r6)",)
    piling = TYPES["piling_rig"].piling
    assert piling is not None
    assert work_s(pile, TYPES["piling_rig"]) == pytest.approx(piling.pitch_s + 3600.0 * 3.0 / 120.0)
    row = component_feasibility(
        pile, [*LIFTERS, SiteRobot("r4", PUMP, (12.0, 0.0, 0.0))]
    )  # a pump drives none
    assert row.reason is not None and row.reason.code is ReasonCode.NO_CAPABLE_ROBOT
    assert "a driven pile" in row.reason.message and "drive piles" in row.reason.message
    assert "add a piling rig to the fleet" in row.reason.message


def test_a_machine_that_only_pours_never_gets_a_part_to_lift_and_alone_on_site_says_none_can() -> None:
    beam = portal_manifest().component("beam")
    pump = SiteRobot("r4", PUMP, (5.0, 0.0, 0.0))
    routes = component_feasibility(beam, [*LIFTERS, pump]).routes
    assert routes == component_feasibility(beam, LIFTERS).routes and "husky" in routes
    assert not any("concrete_pump" in route for route in routes)
    row = component_feasibility(beam, [pump])
    assert row.reason is not None and row.reason.code is ReasonCode.NO_CAPABLE_ROBOT
    assert "no robot on site can carry or lift it" in row.reason.message
    assert "types on site: concrete_pump" in row.reason.message


def test_bids_for_work_in_place_are_formwork_and_pour_or_the_blocks_at_the_layers_rate() -> None:
    pump = SiteRobot("r4", PUMP, (20.0, 0.0, 0.0))
    footing = _cast_footing()
    where = Where((0.0, 0.0), 0.0)
    assert task_estimate_s(pump, (20.0, 0.0), footing, where) == pytest.approx(3600 + 1800 + 2 * 600)
    post = _part(with_methods(portal_manifest(), post_c=M.LAID), "post_c")  # 1.0 m³ of 0.025 m³ blocks
    layer = SiteRobot("r5", LAYER, (12.0, 0.0, 0.0))
    assert blocks_needed(post, LAYER) == 40
    slender = post.model_copy(update={"volume_m3": 0.01})  # less than a block, but 3.0 m is 12 courses
    assert blocks_needed(slender, LAYER) == 12
    assert task_estimate_s(layer, (12.0, 0.0), post, where) == pytest.approx(3600 * 40 / 100 + 2 * 300)


def _core(manifest: Manifest, robots: list[SiteRobot], limits: PlannerLimits | None = None) -> PlannerCore:
    plan = plan_from_sequence(derive_sequence(manifest.components), manifest.components, "test")
    counter = itertools.count(1)
    core = PlannerCore(
        manifest, plan, new_id=lambda: f"ev{next(counter)}", robots=robots, slots={}, limits=limits
    )
    for robot in robots:
        core.robot_liveliness(robot.robot_id, True)
        core.observe_robot_state(robot_msg(robot.robot_id, robot.home_xy_yaw[:2]))
    return core


def _assigned(out: list) -> dict[str, TaskMsg]:
    return {m.guid: m for m in out if isinstance(m, TaskMsg) and m.status is TaskStatus.ASSIGNED}


def test_a_cast_task_goes_to_the_pump_and_carries_its_method_a_lifted_one_to_a_ground_robot() -> None:
    manifest = with_methods(portal_manifest(), foot_a=M.CAST_IN_PLACE)
    core = _core(
        manifest, [SiteRobot("r1", CARRIER, (0.0, -2.0, 0.0)), SiteRobot("r4", PUMP, (20.0, 0.0, 0.0))]
    )
    core.step(0.0)
    for guid in ("foot_a", "foot_b"):
        core.observe_component_state(state_msg(guid, S.RELEASED, event="release"))
    assigned = _assigned(core.step(0.1))
    assert assigned["foot_a"].robot_id == "r4" and assigned["foot_a"].method is M.CAST_IN_PLACE
    assert assigned["foot_b"].robot_id == "r1" and assigned["foot_b"].method is M.LIFTED


def test_the_watchdog_gives_work_in_place_its_expected_duration_on_top_of_the_fixed_bound() -> None:
    manifest = with_methods(portal_manifest(), foot_a=M.CAST_IN_PLACE)  # formwork 3600 s + pour 1800 s
    core = _core(manifest, [SiteRobot("r4", PUMP, (20.0, 0.0, 0.0))], PlannerLimits(task_timeout_s=1200.0))
    core.step(0.0)
    core.observe_component_state(state_msg("foot_a", S.RELEASED, event="release"))
    core.step(0.1)
    core.observe_component_state(state_msg("foot_a", S.FORMING, event="form", robot_id="r4", sim_time_s=10.0))
    busy = robot_msg("r4", (20.0, 0.0), RobotState.WORK_IN_PLACE, task_id="T0001", sim_time_s=10.0)
    core.observe_robot_state(busy.model_copy(update={"busy_until_s": 5410.0}))
    core.observe_clock(5410.0)  # a skip to the end of the work: far beyond the fixed 1200 s
    assert not [m for m in core.step(1.0) if isinstance(m, ComponentEventMsg)]
    assert core.phase("foot_a") is Phase.ASSIGNED and core.robot_of("foot_a") == "r4"
    core.observe_clock(10.0 + 1200.0 + 5400.0 + 1.0)  # beyond the work and the bound: taken back
    abandons = [
        m for m in core.step(2.0) if isinstance(m, ComponentEventMsg) and m.event is ComponentEvent.ABANDON
    ]
    assert [m.guid for m in abandons] == ["foot_a"]
    reason = abandons[0].reason
    assert reason is not None and reason.code is ReasonCode.NO_PROGRESS
    assert "bound 6600 s with 5400 s of work in place" in reason.message


def test_a_robot_in_timed_work_is_not_free_before_the_time_it_says() -> None:
    record = RobotRecord("r4", alive=True, state=RobotState.WORK_IN_PLACE, task_guid="foot_a")
    record.busy_until_s, record.reported_busy_until_s = 1000.0, 5000.0
    assert ready_s(record, 500.0) == 5000.0
    record.reported_busy_until_s = None
    assert ready_s(record, 500.0) == 1000.0
