"""An idle robot sleeps: its answers are not waited for from the step after the one it said so in, until
the step a task message is taken at (the planner's answer says it sent one). Reckoned by step numbers,
so a sleep and a wake give the same waits in whichever order they arrive (same-seed runs rest on it)."""

from __future__ import annotations

from bimbot.services.physics.clock import LockStepBarrier
from bimbot.shared.step_gate import DELAY_STEPS, StepGate


def _gate(steps: int) -> StepGate[str]:
    gate: StepGate[str] = StepGate()
    for step in range(steps):
        gate.clock(step, step * 0.2)
    gate.expect(["r1", "planner"])
    return gate


def _planner_answers(gate: StepGate[str], up_to: int) -> None:
    for step in range(up_to + 1):
        gate.answered("planner", step)


def test_a_sleeper_is_not_waited_for_until_its_wake_then_from_the_wake_on() -> None:
    gate = _gate(30)
    _planner_answers(gate, 27)
    gate.answered("r1", 5, sleeps=True)
    assert gate.waiting_for(7) == [] and gate.waiting_for(20) == []  # asleep: answered as far as anyone asks
    gate.wake_sleepers(12 + DELAY_STEPS)  # the planner sent a task at 12: r1 takes it at 14
    assert gate.waiting_for(15) == []  # needs r1's answers up to 13: it slept through them
    assert gate.waiting_for(16) == ["r1"]  # needs its answer to 14, the step it wakes at
    gate.answered("r1", 14)
    assert gate.waiting_for(16) == [] and gate.waiting_for(17) == ["r1"]


def test_a_wake_heard_before_the_sleep_it_ends_counts_alike() -> None:
    waits = []
    for wake_first in (False, True):
        gate = _gate(30)
        _planner_answers(gate, 27)
        gate.answered("r1", 4)
        if wake_first:
            gate.wake_sleepers(8)
            gate.answered("r1", 5, sleeps=True)
        else:
            gate.answered("r1", 5, sleeps=True)
            gate.wake_sleepers(8)
        waits.append([gate.waiting_for(step) for step in range(6, 12)])
    assert waits[0] == waits[1]
    assert waits[0] == [[], [], [], [], ["r1"], ["r1"]]  # steps 10 and 11 need its answers to 8 and 9


def test_a_wake_before_the_sleep_wakes_nobody_and_a_sleeper_knows_its_own_wake() -> None:
    gate = _gate(30)
    _planner_answers(gate, 27)
    gate.wake_sleepers(6)
    gate.answered("r1", 6, sleeps=True)  # asleep after 6: the wake at 6 is not after it
    assert gate.waiting_for(20) == []
    assert not gate.woken(6, 20)
    gate.wake_sleepers(21)
    assert not gate.woken(6, 20) and gate.woken(6, 21)


def test_an_awake_answer_after_a_sleep_is_waited_for_as_it_comes() -> None:
    gate = _gate(30)
    _planner_answers(gate, 27)
    gate.answered("r1", 5, sleeps=True)
    gate.answered("r1", 9)  # it restarted, awake
    assert gate.waiting_for(11) == [] and gate.waiting_for(12) == ["r1"]


def test_physics_does_not_wait_for_a_sleeping_robot_until_its_wake() -> None:
    barrier = LockStepBarrier(timeout_s=10.0)
    barrier.record("r1", 5, sleeps=True)
    barrier.record("r2", 9)
    barrier.open(9, 0.0)
    assert barrier.missing(["r1", "r2"]) == []
    barrier.wake_sleepers(9)
    assert barrier.missing(["r1", "r2"]) == ["r1"]
    barrier.record("r1", 9)
    assert barrier.missing(["r1", "r2"]) == []
