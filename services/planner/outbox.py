"""What the planner sends: a task message for every phase change, events and assignments until they land.

Why apart: every part of the planner that changes a task's phase or tells a component something goes
through here, so the messages and their delivery rules live in one place. Delivery is at least once:
a component event or an assignment is re-sent unchanged (same ``event_id``) every ``resend_s`` wall
seconds until its effect is observed (its ``settled`` check); a task message of a phase change is sent
once, at the next step.
"""

from __future__ import annotations

import logging
import uuid
from collections.abc import Callable

from bimbot.shared.messages import ComponentEvent, ComponentEventMsg, PoseMsg, TaskKind, TaskMsg, TaskStatus
from bimbot.shared.reasons import Reason

from .planner_state import PlannerState
from .records import SOURCE, Outgoing, Pending, Phase, TaskRecord

_log = logging.getLogger(__name__)


class Outbox:
    """The messages of the next step (owns the queued task messages and the pending events/assignments,
    keyed ``(guid, "event")``, ``(guid, "task")`` and ``(guid, "clear")``); reads the records and clocks
    of ``state``."""

    def __init__(
        self,
        state: PlannerState,
        *,
        resend_s: float = 2.0,
        new_id: Callable[[], str] = lambda: uuid.uuid4().hex,
    ) -> None:
        self._state = state
        self._resend_s = resend_s
        self._new_id = new_id
        self._queued: list[Outgoing] = []
        self._pending: dict[tuple[str, str], Pending] = {}

    def set_phase(self, task: TaskRecord, phase: Phase, status: TaskStatus) -> None:
        """Move ``task`` to ``phase`` and announce it as ``status`` (a hand-off task ends here too)."""
        task.phase = phase
        self._state.revision += 1
        if task.kind is TaskKind.HAND_OFF and phase is not Phase.ASSIGNED:
            self._queued.append(self.task_msg(task, status))  # the hand-off task ends here too
            task.kind, task.put_down_xy = TaskKind.BUILD, None
        self._queued.append(self.task_msg(task, status))

    def send_task(self, task: TaskRecord, status: TaskStatus) -> None:
        """Announce ``task`` as ``status`` once, without a phase change."""
        self._queued.append(self.task_msg(task, status))

    def send_event(
        self,
        guid: str,
        event: ComponentEvent,
        settled: Callable[[], bool],
        robot_id: str | None = None,
        *,
        reason: Reason | None = None,
    ) -> None:
        """Tell ``guid``'s agent ``event`` until ``settled()``; the same event still on its way is kept."""
        current = self._pending.get((guid, "event"))
        if (
            current is not None
            and isinstance(current.message, ComponentEventMsg)  # what an "event" key always holds
            and current.message.event is event
            and not current.settled()
        ):
            return  # already on its way (same event_id on every resend)
        task = self._state.tasks[guid]
        message = ComponentEventMsg(
            guid=guid,
            event=event,
            source=SOURCE,
            event_id=self._new_id(),
            task_id=task.task_id,
            robot_id=robot_id,
            sim_time_s=self._state.sim_time_s,
            wall_time_s=self._state.wall_s,
            reason=reason,
        )
        self._pending[(guid, "event")] = Pending(message, settled)

    def send_assignment(self, task: TaskRecord, settled: Callable[[], bool]) -> None:
        """Send ``task`` as assigned to its robot until ``settled()``."""
        self._pending[(task.guid, "task")] = Pending(self.task_msg(task, TaskStatus.ASSIGNED), settled)

    def send_until(self, guid: str, key: str, message: TaskMsg, settled: Callable[[], bool]) -> None:
        """Send ``message`` (a task of another kind than ``guid``'s own, keyed ``key``) until
        ``settled()``."""
        self._pending[(guid, key)] = Pending(message, settled)

    def queue(self, message: TaskMsg) -> None:
        """Send ``message`` once, at the next step."""
        self._queued.append(message)

    def withdraw(self, guid: str, key: str) -> None:
        """Stop sending ``guid``'s pending ``key`` ("event" or "task"), if any."""
        self._pending.pop((guid, key), None)

    def unsettled(self) -> bool:
        """Whether an event or assignment is still waiting for its effect."""
        return any(not pending.settled() for pending in self._pending.values())

    def due(self, wall_time_s: float) -> list[Outgoing]:
        """The queued task messages, then every pending message due at ``wall_time_s`` (settled ones are
        dropped)."""
        out, self._queued = self._queued, []
        for pending_key, pending in list(self._pending.items()):
            if pending.settled():
                del self._pending[pending_key]
            elif pending.next_send_wall_s is None or wall_time_s >= pending.next_send_wall_s:
                if pending.next_send_wall_s is not None:
                    _log.debug("re-sending %s for %s", type(pending.message).__name__, pending_key[0])
                pending.next_send_wall_s = wall_time_s + self._resend_s
                out.append(pending.message)
        return out

    def task_msg(self, task: TaskRecord, status: TaskStatus) -> TaskMsg:
        """``task`` as a task message with ``status`` (its robot only when assigned, its reason only when
        failed or blocked)."""
        component = self._state.manifest[task.guid]
        pose = component.target_pose_world
        return TaskMsg(
            task_id=task.active_id,
            guid=task.guid,
            component_key=component.key,
            status=status,
            robot_id=task.robot_id if status is TaskStatus.ASSIGNED else None,
            attempt=self._state.components[task.guid].attempt,
            target_pose=PoseMsg(position_m=pose.position_m, quat_xyzw=pose.quat_xyzw),
            sim_time_s=self._state.sim_time_s,
            wall_time_s=self._state.wall_s,
            reason=task.reason if status in (TaskStatus.FAILED, TaskStatus.BLOCKED) else None,
            kind=task.kind,
            put_down_xy_m=task.put_down_xy,
            method=component.method,
        )
