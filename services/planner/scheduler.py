"""The planner's pure core: a ready set over the precedence DAG, robot assignment, follow-up, progress.

:class:`PlannerCore` holds no bus, no files and no clock of its own. The adapter feeds it what it observes
(component states and poses, robot states and liveliness, the sim clock, digital-twin records at start) and
calls :meth:`PlannerCore.step` with the wall time; ``step`` returns the messages to publish
(:class:`ComponentEventMsg`, :class:`TaskMsg`) as values. It implements the construction protocol of
``docs/architecture.md``:

1. **Release** every task whose predecessors are all constructed — the whole ready set at once, in plan
   priority order: event ``release`` and task ``released``. A predecessor cast in place must also have
   cured: it holds what follows it for its ``cast.cure_s`` of sim time after it became constructed
   (:mod:`.curing`; the holds are in the progress, ``curing``).
2. **Assign** a released task once its component reports ``released``, to the nearest alive, idle robot
   (robot ``pose_xy_yaw`` against the component's last pose, else its BIM target): task ``assigned``. A
   robot is idle when it last reported ``idle`` and holds no task of the planner's.
3. **Follow up**: ``constructed`` → task ``done`` (successors may become ready); ``misplaced`` → event
   ``retry``, the task is released and assigned again (maybe to the same robot); ``failed`` → task ``failed``
   and every transitive dependent ``blocked`` (never released) while independent work goes on. A robot that
   reports ``verifying`` for its component has done its part and is free again.
4. **Robot lost** (liveliness gone): its task is given back — event ``abandon`` when the component is being
   carried (picking/transporting/assembling), then released and reassigned — once the robot has been gone
   ``lost_grace_wall_s`` (a router restart cuts a live robot off for seconds), or at once when it comes
   back without the task (it restarted).
5. **Bounds** (:class:`PlannerLimits`): a component given back ``max_give_backs`` times, by any robots, is
   failed with the last give-back's reason (the robot's own: ``no_approach_pose``, ``unreachable``,
   ``robot_trapped``…); a task whose component has not changed state for ``task_timeout_s`` sim seconds is
   taken back from its robot (``no_progress``, counted as a give-back); one worked on in place (forming,
   pouring, laying) gets the expected duration of its work on top (:func:`.work_in_place.work_s`).
   Components no robot type on site can
   build are failed before anything is released (:meth:`PlannerCore.fail_at_start`). What rests on a failed
   component (transitively, in the support graph) is ``blocked`` (event ``block`` with a ``blocked_by``
   reason naming it); a component that only follows it in the schedule goes on: for the release, a failed
   or blocked predecessor it does not rest on counts as done (a too-heavy footing on one side of the site
   does not stop the walls on the other). Every failed or blocked component's reason travels on its task
   and in the progress (``reasons``).

A site where nothing can happen before a known sim time (curing, timed work) says until when:
:meth:`PlannerCore.quiet_until` (:mod:`.quiet`), which the adapter sends to physics as a skip request.

Delivery is at least once: each event and each ``assigned`` task is re-sent unchanged (same ``event_id``)
every ``resend_s`` wall seconds until its effect is observed (the component leaves ``planned`` after a
release, ``misplaced`` after a retry, the carrying states after an abandon; the robot reports the task or
the component leaves ``released`` after an assignment).
"""

from __future__ import annotations

import logging
import uuid
from collections.abc import Callable
from functools import partial

from bimbot.shared.footprint import body_centre_xy
from bimbot.shared.identifiers import named_guid
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import (
    ComponentEvent,
    ComponentEventMsg,
    ComponentPoseMsg,
    ComponentState,
    ComponentStateMsg,
    CuringHold,
    PoseMsg,
    ProgressMsg,
    RobotStateMsg,
    TaskKind,
    TaskMsg,
    TaskStatus,
    TwinMsg,
)
from bimbot.shared.reasons import Reason, ReasonCode, blocked_by

from .capability import SiteRobot, relocation_to_s
from .curing import CuringHolds, Hold, constructed_time_s
from .dispatch import Dispatch
from .quiet import Quiet, Skip
from .records import (
    CARRYING,
    FINAL,
    SOURCE,
    TERMINAL,
    WORKING,
    ComponentRecord,
    Outgoing,
    Pending,
    Phase,
    PlannerLimits,
    RobotRecord,
    TaskRecord,
    left,
    reached,
)
from .sources import Plan
from .work_in_place import cure_s, work_s

__all__ = ["Outgoing", "Phase", "PlannerCore", "PlannerLimits", "Skip"]

_log = logging.getLogger(__name__)


class PlannerCore(Dispatch, Quiet):
    """The planner's state and decisions (see the module docstring); no bus, no files, no clock."""

    def __init__(
        self,
        manifest: Manifest,
        plan: Plan,
        *,
        resend_s: float = 2.0,
        new_id: Callable[[], str] = lambda: uuid.uuid4().hex,
        limits: PlannerLimits | None = None,
        robots: list[SiteRobot] | None = None,
        slots: dict | None = None,
    ) -> None:
        """``robots``: the robots on site with their types (:func:`.capability.site_robots`); with them a
        task goes to the capable robot with the best bid (:mod:`.assignment`), without them to the nearest
        idle robot. ``slots``: the yard slots of the site plan (where a component lies before any pose)."""
        self._manifest = {item.guid: item for item in manifest.components}
        self._site = {robot.robot_id: robot for robot in robots} if robots is not None else None
        self._slots = slots or {}
        self._plan = plan
        self._resend_s = resend_s
        self.limits = limits or PlannerLimits()
        self._new_id = new_id
        self._dependents = plan.dependents()
        self._tasks = {
            guid: TaskRecord(guid, plan.task_ids[guid], priority) for priority, guid in enumerate(plan.order)
        }
        self._components = {guid: ComponentRecord() for guid in plan.order}
        self._curing = CuringHolds(
            {guid: cure_s(item) for guid, item in self._manifest.items() if cure_s(item) > 0}
        )
        self._held: dict[str, Hold] = {}  # GUID → the curing that holds its release (the last release pass)
        self._next_cure_s: float | None = None  # the earliest end of a hold: the release pass runs again then
        self._robots: dict[str, RobotRecord] = {}
        self._pending: dict[tuple[str, str], Pending] = {}
        self._outbox: list[Outgoing] = []
        self._wall_s = 0.0
        self._synced = False
        self.sim_time_s = 0.0
        # Bumped by every change of a component's state or a task's phase: the per-loop passes over every
        # task (release, the watchdog, progress) run again only when something they read has changed (on
        # a 988-component site they were a fifth of a core, taken from the robots and physics).
        self.revision = 1
        self._released_revision = 0
        self._watched: tuple[int, float] | None = None  # (revision, sim time) of the watchdog's last pass

    # --- observations ----------------------------------------------------------------------------------

    def observe_clock(self, sim_time_s: float) -> None:
        self.sim_time_s = max(self.sim_time_s, sim_time_s)

    def observe_component_state(self, msg: ComponentStateMsg) -> None:
        component = self._components.get(msg.guid)
        if component is None:
            _log.debug("state of %s, which is not in the plan", msg.guid)
            return
        signature = (msg.state, msg.previous, msg.event, msg.attempt, msg.robot_id, msg.sim_time_s)
        if signature == component.last:
            return  # a repeated delivery
        if msg.wall_time_s < component.changed_wall_s:
            _log.debug("%s: %s is older than the state applied; not applied", msg.guid, msg.state)
            return
        component.last, component.changed_wall_s = signature, msg.wall_time_s
        self.observe_clock(msg.sim_time_s)
        self._apply_state(
            msg.guid,
            msg.state,
            event=msg.event,
            attempt=msg.attempt,
            robot_id=msg.robot_id,
            sim_s=msg.sim_time_s,
            reason=msg.reason,
        )

    def observe_twin(self, twin: TwinMsg) -> None:
        """A component's digital-twin record (start-up sync: agents may already be further on; in flight, a
        message that went missing). An answer is not applied when its last transition is older than, or the
        same as, one already applied: it can arrive after the state messages of later transitions."""
        component = self._components.get(twin.guid)
        if component is None:
            return
        constructed_s = constructed_time_s(twin) if twin.state is ComponentState.CONSTRUCTED else None
        if constructed_s is not None:  # the exact time, from its history: a restarted planner's curing holds
            self._curing.constructed(twin.guid, constructed_s)
        newest = twin.history[-1] if twin.history else None
        if newest is not None and (
            newest.wall_time_s < component.changed_wall_s
            or (newest.wall_time_s == component.changed_wall_s and twin.state is component.state)
        ):
            _log.debug("%s: twin answer (%s) is not newer than the state applied", twin.guid, twin.state)
            return
        if newest is not None:
            component.changed_wall_s = newest.wall_time_s
        if twin.current_pose is not None:
            pose = twin.current_pose
            component.position_xy = body_centre_xy(self._manifest[twin.guid], pose.position_m, pose.quat_xyzw)
        event = twin.history[-1].event if twin.history else "sync"
        self._apply_state(
            twin.guid,
            twin.state,
            event=event,
            attempt=twin.attempt,
            robot_id=twin.robot_id,
            sim_s=self.sim_time_s,
            reason=twin.reason,
        )

    def observe_component_pose(self, msg: ComponentPoseMsg) -> None:
        component = self._components.get(msg.guid)
        if component is not None:  # where its body lies (its frame's origin may be 100 m away)
            pose = msg.pose
            component.position_xy = body_centre_xy(self._manifest[msg.guid], pose.position_m, pose.quat_xyzw)
            self.observe_clock(msg.sim_time_s)

    def observe_robot_state(self, msg: RobotStateMsg) -> None:
        robot = self._robots.setdefault(msg.robot_id, RobotRecord(msg.robot_id))
        robot.state = msg.state
        robot.reported_task_id = msg.task_id
        if robot.rejoined and robot.alive:
            robot.rejoined = False
            task = self._tasks.get(robot.task_guid) if robot.task_guid is not None else None
            if task is not None and task.phase is Phase.ASSIGNED and msg.task_id != task.active_id:
                self._give_back(task.guid, f"robot {msg.robot_id} came back without its task (restarted)")
        robot.pose_xy_yaw = msg.pose_xy_yaw
        robot.reported_busy_until_s = msg.busy_until_s
        self.observe_clock(msg.sim_time_s)

    def robot_liveliness(self, robot_id: str, alive: bool) -> None:
        """A robot's liveliness token appeared (``alive``) or disappeared (its task is given back)."""
        robot = self._robots.setdefault(robot_id, RobotRecord(robot_id))
        if robot.alive == alive:
            return
        robot.alive = alive
        _log.info("robot %s %s", robot_id, "alive" if alive else "lost")
        if alive:
            if robot.lost_wall_s is not None:  # back within the grace: does it still have its task?
                robot.lost_wall_s, robot.rejoined = None, True
            return
        robot.state = None  # a robot that comes back must announce itself idle again
        if robot.task_guid is not None:
            robot.lost_wall_s = self._wall_s  # given back after the grace (_give_back_lost)

    def fail_at_start(self, reasons: dict[str, Reason]) -> None:
        """Fail, before anything is released, the components no robot on site can build (and block their
        dependents); components already terminal (a restarted planner) are left as they are."""
        failing = [
            guid for guid in self._plan.order if guid in reasons and self._tasks[guid].phase not in FINAL
        ]
        for guid in failing:  # every one with its own reason first: a heavy wall on a heavy slab is too heavy
            _log.warning("%s cannot be built: %s", guid, reasons[guid].line())
            self._fail(guid, reasons[guid], block=False)
        for guid in failing:
            self._block_dependents(guid)

    def finish_sync(self) -> None:
        """Start-up sync is over: tasks held by robots that are not alive are given back."""
        self._synced = True
        for task in self._tasks.values():
            robot = self._robots.get(task.robot_id) if task.robot_id else None
            if task.phase is Phase.ASSIGNED and robot is not None and not robot.alive:
                self._give_back(task.guid, f"robot {task.robot_id} is not alive")

    # --- decisions -------------------------------------------------------------------------------------

    def step(self, wall_time_s: float) -> list[Outgoing]:
        """Release the ready set, assign idle robots, (re)send what is due; the messages to publish."""
        self._wall_s = wall_time_s
        self._give_back_lost()
        self._watch_tasks()
        self._release_ready()
        self._assign()
        out, self._outbox = self._outbox, []
        for pending_key, pending in list(self._pending.items()):
            if pending.settled():
                del self._pending[pending_key]
            elif pending.next_send_wall_s is None or wall_time_s >= pending.next_send_wall_s:
                if pending.next_send_wall_s is not None:
                    _log.debug("re-sending %s for %s", type(pending.message).__name__, pending_key[0])
                pending.next_send_wall_s = wall_time_s + self._resend_s
                out.append(pending.message)
        return out

    @property
    def done(self) -> bool:
        return all(task.phase in FINAL for task in self._tasks.values())

    def confirmed(self) -> bool:
        """Whether every component's agent said it is terminal (constructed, failed, blocked): a planner
        that decided everything at once must not end before the agents took what it sent."""
        return all(component.state in TERMINAL for component in self._components.values())

    def phase(self, guid: str) -> Phase:
        return self._tasks[guid].phase

    def in_flight(self) -> list[str]:
        """Components released or worked on: a state message of theirs that went missing would hold the
        build up, so the adapter asks their twins now and then."""
        return [
            guid for guid in self._plan.order if self._tasks[guid].phase in (Phase.RELEASED, Phase.ASSIGNED)
        ]

    def robot_of(self, guid: str) -> str | None:
        return self._tasks[guid].robot_id

    def failed(self) -> list[str]:
        return [guid for guid in self._plan.order if self._tasks[guid].phase is Phase.FAILED]

    def blocked(self) -> list[str]:
        return [guid for guid in self._plan.order if self._tasks[guid].phase is Phase.BLOCKED]

    def alive_robots(self) -> list[str]:
        return sorted(robot.robot_id for robot in self._robots.values() if robot.alive)

    def progress(self) -> ProgressMsg:
        """Counts by component state, percent constructed, estimated sim time of the finish."""
        counts = {state.value: 0 for state in ComponentState}
        for component in self._components.values():
            counts[component.state.value] += 1
        total = len(self._tasks)
        durations = [task.duration_sim_s for task in self._tasks.values() if task.duration_sim_s is not None]
        remaining = sum(1 for task in self._tasks.values() if task.phase not in FINAL)
        estimate = None
        if remaining == 0:
            estimate = self.sim_time_s
        elif durations:
            mean_s = sum(durations) / len(durations)
            estimate = self.sim_time_s + mean_s * remaining / max(1, len(self.alive_robots()))
        return ProgressMsg(
            total=total,
            counts=counts,
            percent_constructed=100.0 * counts[ComponentState.CONSTRUCTED.value] / total if total else 100.0,
            sim_time_s=self.sim_time_s,
            estimated_finish_sim_time_s=estimate,
            failed=self.failed(),
            blocked=self.blocked(),
            reasons=self.reasons(),
            done=self.done,
            curing=[
                CuringHold(guid=hold.guid, cast_guid=hold.cast_guid, until_s=hold.until_s)
                for hold in self.curing_holds()
            ],
        )

    def curing_holds(self) -> list[Hold]:
        """What is ready but for the curing of a cast predecessor, soonest first."""
        holds = [hold for guid, hold in self._held.items() if self._tasks[guid].phase is Phase.WAITING]
        return sorted(holds, key=lambda hold: (hold.until_s, self._tasks[hold.guid].priority))

    def reasons(self) -> dict[str, Reason]:
        """GUID → why, for every failed and blocked component."""
        return {
            guid: task.reason
            for guid, task in self._tasks.items()
            if task.phase in (Phase.FAILED, Phase.BLOCKED) and task.reason is not None
        }

    def reason_of(self, guid: str) -> Reason | None:
        return self._tasks[guid].reason

    # --- internals -------------------------------------------------------------------------------------

    def _apply_state(
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
        component, task = self._components[guid], self._tasks[guid]
        self.revision += 1
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
                self._free_robot(task)
                self._set_phase(task, Phase.DONE, TaskStatus.DONE)
                _log.info("%s constructed", guid)
        elif state is ComponentState.FAILED:
            if task.phase is not Phase.FAILED:
                self._free_robot(task)
                task.reason = reason or Reason(
                    code=ReasonCode.MISPLACED, message=f"failed after {attempt} attempt(s)"
                )
                self._set_phase(task, Phase.FAILED, TaskStatus.FAILED)
                _log.warning("%s failed: %s; blocking what depends on it", guid, task.reason.line())
                self._block_dependents(guid)
        elif state is ComponentState.BLOCKED:
            self._free_robot(task)
            task.reason = reason or task.reason
            self._set_phase(task, Phase.BLOCKED, TaskStatus.BLOCKED)
        elif state is ComponentState.MISPLACED:
            self._free_robot(task)
            if task.phase is not Phase.RELEASED:
                self._set_phase(task, Phase.RELEASED, TaskStatus.RELEASED)
            settled = partial(left, component, {ComponentState.MISPLACED})
            self._send_event(guid, ComponentEvent.RETRY, settled)
        elif state is ComponentState.RELEASED and event == ComponentEvent.HAND_OFF:
            if task.phase is Phase.ASSIGNED:  # (a restarted planner adopted it as a build: the same end)
                by = task.robot_id
                _log.info("%s: %s put down at the crane's staging spot by %s", task.active_id, guid, by)
                if task.kind is TaskKind.HAND_OFF:
                    self._outbox.append(self._task_msg(task, TaskStatus.DONE))
                self._free_robot(task)
                if task.put_down_xy is not None:  # until physics' pose of it arrives: the crane bids on it
                    component.position_xy = task.put_down_xy
                task.kind, task.put_down_xy = TaskKind.BUILD, None
                self._set_phase(task, Phase.RELEASED, TaskStatus.RELEASED)
        elif state is ComponentState.RELEASED:
            abandoned = task.phase in (Phase.ASSIGNED, Phase.RELEASED) and event == ComponentEvent.ABANDON
            if abandoned:
                giver = robot_id or (reason.robot_id if reason is not None else None)
                if giver is not None:  # the agent's released state names no robot; the robot's reason does
                    task.given_back_by.add(giver)
                    self._robot_gave_back(giver)
                self._count_give_back(
                    task, reason or Reason(code=ReasonCode.NO_PROGRESS, message="given back")
                )
                if task.phase in FINAL:
                    return
            if task.phase is Phase.WAITING or abandoned:
                self._free_robot(task)
                self._set_phase(task, Phase.RELEASED, TaskStatus.RELEASED)
        elif state in CARRYING or state is ComponentState.VERIFYING:
            if task.phase is not Phase.ASSIGNED and robot_id is not None:
                task.robot_id = robot_id  # adopted (start-up sync, or a robot that acted on its own)
                robot = self._robots.setdefault(robot_id, RobotRecord(robot_id))
                robot.task_guid = guid
                task.phase = Phase.ASSIGNED
                self.revision += 1
                if self._synced and not robot.alive:
                    self._give_back(guid, f"robot {robot_id} is not alive")
            if state is ComponentState.VERIFYING:
                placer = self._robots.get(task.robot_id or "")
                if placer is not None:  # it placed one: not boxed in
                    placer.give_backs_in_row = 0
                self._free_robot(task, keep_task_robot=True)
        elif state is ComponentState.PLANNED and task.phase in (Phase.RELEASED, Phase.ASSIGNED):
            self._free_robot(task)  # the agent lost its state: release again when ready
            task.phase = Phase.WAITING
            self.revision += 1

    def _release_ready(self) -> None:
        cured = self._next_cure_s is not None and self.sim_time_s >= self._next_cure_s
        if self._released_revision == self.revision and not cured:
            return  # nothing changed that could make a task ready
        self._released_revision = self.revision
        settled: dict[str, bool] = {}
        held: dict[str, Hold] = {}
        for guid in self._plan.order:
            task = self._tasks[guid]
            if task.phase is not Phase.WAITING:
                continue
            preds = self._plan.predecessors.get(guid, frozenset())
            if all(self._settled_for_release(pred, settled) for pred in preds):
                hold = self._curing.holding(guid, preds, self.sim_time_s)
                if hold is not None:
                    held[guid] = hold
                    continue
                if guid in self._held:
                    _log.info("%s released: %s has cured", guid, self._describe(self._held[guid].cast_guid))
                component = self._components[guid]
                self._set_phase(task, Phase.RELEASED, TaskStatus.RELEASED)
                if component.state is ComponentState.PLANNED:
                    is_released = partial(left, component, {ComponentState.PLANNED})
                    self._send_event(guid, ComponentEvent.RELEASE, is_released)
        for guid, hold in held.items():
            if guid not in self._held:
                _log.info(
                    "%s waits for the curing of %s until %.0f s of sim time (now %.0f s)",
                    self._describe(guid),
                    self._describe(hold.cast_guid),
                    hold.until_s,
                    self.sim_time_s,
                )
        self._held = held
        self._next_cure_s = min((hold.until_s for hold in held.values()), default=None)

    def _settled_for_release(self, pred: str, memo: dict[str, bool]) -> bool:
        """A predecessor is out of the way: constructed, or not built at all and its own predecessors out
        of the way (in a schedule that is one chain, what follows a failed component waits for what came
        before it, not for nothing: a beam after a blocked column waited for no column at all and was
        placed on one that was still being set up)."""
        known = memo.get(pred)
        if known is not None:
            return known
        memo[pred] = False  # a cycle (there is none in a plan) stays unsettled
        if self._components[pred].state is ComponentState.CONSTRUCTED:
            memo[pred] = True
        elif self._tasks[pred].phase in (Phase.FAILED, Phase.BLOCKED):
            before = self._plan.predecessors.get(pred, frozenset())
            memo[pred] = all(self._settled_for_release(item, memo) for item in before)
        return memo[pred]

    def _free_robot(self, task: TaskRecord, *, keep_task_robot: bool = False) -> None:
        if task.robot_id is not None:
            robot = self._robots.get(task.robot_id)
            if robot is not None and robot.task_guid == task.guid:
                robot.task_guid = None
        if not keep_task_robot:
            task.robot_id = None

    def _give_back(self, guid: str, why: str, reason: Reason | None = None) -> None:
        """Take a task back from its robot (lost, or no progress); ``reason`` counts it as a give-back."""
        task, component = self._tasks[guid], self._components[guid]
        if task.phase is not Phase.ASSIGNED:
            return
        robot_id = task.robot_id
        self._free_robot(task)
        if component.state is ComponentState.VERIFYING:
            return  # placed already: verification decides
        _log.warning("%s (%s) given back: %s", task.active_id, guid, why)
        self._set_phase(task, Phase.RELEASED, TaskStatus.RELEASED)
        task.changed_sim_s = self.sim_time_s
        if component.state in CARRYING:
            # counted when the agent reports the abandon (released, event abandon)
            self._send_event(
                guid, ComponentEvent.ABANDON, partial(left, component, CARRYING), robot_id, reason=reason
            )
        elif reason is not None:
            self._count_give_back(task, reason)

    def _robot_gave_back(self, robot_id: str) -> None:
        """One more task given back by ``robot_id`` in a row; from ``hold_after_give_backs`` on it gets no
        new task for a while (:class:`PlannerLimits`), and what it gave back goes to the others."""
        robot = self._robots.get(robot_id)
        if robot is None:
            return
        robot.give_backs_in_row += 1
        beyond = robot.give_backs_in_row - self.limits.hold_after_give_backs
        if beyond < 0:
            return
        hold_s = min(self.limits.hold_s * 2.0**beyond, self.limits.hold_max_s)
        robot.held_until_s = self.sim_time_s + hold_s
        _log.warning(
            "%s gave back %d tasks in a row: no new task for it for %.0f s of sim time",
            robot_id,
            robot.give_backs_in_row,
            hold_s,
        )

    def _count_give_back(self, task: TaskRecord, reason: Reason) -> None:
        """One more give-back of ``task``'s component; at the bound it fails with the last reason."""
        task.give_backs += 1
        task.last_give_back = reason
        limit = self.limits.max_give_backs
        _log.warning("%s given back (%d of %d): %s", task.guid, task.give_backs, limit, reason.line())
        if task.give_backs >= limit:
            message = f"given back {task.give_backs} times; last: {reason.message}"
            self._fail(task.guid, reason.model_copy(update={"message": message[:2000]}))

    def _give_back_lost(self) -> None:
        """The tasks of robots gone for ``lost_grace_wall_s`` are given back."""
        for robot in self._robots.values():
            lost = robot.lost_wall_s
            if lost is None or robot.alive or self._wall_s - lost < self.limits.lost_grace_wall_s:
                continue
            robot.lost_wall_s = None
            if robot.task_guid is not None:
                self._give_back(robot.task_guid, f"robot {robot.robot_id} lost")

    def _watch_tasks(self) -> None:
        """The no-progress watchdog: an assigned task whose component has not changed state for
        ``task_timeout_s`` sim seconds is taken back from its robot."""
        if self._watched == (self.revision, self.sim_time_s):
            return  # no sim time passed and nothing changed since the last pass
        self._watched = (self.revision, self.sim_time_s)
        for task in self._tasks.values():
            state = self._components[task.guid].state
            if task.phase is not Phase.ASSIGNED or state is ComponentState.VERIFYING:
                continue
            idle_s = self.sim_time_s - task.changed_sim_s
            bound = self._task_bound_s(task)
            if idle_s > bound:
                work = bound - self.limits.task_timeout_s
                of_work = f" with {work:.0f} s of work in place" if work > 0 else ""
                reason = Reason(
                    code=ReasonCode.NO_PROGRESS,
                    message=(
                        f"{task.active_id} made no progress for {idle_s:.0f} s of sim time "
                        f"(bound {bound:.0f} s{of_work}; component {state.value}, robot {task.robot_id})"
                    ),
                    robot_id=task.robot_id,
                )
                self._give_back(task.guid, reason.message, reason)

    def _task_bound_s(self, task: TaskRecord) -> float:
        """How long an assigned task may go without a state change of its component (sim s): the fixed
        bound, plus the expected duration of its work while it is worked on in place (and for a machine
        that relocates before it works, its longest relocation to where it works on it)."""
        bound = self.limits.task_timeout_s
        if self._components[task.guid].state in WORKING:
            robot = self._site.get(task.robot_id or "") if self._site is not None else None
            bound += work_s(self._manifest[task.guid], robot.description if robot is not None else None)
            if robot is not None and robot.description.relocates:  # it may relocate first: from anywhere
                component = self._manifest[task.guid]
                bound += max(relocation_to_s(robot, pose[:2], component) for pose in robot.set_up_at)
        return bound

    def _fail(self, guid: str, reason: Reason, *, block: bool = True) -> None:
        """The component cannot be built: event ``fail`` with ``reason``; its dependents are blocked."""
        task, component = self._tasks[guid], self._components[guid]
        if task.phase in FINAL:
            return
        self._free_robot(task)
        task.reason = reason
        self._set_phase(task, Phase.FAILED, TaskStatus.FAILED)
        _log.error("%s failed: %s", guid, reason.line())
        self._send_event(guid, ComponentEvent.FAIL, partial(reached, component, TERMINAL), reason=reason)
        if block:
            self._block_dependents(guid)

    def _block_dependents(self, guid: str) -> None:
        """Block what rests on ``guid`` (transitively); each reason names the failed component and, when
        it rests on it only through others, the one it stands on directly."""
        root_reason = self._tasks[guid].reason
        stack = [(item, guid) for item in self._dependents.get(guid, ())]
        while stack:
            item, parent = stack.pop()
            task = self._tasks[item]
            if task.phase in (Phase.BLOCKED, Phase.DONE, Phase.FAILED):
                continue
            self._free_robot(task)
            via = None if parent == guid else self._describe(parent)
            reason = blocked_by(self._describe(guid), root_reason, via=via).model_copy(update={"guid": guid})
            task.reason = reason
            self._set_phase(task, Phase.BLOCKED, TaskStatus.BLOCKED)
            self._pending.pop((item, "task"), None)
            component = self._components[item]
            if component.state in (ComponentState.PLANNED, ComponentState.RELEASED):
                self._send_event(
                    item, ComponentEvent.BLOCK, partial(reached, component, TERMINAL), reason=reason
                )
            else:
                self._pending.pop((item, "event"), None)
            stack.extend((successor, item) for successor in self._dependents.get(item, ()))

    def _describe(self, guid: str) -> str:
        component = self._manifest.get(guid)
        name = (component.name or component.ifc_class) if component is not None else None
        return named_guid(guid, name)

    def _set_phase(self, task: TaskRecord, phase: Phase, status: TaskStatus) -> None:
        task.phase = phase
        self.revision += 1
        if task.kind is TaskKind.HAND_OFF and phase is not Phase.ASSIGNED:
            self._outbox.append(self._task_msg(task, status))  # the hand-off task ends here too
            task.kind, task.put_down_xy = TaskKind.BUILD, None
        self._outbox.append(self._task_msg(task, status))

    def _send_event(
        self,
        guid: str,
        event: ComponentEvent,
        settled: Callable[[], bool],
        robot_id: str | None = None,
        *,
        reason: Reason | None = None,
    ) -> None:
        current = self._pending.get((guid, "event"))
        if (
            current is not None
            and isinstance(current.message, ComponentEventMsg)  # what an "event" key always holds
            and current.message.event is event
            and not current.settled()
        ):
            return  # already on its way (same event_id on every resend)
        task = self._tasks[guid]
        message = ComponentEventMsg(
            guid=guid,
            event=event,
            source=SOURCE,
            event_id=self._new_id(),
            task_id=task.task_id,
            robot_id=robot_id,
            sim_time_s=self.sim_time_s,
            wall_time_s=self._wall_s,
            reason=reason,
        )
        self._pending[(guid, "event")] = Pending(message, settled)

    def _task_msg(self, task: TaskRecord, status: TaskStatus) -> TaskMsg:
        component = self._manifest[task.guid]
        pose = component.target_pose_world
        return TaskMsg(
            task_id=task.active_id,
            guid=task.guid,
            component_key=component.key,
            status=status,
            robot_id=task.robot_id if status is TaskStatus.ASSIGNED else None,
            attempt=self._components[task.guid].attempt,
            target_pose=PoseMsg(position_m=pose.position_m, quat_xyzw=pose.quat_xyzw),
            sim_time_s=self.sim_time_s,
            wall_time_s=self._wall_s,
            reason=task.reason if status in (TaskStatus.FAILED, TaskStatus.BLOCKED) else None,
            kind=task.kind,
            put_down_xy_m=task.put_down_xy,
            method=component.method,
        )
