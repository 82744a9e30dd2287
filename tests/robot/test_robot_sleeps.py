"""A robot in lock-step sleeps while its executor says it can (idle, nothing ahead): its answer says so,
the steps after it are neither ticked nor answered, and it wakes, ticks and answers at the step that takes
the planner's task message, two steps after the planner's answer that said it sent one. Without this the
robot answers every step and every participant waits for it (tests/shared/test_step_gate_sleep.py)."""

from __future__ import annotations

from dataclasses import dataclass, field

from bimbot.services.robot.protocol import Outgoing
from bimbot.services.robot.stepped import SteppedTicks
from bimbot.shared.bus import Received
from bimbot.shared.messages import (
    PLANNER_PARTICIPANT,
    ROBOT_SENSORS,
    STEP_DONE,
    TASK,
    ClockMsg,
    CmdVelMsg,
    OdomMsg,
    PoseMsg,
    SensorsMsg,
    StepDoneMsg,
    TaskMsg,
    TaskStatus,
)

PERIOD_S = 0.2


@dataclass
class _IdleExecutor:
    """Idle until a task comes; records the steps it was ticked at and the tasks it was handed."""

    robot_id: str = "r1"
    sim_s: float = 0.0
    step: int = -1
    ticked: list[int] = field(default_factory=list)
    tasks: list[str] = field(default_factory=list)

    def handle(self, message: object) -> None:
        if isinstance(message, TaskMsg):
            self.tasks.append(message.task_id)

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


def _sensors(step: int) -> Received[SensorsMsg]:
    now = step * PERIOD_S
    clock = ClockMsg(sim_time_s=now, step=step, real_time_factor=1.0, lock_step=True)
    odom = OdomMsg(robot_id="r1", pose_xy_yaw=(0.0, 0.0, 0.0), v_mps=0, w_radps=0, sim_time_s=now)
    return Received(ROBOT_SENSORS, "s", SensorsMsg(robot_id="r1", clock=clock, odom=odom))


def _planner(step: int, *, wakes: bool = False) -> Received[StepDoneMsg]:
    answer = StepDoneMsg(participant=PLANNER_PARTICIPANT, step=step, sim_time_s=step * PERIOD_S, wakes=wakes)
    return Received(STEP_DONE, "d", answer)


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
    steps: int, task_at: int | None, *, participants: list[str]
) -> tuple[_IdleExecutor, list[CmdVelMsg]]:
    executor = _IdleExecutor()
    answers: list[CmdVelMsg] = []
    ticks = SteppedTicks(
        executor,  # type: ignore[arg-type]
        lambda said: answers.extend(m for m in said if isinstance(m, CmdVelMsg)),
        lambda: None,
        {},
        participants,
    )
    for step in range(steps):
        if step == task_at:
            ticks.hear(_task(step))
        if PLANNER_PARTICIPANT in participants:
            ticks.hear(_planner(step, wakes=step == task_at))
        ticks.hear(_sensors(step))
        ticks.tick_ready()
    return executor, answers


def test_an_idle_robot_sleeps_and_wakes_at_the_step_that_takes_the_task() -> None:
    executor, answers = _run(20, task_at=10, participants=["r1", PLANNER_PARTICIPANT])
    # step 0 is ticked and says it sleeps; nothing until 12, which takes the task stamped at 10
    assert executor.ticked[0] == 0 and answers[0].sleeps
    assert executor.ticked[1] == 12 and executor.tasks == ["T1"]
    assert [a.step for a in answers if not a.sleeps] == list(range(12, 20))
    assert executor.ticked == [0, *range(12, 20)]


def test_without_the_planner_answering_steps_nobody_could_wake_it_so_it_never_sleeps() -> None:
    executor, answers = _run(8, task_at=None, participants=["r1"])
    assert executor.ticked == list(range(8)) and not any(a.sleeps for a in answers)
