"""The planner's records: a task's phase and bounds, what it knows of robots and components (plain data).

Kept apart from :mod:`.scheduler` (the decisions) so the core reads as the protocol it implements.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection
from dataclasses import dataclass, field
from enum import StrEnum

from bimbot.shared.messages import ComponentEventMsg, ComponentState, RobotState, TaskKind, TaskMsg
from bimbot.shared.reasons import Reason

SOURCE = "planner"
CARRYING = frozenset(
    {
        ComponentState.PICKING,
        ComponentState.TRANSPORTING,
        ComponentState.ASSEMBLING,
        ComponentState.FORMING,
        ComponentState.POURING,
        ComponentState.LAYING,
        ComponentState.DRIVING,
    }
)
TERMINAL = frozenset({ComponentState.CONSTRUCTED, ComponentState.FAILED, ComponentState.BLOCKED})
#: Components worked on in place by a robot in timed work (forming, pouring, laying, driving).
WORKING = frozenset(
    {ComponentState.FORMING, ComponentState.POURING, ComponentState.LAYING, ComponentState.DRIVING}
)
Outgoing = ComponentEventMsg | TaskMsg


@dataclass(frozen=True)
class PlannerLimits:
    """The planner's bounds: every retry counted, every wait bounded in sim time."""

    max_give_backs: int = 3  # a component given back this often (by any robots) is failed
    task_timeout_s: float = 1200.0  # sim seconds an assigned task may go without a component state change
    # A robot that gave back this many tasks in a row (boxed in, lost) gets no task for hold_s of sim time,
    # twice as long after each further one, hold_max_s at most: handed task after task, a boxed-in robot
    # gave back 320 on the 988-component site and failed components others could build.
    hold_after_give_backs: int = 2
    hold_s: float = 60.0
    hold_max_s: float = 600.0
    # A robot whose liveliness is gone while it holds a task keeps the task this many wall seconds: back
    # within them and still reporting it, it goes on; back without it (restarted) or not back, the task is
    # given back. 0 (one host: a lost robot is a dead process) gives it back at the next step; a site
    # across hosts allows for a link or router that is down for seconds (bimbot run --routers 2).
    lost_grace_wall_s: float = 0.0


class Phase(StrEnum):
    """A task's phase in the planner (finer than :class:`TaskStatus`)."""

    WAITING = "waiting"  # predecessors not all constructed
    RELEASED = "released"  # released; assignable once its component reports released
    ASSIGNED = "assigned"  # a robot works on it (or the component is verifying)
    DONE = "done"
    FAILED = "failed"
    BLOCKED = "blocked"  # a predecessor failed; never released


FINAL = frozenset({Phase.DONE, Phase.FAILED, Phase.BLOCKED})


@dataclass
class TaskRecord:
    guid: str
    task_id: str
    priority: int
    phase: Phase = Phase.WAITING
    robot_id: str | None = None
    assigned_sim_s: float | None = None
    duration_sim_s: float | None = None
    changed_sim_s: float = 0.0  # last assignment or component state change (the no-progress watchdog)
    give_backs: int = 0
    given_back_by: set[str] = field(default_factory=set)  # robots that gave it back: others first
    given_back_s: float | None = None  # sim time of its last give-back by a robot
    last_give_back: Reason | None = None
    reason: Reason | None = None  # failed/blocked: why
    kind: TaskKind = TaskKind.BUILD  # HAND_OFF while a ground robot carries it to a crane's staging spot
    hand_offs: int = 0  # hand-off tasks started for it (each its own task id)
    hand_offs_given_back: int = 0  # of those, given back by the robot carrying it (never put down)
    put_down_xy: tuple[float, float] | None = None  # the staging spot of the current hand-off

    @property
    def active_id(self) -> str:
        """The id of the task a robot works on now: the build task's, or the current hand-off's."""
        return self.task_id if self.kind is TaskKind.BUILD else f"{self.task_id}-h{self.hand_offs}"


@dataclass
class RobotRecord:
    robot_id: str
    alive: bool = False
    state: RobotState | None = None
    reported_task_id: str | None = None
    pose_xy_yaw: tuple[float, float, float] | None = None
    task_guid: str | None = None  # the task the planner gave it, until its part is over
    busy_until_s: float = 0.0  # sim time its current task should be over (its winning bid)
    # timed work in place: the robot says nothing of it changes before this sim time (its state message)
    reported_busy_until_s: float | None = None
    give_backs_in_row: int = 0  # tasks it gave back since it last placed a component
    held_until_s: float = 0.0  # no new task before this sim time (PlannerLimits.hold_*)
    # it says it is walled in (no way to its depot) since this sim time: no new task while it is, unless no
    # other robot can take it (then it gives it back, and the give-backs bound fails the component)
    walled_in_since_s: float | None = None
    lost_wall_s: float | None = None  # its liveliness went while it held a task (lost_grace_wall_s)
    rejoined: bool = False  # back within the grace: its next state says whether it still has its task


@dataclass
class Pending:
    message: Outgoing
    settled: Callable[[], bool]
    next_send_wall_s: float | None = None  # None: send at the next step


@dataclass
class ComponentRecord:
    state: ComponentState = ComponentState.PLANNED
    attempt: int = 0
    position_xy: tuple[float, float] | None = None  # last pose, world frame (m)
    # the last pose of its frame, world frame (position m, quaternion xyzw): where a failed body lies
    pose: tuple[tuple[float, float, float], tuple[float, float, float, float]] | None = None
    last: tuple[object, ...] | None = field(default=None, repr=False)  # last state message applied
    # agent's wall clock of the newest transition applied: older news (a late twin answer) is not applied
    changed_wall_s: float = float("-inf")


def reached(component: ComponentRecord, states: Collection[ComponentState]) -> bool:
    return component.state in states


def left(component: ComponentRecord, states: Collection[ComponentState]) -> bool:
    return component.state not in states


def distance(pose_xy_yaw: tuple[float, float, float] | None, where: tuple[float, ...]) -> float:
    if pose_xy_yaw is None:
        return math.inf
    return math.hypot(pose_xy_yaw[0] - where[0], pose_xy_yaw[1] - where[1])
