"""A truck-mounted pump that relocates, in the planner: a footing beyond its boom from where it stands but
covered from another of its set-up positions is buildable; the bid adds the relocation, so a pump already
set up nearby costs less; none of its set-ups covering it is out_of_reach from the nearest set-up; a pour
no boom reaches goes to the line pump, whose line does."""

from __future__ import annotations

import dataclasses

import pytest
from component_boxes import box_component
from planner_builders import idle_core, portal_manifest, state_msg

from bimbot.services.planner.capability import SiteRobot, Where, robots_on_plan, task_estimate_s
from bimbot.services.planner.feasibility import advice_tally, component_feasibility
from bimbot.shared.construction_methods import ConstructionMethod
from bimbot.shared.fleet import default_fleet
from bimbot.shared.messages import ComponentState, TaskMsg, TaskStatus
from bimbot.shared.reasons import Reason, ReasonCode
from bimbot.shared.site_layout import plan_site
from bimbot.shared.site_plan import Rect

PUMP = default_fleet().types["concrete_pump"]
HOME, NEAR = (0.0, 0.0, 0.0), (60.0, 0.0, 0.0)
FOOTING = box_component("foot", (1.0, 1.0, 0.5), (70.0, 0.0, -0.5), ConstructionMethod.CAST_IN_PLACE, 2000.0)


def test_a_footing_covered_from_another_set_up_is_buildable_and_not_from_where_it_stands_alone() -> None:
    relocating = SiteRobot("r4", PUMP, HOME, setups=(HOME, NEAR))
    assert component_feasibility(FOOTING, [relocating]).routes == ("concrete_pump (r4)",)
    fixed = SiteRobot("r4", PUMP, HOME)
    row = component_feasibility(FOOTING, [fixed])
    assert row.reason is not None and row.reason.code is ReasonCode.OUT_OF_REACH
    assert "spans 70.0–71.0 m from concrete_pump r4, whose boom reaches 28.0 m" in row.reason.message


def test_out_of_reach_from_every_set_up_names_the_nearest_one() -> None:
    pump = SiteRobot("r4", PUMP, HOME, setups=(HOME, (35.0, 0.0, 0.0)))
    row = component_feasibility(FOOTING, [pump])
    assert row.reason is not None and row.reason.code is ReasonCode.OUT_OF_REACH
    assert (
        "spans 35.0–36.0 m from concrete_pump r4 at the nearest of its 2 set-up positions"
        in row.reason.message
    )


def test_the_bid_adds_the_relocation_so_a_pump_set_up_nearby_costs_less() -> None:
    pump = SiteRobot("r4", PUMP, HOME, setups=(HOME, NEAR))
    where = Where((70.5, 0.5), 0.0)
    from_home = task_estimate_s(pump, HOME[:2], FOOTING, where)
    from_near = task_estimate_s(pump, NEAR[:2], FOOTING, where)
    assert from_home - from_near == pytest.approx(PUMP.setup_s + 60.0 / PUMP.relocation_speed_mps)


def test_the_planner_takes_each_machines_set_ups_from_the_site_plan() -> None:
    components = [FOOTING, box_component("col", (0.3, 0.3, 3.0), (0.0, 0.0, 0.0))]
    fleet = default_fleet()
    layout = plan_site(components, fleet=fleet.robot_types())
    pump_setups = (layout.robot_starts[3], NEAR)
    layout = dataclasses.replace(layout, setups=(layout.setups[0], pump_setups, layout.setups[2]))
    ids = [f"r{number + 1}" for number in range(len(layout.robot_starts))]
    robots = {robot.robot_id: robot for robot in robots_on_plan(ids, fleet.robot_types(), layout)}
    assert robots["r4"].description.name == "concrete_pump" and robots["r4"].setups == pump_setups
    assert robots["r1"].setups == ()  # a ground robot drives


LINE = default_fleet().types["line_pump"]


def test_a_pour_no_boom_set_up_reaches_goes_to_the_line_pump_and_the_boom_bids_lower_where_it_reaches() -> (
    None
):
    """The restaurant's courtyard floor lies 27-52 m inside the building from every set-up of the boom
    pump; the line pump's placing line reaches it from where it stands outside."""
    courtyard = box_component(
        "courtyard", (18.0, 18.0, 0.3), (100.0, 0.0, -0.3), ConstructionMethod.CAST_IN_PLACE, 47600.0
    )
    pump = SiteRobot("r4", PUMP, HOME, setups=(HOME, NEAR))
    line = SiteRobot("r6", LINE, (10.0, 0.0, 0.0))
    alone = component_feasibility(courtyard, [pump])
    assert alone.reason is not None and alone.reason.code is ReasonCode.OUT_OF_REACH
    assert component_feasibility(courtyard, [pump, line]).routes == ("line_pump (r6)",)
    # a footing both reach: the boom pump, set up beside it, finishes first (laying a line takes longer)
    near = SiteRobot("r4", PUMP, NEAR, setups=(HOME, NEAR))
    where = Where((70.5, 0.5), 0.0)
    assert component_feasibility(FOOTING, [near, line]).routes[0] == "concrete_pump (r4)"
    by_boom = task_estimate_s(near, NEAR[:2], FOOTING, where)
    assert by_boom < task_estimate_s(line, (10.0, 0.0), FOOTING, where)


def test_an_idle_pump_works_out_the_set_up_it_stands_at_before_it_relocates() -> None:
    """Offered the released pours in plan order, a relocating machine went across the site for the first
    and back for the next (the structural sample's piling rig: 11 relocations for 216 piles). It now takes
    first what its boom covers from where it stands; the far pour waits for it to be free."""
    near = box_component("near", (1.0, 1.0, 0.5), (5.0, 0.0, -0.5), ConstructionMethod.CAST_IN_PLACE, 2000.0)
    far = FOOTING.model_copy(update={"guid": "afar"})  # sorts first: plan order puts it before "near"
    manifest = portal_manifest().model_copy(update={"components": [far, near]})
    core = idle_core(manifest, [SiteRobot("r4", PUMP, HOME, setups=(HOME, NEAR))])
    assert list(core._state.plan.order) == ["afar", "near"]  # the far pour comes first in plan order
    core.step(0.0)
    for guid in ("afar", "near"):
        core.observe_component_state(state_msg(guid, ComponentState.RELEASED, event="release"))
    out = core.step(0.1)
    assigned = {m.guid: m.robot_id for m in out if isinstance(m, TaskMsg) and m.status is TaskStatus.ASSIGNED}
    assert assigned == {"near": "r4"}


def test_work_another_machine_can_do_keeps_its_place_in_the_round() -> None:
    """Deferred, a pour the boom pump would relocate for went to the slower line pump beside it (the
    restaurant took 5.7 % longer): only work no other machine can do waits for the relocating one."""
    near = box_component("near", (1.0, 1.0, 0.5), (5.0, 0.0, -0.5), ConstructionMethod.CAST_IN_PLACE, 2000.0)
    far = FOOTING.model_copy(update={"guid": "afar"})
    manifest = portal_manifest().model_copy(update={"components": [far, near]})
    pump = SiteRobot("r4", PUMP, HOME, setups=(HOME, NEAR))
    line = SiteRobot("r6", LINE, (10.0, 0.0, 0.0))
    core = idle_core(manifest, [pump, line])
    core.step(0.0)
    for guid in ("afar", "near"):
        core.observe_component_state(state_msg(guid, ComponentState.RELEASED, event="release"))
    out = core.step(0.1)
    assigned = {m.guid: m.robot_id for m in out if isinstance(m, TaskMsg) and m.status is TaskStatus.ASSIGNED}
    assert assigned == {"afar": "r4"}  # the far pour keeps its place: first, to the pump that bids best


def test_work_deeper_inside_the_building_than_any_set_up_reaches_says_so_not_a_longer_boom() -> None:
    """The Revit office's interior masonry lies 55–80 m inside its edge: a longer boom is no answer for
    a block layer that sets up round the building. A footing near the edge still gets the longer boom."""
    building = Rect((0.0, -100.0), (200.0, 100.0))
    deep = box_component(
        "deep", (1.0, 1.0, 0.5), (100.0, 0.0, -0.5), ConstructionMethod.CAST_IN_PLACE, 2000.0
    )
    pump = SiteRobot("r4", PUMP, (-10.0, 0.0, 0.0), setups=((-10.0, 0.0, 0.0),))
    row = component_feasibility(deep, [pump], building=building)
    assert row.reason is not None and row.reason.code is ReasonCode.OUT_OF_REACH
    assert "it lies 100 m inside the building's edge, so no set-up round the building reaches it" in (
        row.reason.message
    )
    assert "a longer boom" not in row.reason.message
    near_edge = box_component("edge", (1.0, 1.0, 0.5), (190.0, 0.0, -0.5), ConstructionMethod.CAST_IN_PLACE)
    row = component_feasibility(near_edge, [pump], building=building)
    assert (
        row.reason is not None
        and "a longer boom (reach_m in the fleet file) would cover it" in row.reason.message
    )


def test_fleet_checks_last_word_counts_the_rows_by_the_fix_their_reasons_advise() -> None:
    building = Rect((0.0, -100.0), (200.0, 100.0))
    pump = SiteRobot("r4", PUMP, (-10.0, 0.0, 0.0), setups=((-10.0, 0.0, 0.0),))
    deep = box_component(
        "deep", (1.0, 1.0, 0.5), (100.0, 0.0, -0.5), ConstructionMethod.CAST_IN_PLACE, 2000.0
    )
    edge = box_component("edge", (1.0, 1.0, 0.5), (190.0, 0.0, -0.5), ConstructionMethod.CAST_IN_PLACE)
    reasons = [component_feasibility(item, [pump], building=building).reason for item in (deep, edge, edge)]
    other = Reason(code=ReasonCode.TOO_HEAVY, message="9,514 kg exceeds the largest payload on site")
    assert advice_tally([*[r for r in reasons if r is not None], other]) == [
        ("a longer boom", 2),
        ("too_heavy (see its rows)", 1),
        ("work in place from inside the building (not simulated), or a methods file making it precast", 1),
    ]
