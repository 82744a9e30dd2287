"""Clearing failed bodies out of the robots' way: one carry to the yard per failed component (planner part).

Why: a component that failed for good keeps its body where it came to rest; across a doorway it cuts the
robots off from the work behind it (:mod:`.obstruction` says which bodies obstruct). Each step, every
failed component whose agent said so and whose body obstructs gets a **clear-away** (:class:`ClearRecord`):
an idle robot that can carry it (:func:`.obstruction.can_clear`; robots walled in last, the nearest first)
gets a task of kind ``clear`` (``<task id>-c``): pick it up where it lies, carry it to its yard slot, put it
down there. The component's state and reason stay failed: it is still not built. The robot says how the
task ended on its state messages (``RobotStateMsg.cleared``); the planner then announces the clear task
``done`` or ``failed`` (with why), which the report records (who, when, how long).

Bounds: at most one clear-away per failed component; one that waits for a free robot, or whose robot says
nothing of it, for ``task_timeout_s`` of sim time ends ``not cleared`` with why, and so does one no robot
on site can carry or that has no yard slot to go to. While a clear-away is open, a component whose last
give-back was ``unreachable`` is not assigned and does not fail at the give-back bound (:meth:`holds`);
once the body is cleared those components get a fresh count of give-backs.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from enum import StrEnum
from functools import partial

from bimbot.shared.messages import (
    ClearOutcome,
    ComponentState,
    PoseMsg,
    RobotState,
    RobotStateMsg,
    TaskKind,
    TaskMsg,
    TaskStatus,
)
from bimbot.shared.reasons import Reason, ReasonCode

from .capability import Where, task_estimate_s
from .obstruction import (
    Obstruction,
    ObstructionConfig,
    Pose,
    can_clear,
    drives_and_carries,
    obstruction,
    put_down_xy,
)
from .outbox import Outbox
from .planner_state import PlannerState
from .records import FINAL, Phase, RobotRecord, TaskRecord

_log = logging.getLogger(__name__)

CLEAR_KEY = "clear"  # the outbox key of a clear task's assignment
HOLDING = frozenset({ReasonCode.UNREACHABLE})  # give-backs a body in the way may explain


class ClearPhase(StrEnum):
    WAITING = "waiting"  # in the way; no robot free to take it yet
    ASSIGNED = "assigned"
    CLEARED = "cleared"
    NOT_CLEARED = "not_cleared"


@dataclass
class ClearRecord:
    """One failed body in the robots' way and its clear-away."""

    guid: str
    task_id: str
    obstruction: Obstruction
    put_down_xy: tuple[float, float] | None
    found_s: float  # sim time it was found in the way
    phase: ClearPhase = ClearPhase.WAITING
    robot_id: str | None = None
    assigned_s: float | None = None
    changed_s: float = 0.0  # the last news of its robot on it (sim s): the no-progress bound
    ended_s: float | None = None
    reason: Reason | None = None  # not cleared: why


class ClearAways:
    """The clear-aways of failed bodies (in ``records``), their tasks sent through ``outbox``."""

    def __init__(self, state: PlannerState, outbox: Outbox, config: ObstructionConfig | None = None) -> None:
        self._state = state
        self._outbox = outbox
        self._config = config or ObstructionConfig()
        self.records: dict[str, ClearRecord] = {}
        self._judged: dict[str, Pose] = {}  # failed GUID → the pose it was last judged at

    # --- what the other parts ask ------------------------------------------------------------------------

    def open(self) -> bool:
        """A clear-away waits for a robot or is under way."""
        return any(r.phase in (ClearPhase.WAITING, ClearPhase.ASSIGNED) for r in self.records.values())

    def in_flight(self) -> bool:
        """A robot works on a clear-away (the build is not over before it ends)."""
        return any(r.phase is ClearPhase.ASSIGNED for r in self.records.values())

    def holds(self, task: TaskRecord) -> bool:
        """``task`` waits for the open clear-aways: its last give-back was one a body in the way explains."""
        last = task.last_give_back
        return last is not None and last.code in HOLDING and self.open()

    # --- observations --------------------------------------------------------------------------------------

    def observe_robot(self, msg: RobotStateMsg) -> None:
        """A robot's state: news of the clear task it works on, or how one ended."""
        for record in self.records.values():
            on_it = record.robot_id == msg.robot_id and msg.task_id == record.task_id
            if record.phase is ClearPhase.ASSIGNED and on_it:
                record.changed_s = max(record.changed_s, msg.sim_time_s)
        outcome = msg.cleared
        if outcome is not None:
            self._ended(msg.robot_id, outcome)

    # --- the step ----------------------------------------------------------------------------------------

    def step(self) -> None:
        """Find failed bodies in the way, bound the open clear-aways, give the waiting ones to robots."""
        self._find()
        self._watch()
        self._assign()

    def _find(self) -> None:
        state = self._state
        for task in state.tasks_in(Phase.FAILED):
            guid = task.guid
            component = state.components[guid]
            if task.phase is not Phase.FAILED or guid in self.records or component.pose is None:
                continue
            if component.state is not ComponentState.FAILED or self._judged.get(guid) == component.pose:
                continue
            self._judged[guid] = component.pose
            slot = state.slots.get(guid)
            staging = [robot.staging for robot in (state.site or {}).values() if robot.staging is not None]
            found = obstruction(
                state.manifest[guid], component.pose, slot=slot, staging=staging, config=self._config
            )
            if found is None:
                continue
            record = ClearRecord(guid, f"{task.task_id}-c", found, put_down_xy(slot), state.sim_time_s)
            self.records[guid] = record
            x, y = found.centre_xy_m
            _log.warning(
                "%s failed and lies in the robots' way at (%.2f, %.2f) (%.1f m² its target leaves free): "
                "to be cleared away",
                state.describe(guid),
                x,
                y,
                found.area_m2,
            )
            self._refuse_at_once(record)

    def _refuse_at_once(self, record: ClearRecord) -> None:
        """No robot on site can carry it, or it has nowhere to go: not cleared, said at once."""
        state = self._state
        item = state.manifest[record.guid]
        site = state.site or {}
        if not any(can_clear(robot.description, item) for robot in site.values()):
            payloads = [r.description.payload_kg for r in site.values() if drives_and_carries(r.description)]
            most = (
                f"the largest payload of a robot that drives and carries is {max(payloads):,.0f} kg"
                if payloads
                else "no robot on site drives and carries"
            )
            code = ReasonCode.TOO_HEAVY if payloads else ReasonCode.NO_CAPABLE_ROBOT
            self._end(
                record,
                ClearPhase.NOT_CLEARED,
                Reason(
                    code=code, message=f"no robot on site can carry its {item.mass_kg:,.0f} kg away: {most}"
                ),
            )
        elif record.put_down_xy is None:
            message = "it has no yard slot to be carried back to"
            self._end(
                record, ClearPhase.NOT_CLEARED, Reason(code=ReasonCode.NO_CAPABLE_ROBOT, message=message)
            )

    def _watch(self) -> None:
        """Every wait bounded: a robot lost or silent on its clear task, no robot free for too long."""
        state = self._state
        bound_s = state.limits.task_timeout_s
        others_open = any(task.phase not in FINAL for task in state.tasks.values())
        for record in list(self.records.values()):
            robot = state.robots.get(record.robot_id or "")
            if record.phase is ClearPhase.WAITING and not others_open:
                self._end(
                    record,
                    ClearPhase.NOT_CLEARED,
                    _reason(ReasonCode.NO_PROGRESS, "nothing was left to build"),
                )
            elif record.phase is ClearPhase.WAITING and state.sim_time_s - record.found_s > bound_s:
                why = f"no robot that can carry it was free within {bound_s:.0f} s of sim time"
                self._end(record, ClearPhase.NOT_CLEARED, _reason(ReasonCode.NO_CAPABLE_ROBOT, why))
            elif record.phase is ClearPhase.ASSIGNED and (robot is None or not robot.alive):
                why = f"{record.robot_id} was lost while it carried it away"
                self._end(
                    record, ClearPhase.NOT_CLEARED, _reason(ReasonCode.NO_PROGRESS, why, record.robot_id)
                )
            elif record.phase is ClearPhase.ASSIGNED and state.sim_time_s - record.changed_s > bound_s:
                why = f"{record.robot_id} said nothing of it for {bound_s:.0f} s of sim time"
                self._end(
                    record, ClearPhase.NOT_CLEARED, _reason(ReasonCode.NO_PROGRESS, why, record.robot_id)
                )

    def _assign(self) -> None:
        state = self._state
        site = state.site
        if site is None:
            return
        for record in self.records.values():
            if record.phase is not ClearPhase.WAITING or record.put_down_xy is None:
                continue
            item = state.manifest[record.guid]
            able = [
                robot
                for robot in state.robots.values()
                if robot.robot_id in site
                and can_clear(site[robot.robot_id].description, item)
                and self._idle(robot)
            ]
            if not able:
                continue
            centre = record.obstruction.centre_xy_m
            robot = min(
                able,
                key=lambda r: (
                    r.walled_in_since_s is not None,
                    math.dist(r.pose_xy_yaw[:2], centre) if r.pose_xy_yaw is not None else math.inf,
                    r.robot_id,
                ),
            )
            self._give_to(record, robot)

    def _idle(self, robot: RobotRecord) -> bool:
        return (
            robot.alive
            and robot.state is RobotState.IDLE
            and robot.task_guid is None
            and self._state.sim_time_s >= robot.held_until_s
        )

    def _give_to(self, record: ClearRecord, robot: RobotRecord) -> None:
        state = self._state
        assert state.site is not None and record.put_down_xy is not None
        site_robot = state.site[robot.robot_id]
        xy = robot.pose_xy_yaw[:2] if robot.pose_xy_yaw is not None else site_robot.home_xy_yaw[:2]
        item = state.manifest[record.guid]
        where = Where(record.obstruction.centre_xy_m, 0.5)
        estimate_s = task_estimate_s(site_robot, xy, item, where, record.put_down_xy)
        record.phase, record.robot_id = ClearPhase.ASSIGNED, robot.robot_id
        record.assigned_s = record.changed_s = state.sim_time_s
        robot.task_guid, robot.busy_until_s = record.guid, state.sim_time_s + estimate_s
        state.revision += 1
        _log.info(
            "%s (%s, clear away to %.1f, %.1f) assigned to %s at %.1f s of sim time (estimate %.0f s)",
            record.task_id,
            record.guid,
            *record.put_down_xy,
            robot.robot_id,
            state.sim_time_s,
            estimate_s,
        )
        settled = partial(_settled, record, robot, record.task_id)
        self._outbox.send_until(record.guid, CLEAR_KEY, self._message(record, TaskStatus.ASSIGNED), settled)

    def _ended(self, robot_id: str, outcome: ClearOutcome) -> None:
        """The robot says how the clear task ended (repeated until its next task: applied once)."""
        record = self.records.get(outcome.guid)
        if record is None or record.phase is not ClearPhase.ASSIGNED:
            return
        if record.task_id != outcome.task_id or record.robot_id != robot_id:
            return
        self._state.sim_time_s = max(self._state.sim_time_s, outcome.sim_time_s)
        if outcome.ok:
            self._end(record, ClearPhase.CLEARED, None, ended_s=outcome.sim_time_s)
        else:
            why = outcome.reason or _reason(ReasonCode.NO_PROGRESS, "given back", robot_id)
            self._end(record, ClearPhase.NOT_CLEARED, why, ended_s=outcome.sim_time_s)

    def _end(
        self, record: ClearRecord, phase: ClearPhase, reason: Reason | None, *, ended_s: float | None = None
    ) -> None:
        state = self._state
        record.phase, record.reason = phase, reason
        record.ended_s = ended_s if ended_s is not None else state.sim_time_s
        robot = state.robots.get(record.robot_id or "")
        if robot is not None and robot.task_guid == record.guid:
            robot.task_guid = None
        self._outbox.withdraw(record.guid, CLEAR_KEY)
        state.revision += 1
        name = state.describe(record.guid)
        if phase is ClearPhase.CLEARED:
            took_s = record.ended_s - (record.assigned_s or record.ended_s)
            _log.info("%s cleared away by %s in %.0f s of sim time", name, record.robot_id, took_s)
            self._outbox.queue(self._message(record, TaskStatus.DONE))
            self._fresh_tries()
        else:
            assert reason is not None
            _log.warning("%s lies in the robots' way and was not cleared away: %s", name, reason.line())
            self._outbox.queue(self._message(record, TaskStatus.FAILED))

    def _fresh_tries(self) -> None:
        """The body is out of the way: what was given back unreachable starts its count again, and the
        robots that were boxed in may take tasks at once."""
        state = self._state
        for task in state.tasks.values():
            last = task.last_give_back
            if task.phase in FINAL or last is None or last.code not in HOLDING or task.give_backs == 0:
                continue
            _log.info(
                "%s: a fresh try after %d give-back(s) (%s)", task.guid, task.give_backs, last.code.value
            )
            task.give_backs = 0
            task.given_back_by.clear()
        for robot in state.robots.values():
            robot.give_backs_in_row = 0
            robot.held_until_s = min(robot.held_until_s, state.sim_time_s)

    def _message(self, record: ClearRecord, status: TaskStatus) -> TaskMsg:
        state = self._state
        item = state.manifest[record.guid]
        target = item.target_pose_world
        return TaskMsg(
            task_id=record.task_id,
            guid=record.guid,
            component_key=item.key,
            status=status,
            robot_id=record.robot_id,
            target_pose=PoseMsg(position_m=target.position_m, quat_xyzw=target.quat_xyzw),
            sim_time_s=state.sim_time_s,
            wall_time_s=state.wall_s,
            reason=record.reason if status is TaskStatus.FAILED else None,
            kind=TaskKind.CLEAR,
            put_down_xy_m=record.put_down_xy,
            method=item.method,
        )


def _settled(record: ClearRecord, robot: RobotRecord, task_id: str) -> bool:
    return record.phase is not ClearPhase.ASSIGNED or robot.reported_task_id == task_id


def _reason(code: ReasonCode, why: str, robot_id: str | None = None) -> Reason:
    return Reason(code=code, message=why, robot_id=robot_id)
