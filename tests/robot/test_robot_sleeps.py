"""A robot in lock-step sleeps while its executor says it can (idle, nothing ahead): its answer says so,
the steps after it are neither ticked nor answered, and it wakes, ticks and answers at the step that takes
the planner's task message, two steps after the planner's answer that said it sent one: the first clock
that names a wake after its sleep. Without this the robot answers every step and physics waits for it
(tests/shared/test_step_gate_sleep.py). Whichever sensors physics sends it while it sleeps, it does the
same: it takes its inputs only at the steps physics always sends, and at its wake."""

from __future__ import annotations

from dataclasses import dataclass, field

from bimbot.services.robot.protocol import Outgoing
from bimbot.services.robot.stepped import SteppedTicks
from bimbot.shared.bus import Received
from bimbot.shared.messages import (
    COMPONENT_STATE,
    PLANNER_PARTICIPANT,
    ROBOT_SENSORS,
    TASK,
    ClockMsg,
    CmdVelMsg,
    ComponentState,
    ComponentStateMsg,
    OdomMsg,
    PoseMsg,
    SensorsMsg,
    TaskMsg,
    TaskStatus,
)
from bimbot.shared.step_gate import DELAY_STEPS, SLEEP_TAKE_STEPS

PERIOD_S = 0.2


@dataclass
class _IdleExecutor:
    """Idle until a task comes; records the steps it was ticked at and the tasks it was handed."""

    robot_id: str = "r1"
    sim_s: float = 0.0
    step: int = -1
    ticked: list[int] = field(default_factory=list)
    tasks: list[str] = field(default_factory=list)
    states: list[tuple[int, str]] = field(default_factory=list)  # (step taken at, GUID)

    def handle(self, message: object) -> None:
        if isinstance(message, TaskMsg):
            self.tasks.append(message.task_id)
        if isinstance(message, ComponentStateMsg):
            self.states.append((self.step, message.guid))

    def tick(self, clock: ClockMsg, wall_s: float) -> list[Outgoing]:
        self.ticked.append(clock.step)
        return [
            CmdVelMsg(
                robot_id=self.robot_id, v_mps=0, w_radps=0, sim_time_s=clock.sim_time_s, step=clock.step
            )
        ]

    def after_tick(self) -> None:
        return None

    def can_sleep(self) -> bool:
        return not self.tasks

    def sleeps_until_s(self) -> float | None:
        return None


@dataclass
class _DrivingExecutor(_IdleExecutor):
    """A kinematic robot that drives until ``drive_end_s`` (it may sleep through it), then waits awake."""

    drive_end_s: float = 3.0

    def can_sleep(self) -> bool:
        return False

    def sleeps_until_s(self) -> float | None:
        return self.drive_end_s if self.sim_s < self.drive_end_s else None

    def tick(self, clock: ClockMsg, wall_s: float) -> list[Outgoing]:
        self.sim_s = clock.sim_time_s
        return super().tick(clock, wall_s)


def _sensors(step: int, last_wake_step: int | None) -> Received[SensorsMsg]:
    now = step * PERIOD_S
    clock = ClockMsg(
        sim_time_s=now,
        step=step,
        real_time_factor=1.0,
        lock_step=True,
        inputs_to_s=max(0, step - DELAY_STEPS) * PERIOD_S,
        last_wake_step=last_wake_step,
    )
    odom = OdomMsg(robot_id="r1", pose_xy_yaw=(0.0, 0.0, 0.0), v_mps=0, w_radps=0, sim_time_s=now)
    return Received(ROBOT_SENSORS, "s", SensorsMsg(robot_id="r1", clock=clock, odom=odom))


def _state(step: int) -> Received[ComponentStateMsg]:
    state = ComponentStateMsg(
        guid=f"g{step}",
        state=ComponentState.RELEASED,
        event="release",
        sim_time_s=step * PERIOD_S,
        wall_time_s=0.0,
    )
    return Received(COMPONENT_STATE, "c", state)


def _task(step: int) -> Received[TaskMsg]:
    task = TaskMsg(
        task_id="T1",
        guid="g",
        component_key="k",
        status=TaskStatus.ASSIGNED,
        robot_id="r1",
        target_pose=PoseMsg(position_m=(0.0, 0.0, 0.0), quat_xyzw=(0.0, 0.0, 0.0, 1.0)),
        sim_time_s=step * PERIOD_S,
        wall_time_s=0.0,
    )
    return Received(TASK, "t", task)


def _run(
    steps: int, task_at: int | None, *, participants: list[str], every_sensors: bool = True
) -> tuple[_IdleExecutor, list[CmdVelMsg]]:
    """``every_sensors``: physics sent every step's sensors (it had not heard the sleep, say); else only
    the ones it always sends a sleeper (every ``SLEEP_TAKE_STEPS``-th step, and from its wake)."""
    executor = _IdleExecutor()
    answers: list[CmdVelMsg] = []
    ticks = SteppedTicks(
        executor,  # type: ignore[arg-type]
        lambda said: answers.extend(m for m in said if isinstance(m, CmdVelMsg)),
        lambda: None,
        {},
        participants,
    )
    wake = None if task_at is None else task_at + DELAY_STEPS
    for step in range(steps):
        if step == task_at:
            ticks.hear(_task(step))
        ticks.hear(_state(step))
        woke = wake is not None and step >= wake
        asleep = answers and answers[-1].sleeps and not woke
        if every_sensors or not asleep or step % SLEEP_TAKE_STEPS == 0:
            ticks.hear(_sensors(step, wake if woke else None))
        ticks.tick_ready()
    return executor, answers


def test_an_idle_robot_sleeps_and_wakes_at_the_step_that_takes_the_task() -> None:
    for every_sensors in (True, False):
        executor, answers = _run(
            20, task_at=10, participants=["r1", PLANNER_PARTICIPANT], every_sensors=every_sensors
        )
        # step 0 is ticked and says it sleeps; nothing until 12, which takes the task stamped at 10
        assert executor.ticked[0] == 0 and answers[0].sleeps
        assert executor.ticked[1] == 12 and executor.tasks == ["T1"]
        assert [a.step for a in answers if not a.sleeps] == list(range(12, 20))
        assert executor.ticked == [0, *range(12, 20)]


def test_a_sleeper_takes_its_inputs_only_where_physics_always_sends_its_sensors() -> None:
    taken = []
    for every_sensors in (True, False):
        executor, _ = _run(
            SLEEP_TAKE_STEPS + 5,
            task_at=None,
            participants=["r1", PLANNER_PARTICIPANT],
            every_sensors=every_sensors,
        )
        assert executor.ticked == [0]
        taken.append(executor.states)
    assert taken[0] == taken[1]
    at = {step for step, _ in taken[0]}
    assert at == {0, SLEEP_TAKE_STEPS}  # everything up to step SLEEP_TAKE_STEPS − 2, in one go
    assert len(taken[0]) == SLEEP_TAKE_STEPS - DELAY_STEPS + 1


def test_without_the_planner_answering_steps_nobody_could_wake_it_so_it_never_sleeps() -> None:
    executor, answers = _run(8, task_at=None, participants=[])
    assert executor.ticked == list(range(8)) and not any(a.sleeps for a in answers)


def test_a_kinematic_robot_sleeps_through_its_drive_and_wakes_at_the_step_that_reaches_its_end() -> None:
    """Physics and the robot tell the wake from the step's clock alone; a task message wakes it sooner."""
    for task_at in (None, 5):
        for every_sensors in (True, False):
            executor = _DrivingExecutor()
            answers: list[CmdVelMsg] = []
            ticks = SteppedTicks(
                executor,  # type: ignore[arg-type]
                answers.extend,
                lambda: None,
                {},
                ["r1", PLANNER_PARTICIPANT],
            )
            wake = None if task_at is None else task_at + DELAY_STEPS
            for step in range(20):
                if step == task_at:
                    ticks.hear(_task(step))
                woke = (wake is not None and step >= wake) or step * PERIOD_S >= executor.drive_end_s
                asleep = answers and answers[-1].sleeps and not woke
                if every_sensors or not asleep or step % SLEEP_TAKE_STEPS == 0:
                    ticks.hear(_sensors(step, wake if wake is not None and step >= wake else None))
                ticks.tick_ready()
            answers = [m for m in answers if isinstance(m, CmdVelMsg)]
            assert answers[0].sleeps and answers[0].wakes_at_s == executor.drive_end_s
            end_step = round(executor.drive_end_s / PERIOD_S)  # 15: the first step at the drive's end
            if task_at is None:
                assert executor.ticked == [0, *range(end_step, 20)]
            else:  # woken at 7 by the task, asleep again until the drive ends
                assert executor.ticked == [0, task_at + DELAY_STEPS, *range(end_step, 20)]
            assert not any(a.sleeps for a in answers if a.step is not None and a.step >= end_step)
