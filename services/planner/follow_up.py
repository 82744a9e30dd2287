"""Following up a component's new state (step 3 of the construction protocol).

What each state the agent reports means for the component's task: ``constructed`` → task ``done``
(successors may become ready); ``misplaced`` → event ``retry``, the task released again; ``failed`` →
task ``failed`` and what rests on it ``blocked``; ``released`` after a hand-off → the crane's task
released; ``released`` after an abandon → a give-back counted; a carrying or verifying state names the
robot at work (a restarted planner adopts it); ``planned`` again → the task waits for its release again.

Why apart: the same follow-up serves a state message and a digital-twin record (start-up sync).
"""

from __future__ import annotations

import logging
from functools import partial

from bimbot.shared.messages import ComponentEvent, ComponentState, TaskKind, TaskStatus
from bimbot.shared.reasons import Reason, ReasonCode

from .curing import CuringHolds
from .failures import Failures
from .give_backs import GiveBacks
from .outbox import Outbox
from .planner_state import PlannerState
from .records import CARRYING, FINAL, Phase, left

_log = logging.getLogger(__name__)


class FollowUp:
    """Applies component states to their tasks (in the records of ``state``); records in ``curing`` when
    each cast component was constructed."""

    def __init__(
        self,
        state: PlannerState,
        outbox: Outbox,
        curing: CuringHolds,
        failures: Failures,
        give_backs: GiveBacks,
    ) -> None:
        self._state = state
        self._outbox = outbox
        self._curing = curing
        self._failures = failures
        self._give_backs = give_backs

    def apply(
        self,
        guid: str,
        state: ComponentState,
        *,
        event: str,
        attempt: int,
        robot_id: str | None,
        sim_s: float,
        reason: Reason | None = None,
    ) -> None:
        """``guid``'s agent reports ``state`` (after ``event``, at ``sim_s``): what it means for its task."""
        records, outbox = self._state, self._outbox
        component, task = records.components[guid], records.tasks[guid]
        records.revision += 1
        if state is not component.state:
            task.changed_sim_s = max(task.changed_sim_s, sim_s)
        component.state, component.attempt = state, attempt
        if task.phase in FINAL and state is not ComponentState.CONSTRUCTED:
            return
        if state is ComponentState.CONSTRUCTED:
            self._curing.constructed(guid, sim_s)  # (a twin's is exact and earlier: the earlier is kept)
            if task.phase is not Phase.DONE:
                if task.assigned_sim_s is not None:
                    task.duration_sim_s = max(0.0, sim_s - task.assigned_sim_s)
                records.free_robot(task)
                outbox.set_phase(task, Phase.DONE, TaskStatus.DONE)
                _log.info("%s constructed", guid)
        elif state is ComponentState.FAILED:
            if task.phase is not Phase.FAILED:
                records.free_robot(task)
                task.reason = reason or Reason(
                    code=ReasonCode.MISPLACED, message=f"failed after {attempt} attempt(s)"
                )
                outbox.set_phase(task, Phase.FAILED, TaskStatus.FAILED)
                _log.warning("%s failed: %s; blocking what depends on it", guid, task.reason.line())
                self._failures.block_dependents(guid)
        elif state is ComponentState.BLOCKED:
            records.free_robot(task)
            task.reason = reason or task.reason
            outbox.set_phase(task, Phase.BLOCKED, TaskStatus.BLOCKED)
        elif state is ComponentState.MISPLACED:
            records.free_robot(task)
            if task.phase is not Phase.RELEASED:
                outbox.set_phase(task, Phase.RELEASED, TaskStatus.RELEASED)
            settled = partial(left, component, {ComponentState.MISPLACED})
            outbox.send_event(guid, ComponentEvent.RETRY, settled)
        elif state is ComponentState.RELEASED and event == ComponentEvent.HAND_OFF:
            if task.phase is Phase.ASSIGNED:  # (a restarted planner adopted it as a build: the same end)
                by = task.robot_id
                _log.info("%s: %s put down at the crane's staging spot by %s", task.active_id, guid, by)
                if task.kind is TaskKind.HAND_OFF:
                    outbox.send_task(task, TaskStatus.DONE)
                records.free_robot(task)
                if task.put_down_xy is not None:  # until physics' pose of it arrives: the crane bids on it
                    component.position_xy = task.put_down_xy
                task.kind, task.put_down_xy = TaskKind.BUILD, None
                outbox.set_phase(task, Phase.RELEASED, TaskStatus.RELEASED)
        elif state is ComponentState.RELEASED:
            abandoned = task.phase in (Phase.ASSIGNED, Phase.RELEASED) and event == ComponentEvent.ABANDON
            if abandoned:
                giver = robot_id or (reason.robot_id if reason is not None else None)
                if giver is not None:  # the agent's released state names no robot; the robot's reason does
                    task.given_back_by.add(giver)
                    task.given_back_s = records.sim_time_s
                    self._give_backs.robot_gave_back(giver)
                given_back = reason or Reason(code=ReasonCode.NO_PROGRESS, message="given back")
                self._give_backs.count(task, given_back)
                if task.phase in FINAL:
                    return
            if task.phase is Phase.WAITING or abandoned:
                records.free_robot(task)
                outbox.set_phase(task, Phase.RELEASED, TaskStatus.RELEASED)
        elif state in CARRYING or state is ComponentState.VERIFYING:
            if task.phase is not Phase.ASSIGNED and robot_id is not None:
                task.robot_id = robot_id  # adopted (start-up sync, or a robot that acted on its own)
                robot = records.robot(robot_id)
                robot.task_guid = guid
                task.phase = Phase.ASSIGNED
                records.revision += 1
                if records.synced and not robot.alive:
                    self._give_backs.give_back(guid, f"robot {robot_id} is not alive")
            if state is ComponentState.VERIFYING:
                placer = records.robots.get(task.robot_id or "")
                if placer is not None:  # it placed one: not boxed in
                    placer.give_backs_in_row = 0
                records.free_robot(task, keep_task_robot=True)
        elif state is ComponentState.PLANNED and task.phase in (Phase.RELEASED, Phase.ASSIGNED):
            records.free_robot(task)  # the agent lost its state: release again when ready
            task.phase = Phase.WAITING
            records.revision += 1
