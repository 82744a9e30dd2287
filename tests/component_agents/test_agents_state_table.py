"""The component state table on its own, and the shared transitions machine built from it."""

from __future__ import annotations

import itertools

import pytest

from bimbot.shared.messages import ComponentEvent, ComponentState
from bimbot.shared.state_table import (
    EXTERNAL_TRIGGERS,
    INITIAL,
    INTERNAL_TRIGGERS,
    TERMINAL,
    TRANSITIONS,
    ComponentMachine,
    Verdict,
    edges,
    next_state,
    reachable_from,
    triggers_from,
)

S = ComponentState

# The construction protocol of docs/architecture.md, written out independently of the table.
EXPECTED_EDGES = {
    ("release", S.PLANNED, S.RELEASED),
    ("pick", S.RELEASED, S.PICKING),
    ("attach", S.PICKING, S.TRANSPORTING),
    ("arrive", S.TRANSPORTING, S.ASSEMBLING),
    ("place", S.ASSEMBLING, S.VERIFYING),
    ("retry", S.MISPLACED, S.RELEASED),
    ("abandon", S.PICKING, S.RELEASED),
    ("abandon", S.TRANSPORTING, S.RELEASED),
    ("abandon", S.ASSEMBLING, S.RELEASED),
    ("hand_off", S.TRANSPORTING, S.RELEASED),
    ("verified", S.VERIFYING, S.CONSTRUCTED),
    ("misplaced_placement", S.VERIFYING, S.MISPLACED),
    ("failed_placement", S.VERIFYING, S.FAILED),
    ("fail", S.PLANNED, S.FAILED),
    ("fail", S.RELEASED, S.FAILED),
    ("fail", S.MISPLACED, S.FAILED),
    ("block", S.PLANNED, S.BLOCKED),
    ("block", S.RELEASED, S.BLOCKED),
    # work in place: cast (formwork, pour), laid and driven, then verified like a placement
    ("form", S.RELEASED, S.FORMING),
    ("pour", S.FORMING, S.POURING),
    ("lay", S.RELEASED, S.LAYING),
    ("drive", S.RELEASED, S.DRIVING),
    ("place", S.POURING, S.VERIFYING),
    ("place", S.LAYING, S.VERIFYING),
    ("place", S.DRIVING, S.VERIFYING),
    ("abandon", S.FORMING, S.RELEASED),
    ("abandon", S.POURING, S.RELEASED),
    ("abandon", S.LAYING, S.RELEASED),
    ("abandon", S.DRIVING, S.RELEASED),
}
ALL_TRIGGERS = sorted(EXTERNAL_TRIGGERS | INTERNAL_TRIGGERS)


def test_table_is_exactly_the_construction_protocol() -> None:
    assert set(edges()) == EXPECTED_EDGES
    assert len(edges()) == len(EXPECTED_EDGES)  # no duplicate rows


def test_table_rows_are_plain_trigger_source_dest_dicts() -> None:
    for row in TRANSITIONS:
        assert set(row) == {"trigger", "source", "dest"}
        assert isinstance(row["dest"], ComponentState)


def test_every_state_is_reachable_from_planned() -> None:
    assert INITIAL is S.PLANNED
    assert reachable_from(S.PLANNED) == set(ComponentState)


def test_constructed_failed_and_blocked_are_terminal() -> None:
    assert {S.CONSTRUCTED, S.FAILED, S.BLOCKED} == TERMINAL
    for state in TERMINAL:
        assert triggers_from(state) == set()
        assert reachable_from(state) == {state}


def test_every_non_terminal_state_can_still_reach_constructed() -> None:
    for state in set(ComponentState) - TERMINAL:
        assert S.CONSTRUCTED in reachable_from(state), state


def test_every_bus_event_is_a_trigger_and_verdicts_only_leave_verifying() -> None:
    triggers = {name for name, _, _ in edges()}
    assert {event.value for event in ComponentEvent} <= triggers
    assert {verdict.value for verdict in Verdict} <= triggers
    assert not EXTERNAL_TRIGGERS & INTERNAL_TRIGGERS
    for name, source, _ in edges():
        if name in INTERNAL_TRIGGERS:
            assert source is S.VERIFYING
    assert triggers_from(S.VERIFYING) == INTERNAL_TRIGGERS  # nothing from outside while it verifies


def test_place_is_strict_not_accepted_while_transporting() -> None:
    assert next_state(S.TRANSPORTING, "place") is None
    assert next_state(S.ASSEMBLING, "place") is S.VERIFYING


def test_misplaced_only_goes_back_through_retry_or_fails() -> None:
    assert triggers_from(S.MISPLACED) == {"retry", "fail"}
    assert next_state(S.MISPLACED, "retry") is S.RELEASED


class _Model:
    __slots__ = ("state",)  # like the agent: nothing can be bound onto it


@pytest.mark.parametrize(("state", "trigger"), list(itertools.product(ComponentState, ALL_TRIGGERS)))
def test_machine_applies_exactly_the_table(state: ComponentState, trigger: str) -> None:
    machine = ComponentMachine()
    model = _Model()
    machine.start(model, state)
    allowed = machine.may_fire(model, trigger)
    applied = machine.fire(model, trigger)
    expected = next_state(state, trigger)
    assert allowed is applied is (expected is not None)
    assert model.state is (expected if expected is not None else state)


def test_machine_has_no_auto_transitions_and_starts_models_planned() -> None:
    machine = ComponentMachine()
    assert set(machine.machine.events) == {name for name, _, _ in edges()}
    model = _Model()
    machine.start(model)
    assert model.state is S.PLANNED


def test_one_machine_serves_many_models_independently() -> None:
    machine = ComponentMachine()
    models = [_Model() for _ in range(3)]
    for model in models:
        machine.start(model)
    assert machine.fire(models[1], "release")
    assert [model.state for model in models] == [S.PLANNED, S.RELEASED, S.PLANNED]
