"""Curing holds: what rests on a cast footing is released only once the footing has cured, the progress says
what waits and until when, and a restarted planner rebuilds the hold from the twins' histories."""

from __future__ import annotations

import itertools

from planner_builders import portal_manifest, state_msg, twin_msg, with_methods

from bimbot.services.planner.scheduler import Phase, PlannerCore
from bimbot.services.planner.sources import plan_from_sequence
from bimbot.shared.construction_methods import ConstructionMethod
from bimbot.shared.messages import ComponentEvent, ComponentEventMsg, ComponentState, CuringHold
from bimbot.shared.support_graph import derive_sequence

S = ComponentState
CURE_S = 86400.0  # planner_builders.FOOTING_CAST


def _core() -> PlannerCore:
    """The portal with foot_a cast in place (col_a rests on it); no robots: only the release is watched."""
    manifest = with_methods(portal_manifest(), foot_a=ConstructionMethod.CAST_IN_PLACE)
    plan = plan_from_sequence(derive_sequence(manifest.components), manifest.components, "test")
    counter = itertools.count(1)
    return PlannerCore(manifest, plan, new_id=lambda: f"ev{next(counter)}")


def _released(out: list) -> set[str]:
    return {m.guid for m in out if isinstance(m, ComponentEventMsg) and m.event is ComponentEvent.RELEASE}


def test_a_column_on_a_cast_footing_is_released_only_after_the_footing_has_cured() -> None:
    core = _core()
    core.step(0.0)
    core.observe_component_state(state_msg("foot_a", S.CONSTRUCTED, event="verified", sim_time_s=100.0))
    core.observe_component_state(state_msg("foot_b", S.CONSTRUCTED, event="verified", sim_time_s=120.0))
    out = core.step(1.0)
    assert "col_b" in _released(out)  # on a lifted footing: released at once
    assert "col_a" not in _released(out) and core.phase("col_a") is Phase.WAITING
    assert core.progress().curing == [CuringHold(guid="col_a", cast_guid="foot_a", until_s=100.0 + CURE_S)]
    core.observe_clock(100.0 + CURE_S - 1.0)
    assert "col_a" not in _released(core.step(2.0))
    core.observe_clock(100.0 + CURE_S)  # no state changed: the hold's end alone runs the release again
    assert "col_a" in _released(core.step(3.0))
    assert core.phase("col_a") is Phase.RELEASED and core.progress().curing == []


def test_a_restarted_planner_holds_from_the_time_in_the_twins_history_not_from_its_own_start() -> None:
    core = _core()
    core.observe_clock(5000.0)
    constructed = state_msg(
        "foot_a", S.CONSTRUCTED, event="verified", sim_time_s=100.0, previous=S.VERIFYING, wall_time_s=1.0
    )
    core.observe_twin(twin_msg("foot_a", S.CONSTRUCTED, placed_at_s=90.0, history=[constructed]))
    core.step(0.0)
    assert core.phase("col_a") is Phase.WAITING
    assert [hold.until_s for hold in core.progress().curing] == [100.0 + CURE_S]
    core.observe_clock(100.0 + CURE_S)
    assert "col_a" in _released(core.step(1.0))


def test_a_twin_without_history_is_taken_as_constructed_when_seen_so_the_hold_is_never_shorter() -> None:
    core = _core()
    core.observe_clock(5000.0)
    core.observe_twin(twin_msg("foot_a", S.CONSTRUCTED, placed_at_s=90.0))
    core.step(0.0)
    assert [hold.until_s for hold in core.progress().curing] == [5000.0 + CURE_S]


def test_a_cast_footing_cured_long_ago_holds_nothing_after_a_restart() -> None:
    core = _core()
    core.observe_clock(2 * CURE_S)
    constructed = state_msg("foot_a", S.CONSTRUCTED, event="verified", sim_time_s=100.0, wall_time_s=1.0)
    core.observe_twin(twin_msg("foot_a", S.CONSTRUCTED, history=[constructed]))
    assert "col_a" in _released(core.step(0.0))
    assert core.progress().curing == []


def test_the_planner_s_next_own_event_is_the_end_of_the_curing_it_holds_a_task_for() -> None:
    """Physics' plan fidelity knows the robots' timed work, not the curing: the planner says its end in
    its answer to each step (``StepDoneMsg.next_event_s``), and nothing once it has passed."""
    core = _core()
    core.step(0.0)
    assert core.next_own_event_s() is None  # nothing cures yet
    core.observe_component_state(state_msg("foot_a", S.CONSTRUCTED, event="verified", sim_time_s=100.0))
    core.observe_clock(101.0)
    core.step(1.0)
    assert core.next_own_event_s() == 100.0 + CURE_S
    core.observe_clock(100.0 + CURE_S)
    core.step(2.0)
    assert core.next_own_event_s() is None
