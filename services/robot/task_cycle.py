"""The robot's task in hand and its state machine, each state change said on the bus at once.

Why one object: the executor's steps (:mod:`.executor`) and its physics replies and give-backs
(:mod:`.handover`) move the same task through the paper's states (:mod:`.task_machine`). Every change must
reach the bus in order, even a state that lasts less than a control step, and the periodic state must say
the same. It owns the machine, the task in hand, the finished tasks, the messages due out, and when the
state last changed (the executor's task watchdog). It also says whether the robot is walled in (no way to
its depot start): from the first give-back or parking drive that found so until it drives out again.
"""

from __future__ import annotations

import logging
import math

from bimbot.shared.messages import ClearOutcome, ComponentState, RobotState, RobotStateMsg
from bimbot.shared.reasons import Reason

from .protocol import Outgoing
from .robot_context import RobotContext
from .task_machine import TaskMachine, Trigger
from .task_state import Task

_C = ComponentState
_log = logging.getLogger(__name__)


class TaskCycle:
    """The task in hand, its state, and the messages due out (see the module doc)."""

    def __init__(self, context: RobotContext) -> None:
        self.context = context
        self.machine = TaskMachine()
        self.task: Task | None = None
        self.done: list[tuple[str, ComponentState]] = []  # (GUID, verdict) of finished tasks
        self.outbox: list[Outgoing] = []
        self.activity = ""  # what an idle robot is up to, in words, when it matters (its state message)
        self.state_since_s = 0.0  # sim time of the last task state change (the task watchdog)
        self.walled_in_since_s: float | None = None  # no way to the depot start since (its state says so)
        self.cleared: ClearOutcome | None = None  # how the last clear-away ended, said until the next task
        self._last_state: tuple[RobotState, str | None, float | None, str | None] | None = None
        self._last_state_wall_s = -math.inf

    @property
    def state(self) -> RobotState:
        return self.machine.state

    def state_message(self, wall_s: float) -> RobotStateMsg:
        task, context = self.task, self.context
        return RobotStateMsg(
            robot_id=context.robot_id,
            state=self.machine.state,
            task_id=task.message.task_id if task else None,
            guid=task.message.guid if task else None,
            pose_xy_yaw=context.navigator.pose_xy_yaw,
            sim_time_s=context.sim_s,
            wall_time_s=wall_s,
            distance_m=context.distance_m,
            activity="" if task else self.activity,
            walled_in_since_s=self.walled_in_since_s,
            cleared=self.cleared,
        )

    def start(self, task: Task) -> None:
        """``task`` is the task in hand now (the last clear-away's end has been said long enough)."""
        self.task, self.cleared = task, None

    def clear_ended(self, ok: bool, reason: Reason | None = None) -> None:
        """The clear-away in hand is over: its load lies at its yard slot (``ok``), or it is given back
        with ``reason``; the state messages say so until the next task starts, and the robot is idle."""
        task, context = self.task, self.context
        assert task is not None
        self.cleared = ClearOutcome(
            task_id=task.message.task_id,
            guid=task.message.guid,
            ok=ok,
            sim_time_s=context.sim_s,
            reason=reason,
        )
        if ok:
            self.moved_out(f"it carried {task.message.guid} out of the way")
        context.navigator.cancel()
        self.task = None
        self.fire(Trigger.HANDED_OFF if ok else Trigger.ABORTED)

    def walled_in(self, why: str) -> None:
        """The robot found no way to its depot start (``why``): its state says since when and where it
        stands, so the planner gives it no new task, until :meth:`moved_out`."""
        if self.walled_in_since_s is not None:
            return
        context = self.context
        self.walled_in_since_s = context.sim_s
        x, y = context.navigator.pose_xy_yaw[:2]
        if "beside it:" not in why:  # the run summary sends the reader here for what walls it in
            why += context.beside_words((float(x), float(y)))
        _log.warning(
            "%s: walled in at (%.2f, %.2f) since %.1f s of sim time; it takes no new task until it drives "
            "out: %s",
            context.robot_id,
            x,
            y,
            context.sim_s,
            why,
        )
        self.say_state_soon()

    def moved_out(self, how: str) -> None:
        """The robot walled in got out (``how``: it reached its depot, it built a component): its state
        says so, and it takes tasks again."""
        since_s = self.walled_in_since_s
        if since_s is None:
            return
        self.walled_in_since_s = None
        _log.info(
            "%s: no longer walled in (since %.1f s of sim time): %s", self.context.robot_id, since_s, how
        )
        self.say_state_soon()

    def fire(self, trigger: Trigger) -> None:
        """Change state and publish it at once: every state of the cycle shows on the bus, even those that
        last less than a control step (detecting a position known already)."""
        if not self.machine.fire(trigger):
            raise RuntimeError(
                f"{self.context.robot_id}: {trigger.value} is not allowed in {self.machine.state.value}"
            )
        wall_s = self.context.wall_s
        self.state_since_s = self.context.sim_s
        self.outbox.append(self.state_message(wall_s))
        self._last_state = self._signature()
        self._last_state_wall_s = wall_s

    def finish(self, verdict: ComponentState | None) -> None:
        """The task is over: a verdict (constructed, misplaced, failed), ``released`` after a hand-off, or
        None (given back or withdrawn)."""
        task = self.task
        if task is not None and verdict is not None:
            self.done.append((task.message.guid, verdict))
            self.moved_out(f"it carried {task.message.guid} to its end")
        self.context.navigator.cancel()
        self.task = None
        if verdict is _C.RELEASED:
            self.fire(Trigger.HANDED_OFF)
        else:
            self.fire(Trigger.FINISHED if verdict is not None else Trigger.ABORTED)

    def say_state_soon(self) -> None:
        """Send the state at the next poll, not at the next period."""
        self._last_state_wall_s = -math.inf

    def say_state_if_due(self, wall_s: float) -> None:
        """The state when it changed since last said, or every ``state_period_s`` of wall time."""
        signature = self._signature()
        period_s = self.context.config.state_period_s
        if signature != self._last_state or wall_s - self._last_state_wall_s >= period_s:
            self.outbox.append(self.state_message(wall_s))
            self._last_state, self._last_state_wall_s = signature, wall_s

    def _signature(self) -> tuple[RobotState, str | None, float | None, str | None]:
        """What a state message says that, changed, is said at once."""
        task = self.task
        cleared = self.cleared.task_id if self.cleared is not None else None
        return (self.machine.state, task.message.task_id if task else None, self.walled_in_since_s, cleared)

    def take_outbox(self) -> list[Outgoing]:
        out, self.outbox = self.outbox, []
        return out
