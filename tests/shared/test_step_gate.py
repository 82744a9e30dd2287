"""The step gate takes each stamped input at one defined step, in one defined order, whatever the
order and the moment it arrived in (the determinism of lock-step runs rests on it)."""

from __future__ import annotations

import pytest

from bimbot.shared.step_gate import StepGate


def _clocked(steps: int, period_s: float = 0.2) -> StepGate[str]:
    gate: StepGate[str] = StepGate()
    for step in range(steps):
        gate.clock(step, step * period_s)
    return gate


def test_a_step_takes_what_is_stamped_two_steps_before_in_stamp_then_sender_order() -> None:
    arrivals = [(0.2, "r2", "b"), (0.0, "r3", "c"), (0.2, "r1", "a"), (0.4, "r1", "late")]
    taken = []
    for order in (arrivals, list(reversed(arrivals))):
        gate = _clocked(4)
        for stamp, sender, item in order:
            gate.put(stamp, sender, item)
        taken.append((gate.take(2), gate.take(3), gate.take(4)))
    assert taken[0] == taken[1] == (["c"], ["a", "b"], ["late"])


def test_the_first_steps_heard_take_nothing() -> None:
    gate = _clocked(2)
    gate.put(0.0, "planner", "task")
    assert gate.take(0) == [] and gate.take(1) == []
    gate.clock(2, 0.4)
    assert gate.take(2) == ["task"]


def test_a_step_takes_up_to_the_time_its_clock_vouches_for() -> None:
    """Physics' clock says up to when every participant's output has come: a participant that slept
    through the steps between still takes each input at the step whose clock covers it."""
    gate: StepGate[str] = StepGate()
    gate.put(0.2, "r1", "early")
    gate.put(0.6, "planner", "task")
    gate.put(9.0, "r2", "later")
    gate.clock(40, 8.0, inputs_to_s=0.6)  # no clock heard before it: the time comes with this one
    assert gate.ready(40) and gate.take(40) == ["early", "task"]
    gate.clock(90, 18.0, inputs_to_s=17.6)
    assert gate.take(90) == ["later"]


def test_a_step_with_an_unresolved_input_is_taken_only_when_forced_and_leaves_it_for_later() -> None:
    gate = _clocked(5)
    gate.put(0.2, "0abc", "constructed (claim)", resolved=False)
    gate.put(0.2, "r1", "state")
    assert not gate.ready(3)
    with pytest.raises(RuntimeError):
        gate.take(3)
    assert gate.take(3, force=True) == ["state"] and gate.forced == 1
    gate.resolve("constructed (claim)")
    assert gate.take(4) == ["constructed (claim)"]


def test_an_input_waiting_for_an_answer_holds_its_step_and_is_taken_in_its_place() -> None:
    gate = _clocked(4)
    claim = "constructed (claim)"
    gate.put(0.2, "0abc", claim, resolved=False)
    gate.put(0.2, "1def", "released")
    assert gate.ready(2) and gate.take(2) == []
    assert not gate.ready(3)
    assert gate.resolve(claim, "constructed (twin)")
    assert gate.take(3) == ["constructed (twin)", "released"]


def test_a_repeated_delivery_is_dropped_and_a_late_one_counted() -> None:
    gate = _clocked(4)
    assert gate.put(0.0, "r1", "event", key="e1")
    assert not gate.put(0.0, "r1", "event", key="e1")
    assert gate.take(2) == ["event"]
    assert gate.note_late(0.0, 2) and gate.late == 1
    assert not gate.note_late(0.4, 2)


def test_a_participant_far_behind_still_takes_each_input_at_its_own_step() -> None:
    gate = _clocked(40)  # forty clocks heard before the first step is taken
    gate.put(0.2, "r1", "early")
    gate.put(6.0, "r1", "late")
    taken = {step: gate.take(step) for step in range(40)}
    assert taken[3] == ["early"] and taken[32] == ["late"]
    assert sum(len(items) for items in taken.values()) == 2
