"""The robot's task states as data: the paper's cycle, aborts from anywhere, nothing else."""

from __future__ import annotations

import pytest

from bimbot.services.robot.task_machine import (
    INITIAL,
    PAPER_ORDER,
    TRANSITIONS,
    TaskMachine,
    Trigger,
    next_state,
    triggers_from,
)
from bimbot.shared.messages import RobotState

CYCLE = (Trigger.ASSIGNED, Trigger.LOCATED, Trigger.ATTACHED, Trigger.ARRIVED, Trigger.FINISHED)


def test_the_happy_path_visits_the_papers_states_in_order() -> None:
    machine = TaskMachine()
    seen = [machine.state]
    for trigger in CYCLE:
        assert machine.fire(trigger)
        seen.append(machine.state)
    assert tuple(seen) == PAPER_ORDER
    assert machine.state is INITIAL is RobotState.IDLE


@pytest.mark.parametrize("state", [s for s in RobotState if s is not RobotState.IDLE])
def test_every_busy_state_can_be_aborted_back_to_idle(state: RobotState) -> None:
    assert next_state(state, Trigger.ABORTED) is RobotState.IDLE


def test_idle_only_accepts_an_assignment() -> None:
    assert triggers_from(RobotState.IDLE) == {Trigger.ASSIGNED, Trigger.WORK_ASSIGNED}


def test_out_of_order_triggers_are_refused_and_leave_the_state_alone() -> None:
    machine = TaskMachine()
    assert not machine.fire(Trigger.ATTACHED)
    assert machine.state is RobotState.IDLE
    machine.fire(Trigger.ASSIGNED)
    assert not machine.can(Trigger.ARRIVED) and not machine.fire(Trigger.FINISHED)
    assert machine.state is RobotState.DETECT_COMPONENT_POSITION


def test_the_table_is_deterministic_and_every_state_is_reachable() -> None:
    pairs = [(trigger, source) for trigger, source, _ in TRANSITIONS]
    assert len(pairs) == len(set(pairs)), "one destination per (trigger, state)"
    reached = {RobotState.IDLE} | {dest for _, _, dest in TRANSITIONS}
    assert reached == set(RobotState)
