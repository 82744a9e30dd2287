"""The planner with a fleet: tasks go only to capable robot types, by bid; a crane out of reach of a
component's slot gets it through a hand-off task of its own (pure core, no bus)."""

from __future__ import annotations

import math

import pytest
from planner_builders import idle_core, portal_manifest, robot_msg, state_msg

from bimbot.services.planner.capability import SiteRobot, Where, crane_reaches_centre
from bimbot.services.planner.scheduler import Phase, PlannerCore
from bimbot.shared.fleet import default_fleet
from bimbot.shared.manifest import Component, Manifest
from bimbot.shared.messages import (
    ComponentEvent,
    ComponentPoseMsg,
    ComponentState,
    PoseMsg,
    RobotState,
    TaskKind,
    TaskMsg,
    TaskStatus,
)
from bimbot.shared.reasons import Reason, ReasonCode
from bimbot.shared.site_plan import Rect

S = ComponentState
TYPES = default_fleet().types
HUSKY, CARRIER, CRANE = TYPES["husky"], TYPES["carrier"], TYPES["tower_crane"]


def _manifest(**masses: float) -> Manifest:
    manifest = portal_manifest()
    components = [c.model_copy(update={"mass_kg": masses.get(c.guid, 40.0)}) for c in manifest.components]
    return manifest.model_copy(update={"components": components})


def _assignments(out: list) -> dict[str, TaskMsg]:
    return {m.guid: m for m in out if isinstance(m, TaskMsg) and m.status is TaskStatus.ASSIGNED}


def _release(core: PlannerCore, *guids: str, sim_s: float = 0.0) -> list:
    core.step(0.0)
    for guid in guids:
        core.observe_component_state(state_msg(guid, S.RELEASED, event="release", sim_time_s=sim_s))
    return core.step(0.1)


def test_a_component_heavier_than_the_husky_payload_never_goes_to_the_husky_even_when_it_is_idle() -> None:
    manifest = _manifest(foot_a=259.0, foot_b=259.0, foot_c=259.0)
    robots = [
        SiteRobot("r1", HUSKY, (0.0, -5.0, 0.0)),  # right beside the footings
        SiteRobot("r2", CARRIER, (-30.0, -5.0, 0.0)),  # far away
    ]
    core = idle_core(manifest, robots)
    out = _release(core, "foot_a", "foot_b", "foot_c")
    assigned = _assignments(out)
    assert {m.robot_id for m in assigned.values()} == {"r2"}  # one footing to the carrier, the others wait
    assert len(assigned) == 1
    assert all(core.robot_of(guid) != "r1" for guid in ("foot_a", "foot_b", "foot_c"))


def test_among_capable_idle_robots_the_lowest_bid_wins_not_the_nearest() -> None:
    manifest = _manifest()
    slow = CARRIER.model_copy(update={"name": "slow", "max_speed_mps": 0.05})
    robots = [
        SiteRobot("r1", slow, (0.0, -3.0, 0.0)),  # nearest, but crawls
        SiteRobot("r2", HUSKY, (-20.0, -3.0, 0.0)),
    ]
    core = idle_core(manifest, robots)
    assigned = _assignments(_release(core, "foot_a"))
    assert assigned["foot_a"].robot_id == "r2"


def test_a_busy_robot_that_would_finish_sooner_is_waited_for() -> None:
    manifest = _manifest(foot_a=259.0, foot_b=259.0)
    robots = [
        SiteRobot("r1", CARRIER, (0.0, -3.0, 0.0)),
        SiteRobot("r2", CARRIER.model_copy(update={"name": "crawler", "max_speed_mps": 0.02}), (60.0, 0, 0)),
    ]
    core = idle_core(manifest, robots)
    first = _assignments(_release(core, "foot_a", "foot_b"))
    assert [m.robot_id for m in first.values()] == ["r1"]  # r2 would take hours: foot_b waits for r1
    assert core.phase("foot_b") is Phase.RELEASED


def test_a_crane_gets_what_only_it_can_place_and_a_hand_off_brings_it_within_its_hook() -> None:
    manifest = _manifest(beam=300.0)
    crane_spec = CRANE.crane
    assert crane_spec is not None
    crane_at = (2.0, 12.0, -1.5708)
    staging = Rect((-2.0, 16.0), (6.0, 24.0))
    robots = [
        SiteRobot("r1", CARRIER.model_copy(update={"max_place_height_m": 1.0}), (-10.0, -10.0, 0.0)),
        SiteRobot("r2", CRANE, crane_at, staging),
    ]
    core = idle_core(manifest, robots)
    for guid in ("foot_a", "foot_b", "foot_c", "col_a", "col_b", "post_c"):
        core.observe_component_state(state_msg(guid, S.CONSTRUCTED, event="verified"))
    # the beam lies 70 m from the crane: beyond its 60 m jib
    core.observe_component_pose(_pose("beam", (2.0, -58.0)))
    out = _release(core, "beam")
    hand_off = _assignments(out)["beam"]
    assert hand_off.kind is TaskKind.HAND_OFF and hand_off.robot_id == "r1"
    assert hand_off.task_id.endswith("-h1") and hand_off.put_down_xy_m is not None
    x, y = hand_off.put_down_xy_m
    assert staging.min_xy[0] <= x <= staging.max_xy[0] and staging.min_xy[1] <= y <= staging.max_xy[1]
    carrying = RobotState.IDENTIFY_TARGET_LOCATION
    core.observe_robot_state(robot_msg("r1", (0.0, -50.0), state=carrying, task_id=hand_off.task_id))
    for state, event, sim_s in ((S.PICKING, "pick", 10), (S.TRANSPORTING, "attach", 11)):
        core.observe_component_state(state_msg("beam", state, event=event, robot_id="r1", sim_time_s=sim_s))
    core.observe_component_state(
        state_msg("beam", S.RELEASED, event=ComponentEvent.HAND_OFF.value, robot_id="r1", sim_time_s=90)
    )
    core.observe_robot_state(robot_msg("r1", (x, y - 2.0), sim_time_s=90))
    out = core.step(1.0)
    done = [m for m in out if isinstance(m, TaskMsg) and m.task_id == hand_off.task_id]
    assert done and done[0].status is TaskStatus.DONE
    build = _assignments(out)["beam"]
    assert build.robot_id == "r2" and build.kind is TaskKind.BUILD and not build.task_id.endswith("-h1")


def _pose(guid: str, xy: tuple[float, float]):

    return ComponentPoseMsg(
        guid=guid, pose=PoseMsg(position_m=(xy[0], xy[1], 0.1), quat_xyzw=(0, 0, 0, 1)), sim_time_s=0.0
    )


def test_crane_hook_radius_is_to_the_load_centre_and_limited_by_the_load_chart() -> None:
    crane = SiteRobot("r3", CRANE, (0.0, 0.0, 0.0))
    assert crane_reaches_centre(crane, Where((30.0, 0.0), 0.0), 3900.0)  # 30 m: 3,900 kg allowed
    assert not crane_reaches_centre(crane, Where((30.0, 0.0), 0.0), 4000.0)
    assert not crane_reaches_centre(crane, Where((1.0, 0.0), 0.0), 10.0)  # inside the trolley's minimum
    assert not crane_reaches_centre(crane, Where((61.0, 0.0), 0.0), 10.0)  # beyond the jib


def _beam_for_the_crane_only() -> PlannerCore:
    """A beam released 58 m south of the crane's mast: beyond its hook, set too high for the carrier (r1),
    which must hand it off to the crane (r2)."""
    staging = Rect((-2.0, 16.0), (6.0, 24.0))
    robots = [
        SiteRobot("r1", CARRIER.model_copy(update={"max_place_height_m": 1.0}), (-10.0, -10.0, 0.0)),
        SiteRobot("r2", CRANE, (2.0, 12.0, -1.5708), staging),
    ]
    core = idle_core(_manifest(beam=300.0), robots)
    for guid in ("foot_a", "foot_b", "foot_c", "col_a", "col_b", "post_c"):
        core.observe_component_state(state_msg(guid, S.CONSTRUCTED, event="verified"))
    core.observe_component_pose(_pose("beam", (2.0, -58.0)))
    _release(core, "beam")
    return core


def test_a_component_the_crane_still_cannot_reach_after_its_hand_offs_fails_out_of_reach() -> None:
    core = _beam_for_the_crane_only()
    for number in (1, 2):  # each hand-off puts it down again out of the hook's reach
        assert core.phase("beam") is Phase.ASSIGNED
        for state, event in ((S.PICKING, "pick"), (S.TRANSPORTING, "attach")):
            core.observe_component_state(
                state_msg("beam", state, event=event, robot_id="r1", sim_time_s=10.0 * number)
            )
        core.observe_component_state(
            state_msg("beam", S.RELEASED, event="hand_off", robot_id="r1", sim_time_s=10.0 * number + 5)
        )
        core.observe_component_pose(_pose("beam", (2.0, -58.0)))
        core.observe_robot_state(robot_msg("r1", (0.0, -50.0), sim_time_s=10.0 * number + 5))
        core.step(float(number))
    assert core.phase("beam") is Phase.FAILED
    reason = core.reason_of("beam")
    assert (
        reason is not None
        and reason.code.value == "out_of_reach"
        and "handed off 2 time(s)" in reason.message
    )


def test_hand_offs_the_carrier_gave_back_fail_with_its_reason_not_the_crane_s_reach() -> None:
    """A carrier walled in gives back each hand-off it is given before it picks the beam up: the beam was
    never put down beside the crane, so the reason is the carrier's, not "still beyond the hook"."""
    core = _beam_for_the_crane_only()  # each give-back 100 s apart: beyond the hold on giving it again
    trapped = Reason(code=ReasonCode.ROBOT_TRAPPED, message="r1 at (0, -50) is walled in", robot_id="r1")
    for number in (1, 2):
        assert core.phase("beam") is Phase.ASSIGNED
        core.observe_component_state(
            state_msg("beam", S.PICKING, event="pick", robot_id="r1", sim_time_s=100.0 * number)
        )
        core.observe_component_state(
            state_msg(
                "beam",
                S.RELEASED,
                event="abandon",
                robot_id="r1",
                sim_time_s=100.0 * number + 5,
                reason=trapped,
            )
        )
        core.observe_robot_state(robot_msg("r1", (0.0, -50.0), sim_time_s=100.0 * number + 70))
        core.step(float(number))
    core.observe_robot_state(robot_msg("r1", (0.0, -50.0), sim_time_s=10_000.0))  # past any hold
    core.step(3.0)
    assert core.phase("beam") is Phase.FAILED
    reason = core.reason_of("beam")
    assert reason is not None and reason.code is ReasonCode.ROBOT_TRAPPED
    assert "every hand-off of it to a crane (2) was given back" in reason.message
    assert "walled in" in reason.message and "beyond the hook" not in reason.message


def test_an_out_of_reach_reason_measures_to_the_footprint_the_decision_used_not_the_placement_origin() -> (
    None
):
    """A Revit member may have its placement at the project origin and its body 100 m away: the reason
    said "its target is 100.2 m from tower_crane r3" for a beam whose body lay elsewhere."""
    from bimbot.services.planner.feasibility import component_feasibility

    beam = next(c for c in _manifest(beam=300.0).components if c.guid == "beam")
    shift = 75.0  # the body 75 m east of its placement's origin, which lies at the crane's mast
    local = beam.bbox_local.model_copy(
        update={
            "min_m": (beam.bbox_local.min_m[0] + shift, *beam.bbox_local.min_m[1:]),
            "max_m": (beam.bbox_local.max_m[0] + shift, *beam.bbox_local.max_m[1:]),
        }
    )
    origin = beam.target_pose_world.model_copy(
        update={"position_m": (0.0, 0.0, 0.0), "quat_xyzw": (0, 0, 0, 1)}
    )
    far_body = beam.model_copy(update={"bbox_local": local, "target_pose_world": origin})
    verdict = component_feasibility(far_body, [SiteRobot("r3", CRANE, (0.0, 0.0, 0.0))])
    assert verdict.reason is not None and verdict.reason.code.value == "out_of_reach"
    low, high = local.min_m, local.max_m
    centre_m = math.hypot((low[0] + high[0]) / 2.0, (low[1] + high[1]) / 2.0)
    assert f"is {centre_m:.1f} m from tower_crane r3" in verdict.reason.message
    assert "is 0.0 m from" not in verdict.reason.message
    assert centre_m > CRANE.reach_m and "takes more tower cranes" in verdict.reason.message  # beyond the jib
    near_body = beam.model_copy(update={"mass_kg": 20_000.0})  # at its placement, 0 m: too heavy, not far
    near = component_feasibility(near_body, [SiteRobot("r3", CRANE, (0.0, 0.0, 0.0))]).reason
    assert near is not None and "more tower cranes" not in near.message


def _beam_at(x_m: float, **update: object) -> Component:
    """The portal's beam moved ``x_m`` east (its body and its placement), with ``update``."""
    beam = next(c for c in _manifest(beam=300.0).components if c.guid == "beam")
    pose = beam.target_pose_world
    moved = pose.model_copy(update={"position_m": (pose.position_m[0] + x_m, *pose.position_m[1:])})
    low, high = beam.bbox_world.min_m, beam.bbox_world.max_m
    box = beam.bbox_world.model_copy(
        update={"min_m": (low[0] + x_m, *low[1:]), "max_m": (high[0] + x_m, *high[1:])}
    )
    return beam.model_copy(update={"target_pose_world": moved, "bbox_world": box, **update})


def test_beyond_every_jib_the_advice_is_more_cranes_only_where_a_crane_round_the_building_could_hook_it() -> (
    None
):
    """A public Revit office (236 m × 161 m): a user who followed "a building this size takes more tower
    cranes" with six cranes got the same sentence back for parts 80 m inside the building, which no crane
    standing round it hooks. Such a part now says how deep inside it lies; one near an edge keeps the
    advice; several cranes: the reason names the nearest."""
    from bimbot.services.planner.feasibility import component_feasibility

    building = Rect((-5.0, -160.0), (235.0, 5.0))
    crane = SiteRobot("r3", CRANE, (0.0, 12.0, 0.0))
    deep = component_feasibility(_beam_at(100.0), [crane], None, Rect((-5.0, -160.0), (235.0, 100.0)))
    assert deep.reason is not None and deep.reason.code.value == "out_of_reach"
    assert "inside the building's edge" in deep.reason.message
    assert "more tower cranes" not in deep.reason.message
    edge = component_feasibility(_beam_at(100.0), [crane], None, building).reason
    assert edge is not None and "takes more tower cranes" in edge.message
    far_crane = SiteRobot("r7", CRANE, (-200.0, 12.0, 0.0))
    both = component_feasibility(_beam_at(100.0), [far_crane, crane], None, building).reason
    assert both is not None and "from tower_crane r3" in both.message


def test_a_part_no_robot_takes_is_refused_by_the_strongest_robot_not_the_first() -> None:
    """The office's 7.8 t slab panel at 37 m, above the crane's placement height, read "exceeds the husky
    payload of 75 kg" with an 8 t crane and a 3 t carrier on site: the reason is the crane's height."""
    from bimbot.services.planner.feasibility import component_feasibility

    high = _beam_at(0.0, mass_kg=7_830.0)
    top = CRANE.max_place_height_m + 1.0
    low, high_m = high.bbox_world.min_m, high.bbox_world.max_m
    box = high.bbox_world.model_copy(update={"min_m": (*low[:2], top - 0.3), "max_m": (*high_m[:2], top)})
    robots = [
        SiteRobot("r1", HUSKY, (-10.0, -10.0, 0.0)),
        SiteRobot("r2", CARRIER, (-12.0, -10.0, 0.0)),
        SiteRobot("r3", CRANE, (0.0, 12.0, 0.0)),
    ]
    reason = component_feasibility(high.model_copy(update={"bbox_world": box}), robots).reason
    assert reason is not None and "husky" not in reason.message
    assert "tower_crane" in reason.message and "placement height" in reason.message


def test_a_restarted_planner_that_adopted_a_hand_off_as_a_build_frees_its_robot_when_it_ends() -> None:
    manifest = _manifest(beam=300.0)
    robots = [
        SiteRobot("r1", CARRIER.model_copy(update={"max_place_height_m": 1.0}), (-10.0, -10.0, 0.0)),
        SiteRobot("r2", CRANE, (2.0, 12.0, -1.5708), Rect((-2.0, 16.0), (6.0, 24.0))),
    ]
    core = idle_core(manifest, robots)  # a new planner: it never assigned the hand-off r1 is carrying out
    for guid in ("foot_a", "foot_b", "foot_c", "col_a", "col_b", "post_c"):
        core.observe_component_state(state_msg(guid, S.CONSTRUCTED, event="verified"))
    core.observe_component_state(state_msg("beam", S.TRANSPORTING, event="attach", robot_id="r1"))
    assert core.phase("beam") is Phase.ASSIGNED and core.robot_of("beam") == "r1"  # adopted
    core.observe_component_state(state_msg("beam", S.RELEASED, event="hand_off", robot_id="r1", sim_time_s=5))
    core.observe_component_pose(_pose("beam", (2.0, 18.0)))
    out = core.step(1.0)
    assert _assignments(out)["beam"].robot_id == "r2"  # the crane builds it; r1 is free again


def test_a_component_too_high_for_every_ground_robot_says_what_would_place_it() -> None:
    from bimbot.services.planner.feasibility import infeasible

    manifest = _manifest()
    low = CARRIER.model_copy(update={"max_place_height_m": 1.0})  # below every beam of the portal
    without_crane = infeasible(manifest.components, [SiteRobot("r1", low, (-10.0, -10.0, 0.0))], {})
    assert without_crane, "the portal's beam is above 1 m"
    for reason in without_crane.values():
        assert reason.code.value == "out_of_reach"
        assert "no tower crane is on site" in reason.message and "--fleet" in reason.message
    with_crane = infeasible(
        manifest.components,
        [SiteRobot("r1", low, (-10.0, -10.0, 0.0)), SiteRobot("r2", CRANE, (60.0, 60.0, 0.0))],
        {},
    )
    assert all("no tower crane" not in reason.message for reason in with_crane.values())


def _far_origin(manifest: Manifest, guid: str, offset_xy: tuple[float, float]) -> Manifest:
    """``guid`` as Revit exports it: the same body, its frame's origin ``offset_xy`` away (identity
    placement, geometry in world coordinates): local box moved by the offset, target moved back."""
    dx, dy = offset_xy

    def moved(component: Component) -> Component:
        if component.guid != guid:
            return component
        low, high = component.bbox_local.min_m, component.bbox_local.max_m
        box = component.bbox_local.model_copy(
            update={
                "min_m": (low[0] + dx, low[1] + dy, low[2]),
                "max_m": (high[0] + dx, high[1] + dy, high[2]),
            }
        )
        x, y, z = component.target_pose_world.position_m
        target = component.target_pose_world.model_copy(update={"position_m": (x - dx, y - dy, z)})
        return component.model_copy(update={"bbox_local": box, "target_pose_world": target})

    return manifest.model_copy(update={"components": [moved(c) for c in manifest.components]})


def test_where_a_component_lies_is_its_body_not_its_frame_origin_100_m_away() -> None:
    """On the Revit hub a 3.4 t wall lay in the crane's reach, but its pose's position (the project origin,
    where its frame lies) was out of it: the planner never assigned it, and the run stalled."""
    manifest = _far_origin(_manifest(beam=300.0), "beam", (100.0, 0.0))
    crane_at = (2.0, 12.0, -1.5708)
    robots = [
        SiteRobot("r1", CARRIER.model_copy(update={"max_place_height_m": 1.0}), (-10.0, -10.0, 0.0)),
        SiteRobot("r2", CRANE, crane_at, Rect((-2.0, 16.0), (6.0, 24.0))),
    ]
    core = idle_core(manifest, robots)
    for guid in ("foot_a", "foot_b", "foot_c", "col_a", "col_b", "post_c"):
        core.observe_component_state(state_msg(guid, S.CONSTRUCTED, event="verified"))
    beam = next(c for c in manifest.components if c.guid == "beam")
    low, high = beam.bbox_local.min_m, beam.bbox_local.max_m
    centre = ((low[0] + high[0]) / 2.0, (low[1] + high[1]) / 2.0)
    # its body lies at (2, 20), in the crane's staging area; its frame's origin 100 m west of it
    core.observe_component_pose(_pose("beam", (2.0 - centre[0], 20.0 - centre[1])))
    build = _assignments(_release(core, "beam"))["beam"]
    assert build.robot_id == "r2" and build.kind is TaskKind.BUILD


def test_a_robot_that_gave_a_task_back_gets_it_again_when_no_other_robot_can_take_it() -> None:
    """The hub: a carrier gave back a 1.1 t beam (it could not drive there); the Husky (75 kg) and the
    crane (out of reach) were alive and idle, so the beam waited "for a robot" until the run stalled.
    Another robot that *can* take it goes first; when none can, the one that gave it back bids again once
    the hold after its give-back is over (its give-backs stay bounded: max_give_backs fails the component
    with its reason)."""
    manifest = _manifest(foot_a=259.0)
    robots = [SiteRobot("r1", HUSKY, (0.0, -5.0, 0.0)), SiteRobot("r2", CARRIER, (-30.0, -5.0, 0.0))]
    core = idle_core(manifest, robots)
    assert _assignments(_release(core, "foot_a"))["foot_a"].robot_id == "r2"
    why = Reason(code=ReasonCode.NO_PROGRESS, message="r2 could not drive there", robot_id="r2")
    core.observe_component_state(state_msg("foot_a", S.PICKING, event="pick", robot_id="r2", sim_time_s=1.0))
    core.observe_component_state(
        state_msg("foot_a", S.RELEASED, event="abandon", robot_id=None, sim_time_s=2.0, reason=why)
    )
    core.observe_robot_state(robot_msg("r2", (-30.0, -5.0), sim_time_s=2.0))
    core.observe_clock(3.0)
    assert "foot_a" not in _assignments(core.step(3.0)), "given back a second ago: its way may open first"
    core.observe_robot_state(robot_msg("r2", (-30.0, -5.0), sim_time_s=62.0))
    core.observe_clock(63.0)
    out = core.step(63.0)
    assert _assignments(out)["foot_a"].robot_id == "r2"  # the Husky, idle beside it, cannot carry 259 kg


def test_what_a_robot_can_build_is_worked_out_once_per_place_a_component_lies_not_at_every_step(
    monkeypatch,
) -> None:
    """The planner asks, at every step, which robot can build each released task; on a 988-component site
    that question (footprints, load charts) took half the planner's time. It is asked once per robot,
    component and place the component lies, and a footprint at its target is computed once."""
    from bimbot.services.planner import dispatch
    from bimbot.services.planner.work_in_place import target_footprint

    asked: list[tuple[str, str]] = []

    def counting(robot: SiteRobot, component: Component, where: Where) -> bool:
        asked.append((robot.robot_id, component.guid))
        return dispatch.can_build_from.__wrapped__(robot, component, where)

    counting.__wrapped__ = dispatch.can_build_from  # type: ignore[attr-defined]
    monkeypatch.setattr(dispatch, "can_build_from", counting)
    manifest = _manifest(foot_a=259.0, foot_b=259.0, foot_c=259.0)
    robots = [SiteRobot("r1", HUSKY, (0.0, -5.0, 0.0)), SiteRobot("r2", CARRIER, (-30.0, -5.0, 0.0))]
    core = idle_core(manifest, robots)
    _release(core, "foot_a", "foot_b", "foot_c")  # r2 takes one; the two others wait for it
    first = len(asked)
    assert first > 0
    for step in range(2, 30):
        core.step(0.1 * step)
    assert len(asked) == first, "asked again while nothing moved"
    assert set(asked) <= {(r.robot_id, g) for r in robots for g in ("foot_a", "foot_b", "foot_c")}
    component = manifest.component("foot_a")
    assert target_footprint(component) is target_footprint(component)
    pose = component.target_pose_world.model_copy(update={"position_m": (9.0, 9.0, 0.0)})
    moved = component.model_copy(update={"target_pose_world": pose})
    assert target_footprint(moved).polygon_xy_m.mean(axis=0) == pytest.approx((9.0, 9.0), abs=0.5)


def test_bids_are_asked_again_when_something_changed_or_every_rebid_period_not_at_every_step(
    monkeypatch,
) -> None:
    """With tasks waiting for a busy robot and an idle one that cannot take them, the pass over the bids
    runs once per REBID_S of sim time while nothing changes, and at once when a robot comes free; and a
    pass whose only idle robot can take none of them asks no robot for a bid."""
    from bimbot.services.planner import dispatch

    passes: list[float] = []
    bids: list[float] = []
    real_choose, real_could_win = dispatch.choose, dispatch.Dispatch._could_win

    def counting(*args, **kwargs):
        bids.append(kwargs["now_s"])
        return real_choose(*args, **kwargs)

    def counting_passes(self, idle):
        passes.append(self._state.sim_time_s)
        return real_could_win(self, idle)

    monkeypatch.setattr(dispatch, "choose", counting)
    monkeypatch.setattr(dispatch.Dispatch, "_could_win", counting_passes)
    manifest = _manifest(foot_a=259.0, foot_b=259.0, foot_c=259.0)
    robots = [SiteRobot("r1", HUSKY, (0.0, -5.0, 0.0)), SiteRobot("r2", CARRIER, (-30.0, -5.0, 0.0))]
    core = idle_core(manifest, robots)
    assigned = _assignments(_release(core, "foot_a", "foot_b", "foot_c"))
    assert [m.robot_id for m in assigned.values()] == ["r2"]
    core.observe_clock(0.2)
    core.step(0.2)  # the assignment itself changed the records: one more pass
    passes.clear()
    bids.clear()
    for step in range(3, 20):  # 0.3 .. 1.9 s: the idle Husky cannot lift any of them, r2 is busy
        core.observe_clock(0.1 * step)
        core.step(0.1 * step)
    assert passes == [], "no pass while nothing changed for less than REBID_S"
    core.observe_clock(0.2 + dispatch.REBID_S)
    core.step(0.2 + dispatch.REBID_S)
    assert passes, "a pass once REBID_S went by"
    assert bids == [], "the Husky cannot take any: nobody is asked for a bid"
    passes.clear()
    (guid,) = assigned
    core.observe_clock(2.3)
    core.observe_component_state(state_msg(guid, S.CONSTRUCTED, event="verified", sim_time_s=2.3))
    core.observe_robot_state(robot_msg("r2", (0.0, -4.0)))
    core.step(2.3)
    assert passes and bids, "a pass at once when a component was built and its robot came free"


def test_a_beam_a_carrier_could_not_get_to_goes_to_the_crane_by_a_hand_off() -> None:
    """The carrier can set the beam, and takes it first; its target cut off, the carrier gives it back
    ``unreachable``. A site then lifts it with the crane: the next task is a hand-off to the crane's
    staging area, not the same drive again (the Janesville restaurant's canopy tee, given back 3 times)."""
    staging = Rect((-2.0, 16.0), (6.0, 24.0))
    robots = [
        SiteRobot("r1", CARRIER, (-10.0, -10.0, 0.0)),
        SiteRobot("r2", CRANE, (2.0, 12.0, -1.5708), staging),
    ]
    core = idle_core(_manifest(beam=300.0), robots)
    for guid in ("foot_a", "foot_b", "foot_c", "col_a", "col_b", "post_c"):
        core.observe_component_state(state_msg(guid, S.CONSTRUCTED, event="verified"))
    core.observe_component_pose(_pose("beam", (2.0, -58.0)))  # beyond the crane's hook where it lies
    first = _assignments(_release(core, "beam"))["beam"]
    assert (first.robot_id, first.kind) == ("r1", TaskKind.BUILD)
    cut_off = Reason(
        code=ReasonCode.UNREACHABLE, message="the target of beam is cut off from r1", robot_id="r1"
    )
    core.observe_component_state(
        state_msg("beam", S.RELEASED, event="abandon", robot_id="r1", sim_time_s=20.0, reason=cut_off)
    )
    core.observe_robot_state(robot_msg("r1", (0.0, -50.0), sim_time_s=10_000.0))  # past any hold
    again = _assignments(core.step(1.0))["beam"]
    assert (again.robot_id, again.kind) == ("r1", TaskKind.HAND_OFF)
    assert again.put_down_xy_m is not None


def test_what_no_ground_robot_can_get_to_at_its_turn_goes_to_the_crane_first() -> None:
    """The access check found the beam's target closed to ground robots by what stands before it (the
    Revit duplex's upper-floor door in a room its exterior walls close) and a crane on site that sets it:
    the plan lists it ``from_above``. Its first task is the hand-off that brings it under the crane's hook,
    not a drive the carrier cannot finish."""
    staging = Rect((-2.0, 16.0), (6.0, 24.0))
    robots = [
        SiteRobot("r1", CARRIER, (-10.0, -10.0, 0.0)),
        SiteRobot("r2", CRANE, (2.0, 12.0, -1.5708), staging),
    ]
    core = idle_core(_manifest(beam=300.0), robots, from_above=["beam"])
    for guid in ("foot_a", "foot_b", "foot_c", "col_a", "col_b", "post_c"):
        core.observe_component_state(state_msg(guid, S.CONSTRUCTED, event="verified"))
    core.observe_component_pose(_pose("beam", (2.0, -58.0)))  # beyond the crane's hook where it lies
    first = _assignments(_release(core, "beam"))["beam"]
    assert (first.robot_id, first.kind) == ("r1", TaskKind.HAND_OFF)
    assert first.put_down_xy_m is not None
