"""An idle robot sleeps: physics does not wait for its answers from the step after the one it said so in,
until the step a task message is taken at (the planner's answer says it sent one), and sends it its
sensors only at its wake and every ``SLEEP_TAKE_STEPS``-th step. Each clock says the latest wake at or
before it, so the robot knows from its sensors alone when it woke. Reckoned by step numbers, so a sleep and
a wake give the same waits in whichever order they arrive (same-seed runs rest on it)."""

from __future__ import annotations

from bimbot.services.physics.clock import LockStepBarrier
from bimbot.services.physics.sleepers import Sleepers
from bimbot.shared.step_gate import DELAY_STEPS, SLEEP_TAKE_STEPS, woken


def _barrier_at(step: int) -> LockStepBarrier:
    barrier = LockStepBarrier(timeout_s=10.0)
    barrier.open(step, 0.0)
    return barrier


def test_physics_does_not_wait_for_a_sleeping_robot_until_its_wake() -> None:
    barrier = _barrier_at(9)
    barrier.record("r1", 5, sleeps=True)
    barrier.record("r2", 9)
    assert barrier.missing(["r1", "r2"]) == []
    barrier.wake_sleepers(9)
    assert barrier.missing(["r1", "r2"]) == ["r1"]
    barrier.record("r1", 9)
    assert barrier.missing(["r1", "r2"]) == []


def test_a_sleeper_is_waited_for_from_its_wake_on() -> None:
    barrier = LockStepBarrier(timeout_s=10.0)
    barrier.record("r1", 5, sleeps=True)
    barrier.wake_sleepers(12 + DELAY_STEPS)  # the planner sent a task at 12: r1 takes it at 14
    barrier.open(13, 0.0)
    assert barrier.missing(["r1"]) == []  # it slept through 13
    barrier.open(14, 0.0)
    assert barrier.missing(["r1"]) == ["r1"]  # the step it wakes at


def test_a_wake_heard_before_the_sleep_it_ends_counts_alike() -> None:
    waits = []
    for wake_first in (False, True):
        barrier = LockStepBarrier(timeout_s=10.0)
        barrier.record("r1", 4)
        if wake_first:
            barrier.wake_sleepers(8)
            barrier.record("r1", 5, sleeps=True)
        else:
            barrier.record("r1", 5, sleeps=True)
            barrier.wake_sleepers(8)
        missing = []
        for step in range(6, 10):
            barrier.open(step, 0.0)
            missing.append(barrier.missing(["r1"]))
        waits.append(missing)
    assert waits[0] == waits[1] == [[], [], ["r1"], ["r1"]]


def test_a_clock_says_the_latest_wake_at_or_before_it_even_one_long_forgotten() -> None:
    sleepers = Sleepers()
    assert sleepers.latest_wake(100) is None
    sleepers.wake({}, 14)
    sleepers.wake({}, 20)  # heard early: a clock before 20 does not name it
    assert sleepers.latest_wake(13) is None and sleepers.latest_wake(19) == 14
    assert sleepers.latest_wake(20) == 20
    sleepers.forget_before(50)
    assert sleepers.wakes == set() and sleepers.latest_wake(60) == 20


def test_a_robot_tells_its_wake_from_the_clock_alone() -> None:
    assert not woken(6, None) and not woken(6, 6)  # a wake at the step it fell asleep after is before it
    assert woken(6, 7) and woken(6, 30)


def test_physics_sends_a_sleeper_its_sensors_only_every_few_steps_and_once_it_woke() -> None:
    sleepers = Sleepers()
    answered: dict[str, int] = {}
    sleepers.answered(answered, "r1", 5, sleeps=True)
    sent = [step for step in range(6, 3 * SLEEP_TAKE_STEPS) if sleepers.sends_sensors("r1", step)]
    assert sent == [SLEEP_TAKE_STEPS, 2 * SLEEP_TAKE_STEPS]
    assert sleepers.sends_sensors("r2", 7)  # awake: every step
    sleepers.wake(answered, 70)
    assert sleepers.sends_sensors("r1", 70) and answered["r1"] == 69


def test_a_driving_sleeper_is_waited_for_from_the_first_step_that_reaches_its_wake_time() -> None:
    """Physics tells the wake from each clock it publishes; a step published before it heard the sleep
    counts too (it publishes step k once it heard the answers to k − 2)."""
    barrier = LockStepBarrier(timeout_s=10.0)
    for step, sim_s in ((6, 1.2), (7, 1.4)):
        barrier.publishing(step, sim_s)
    barrier.record("r1", 5, sleeps=True, wakes_at_s=2.0)
    barrier.open(7, 0.0)
    assert barrier.missing(["r1"]) == [] and not barrier.sleepers.sends_sensors("r1", 8)
    barrier.publishing(8, 5.0)  # a jump to the drive's end
    barrier.open(8, 0.0)
    assert barrier.missing(["r1"]) == ["r1"] and barrier.sleepers.sends_sensors("r1", 8)

    late = LockStepBarrier(timeout_s=10.0)
    late.publishing(6, 2.4)  # already past its wake when the sleep said at 5 came
    late.record("r1", 5, sleeps=True, wakes_at_s=2.0)
    late.open(6, 0.0)
    assert late.missing(["r1"]) == ["r1"]
