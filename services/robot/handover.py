"""Physics requests and ending a task early: attach, place, drop, abandon with a reason, withdrawals.

Why apart from :mod:`.executor`: the part of a task that talks to physics and ends it early
(:meth:`Handover.ending`: withdrawn by the planner, given back, handed off). Requests go
out without blocking (:class:`~.protocol.PhysicsRequest`; replies come back to
:meth:`Handover.take_result`). A refusal sends the robot to another approach pose; ``max_tries`` refusals
give the task back (``physics_refused``, physics' reason quoted). Giving back
(:meth:`Handover.give_back`): a robot that carries the component first asks physics to put it down
(``drop``: it rests beside the robot, free for any robot), then sends ``abandon`` with the reason
(:meth:`Handover.give_up`), which the agent applies (back to released). A clear-away (a failed component
carried out of the way) sends no component event: how it ended goes on the robot's state.
"""

from __future__ import annotations

import logging
import math

import numpy as np

from bimbot.shared.messages import (
    AttachRequest,
    ComponentEvent,
    ComponentState,
    DropRequest,
    PlaceRequest,
    PoseMsg,
    RobotState,
    TaskKind,
    TaskMsg,
    TaskStatus,
)
from bimbot.shared.reasons import Reason, ReasonCode
from bimbot.shared.robot_description import Capability

from . import give_back
from .protocol import PhysicsRequest, PhysicsResult, injected
from .robot_context import RobotContext
from .task_cycle import TaskCycle
from .task_machine import Trigger
from .task_state import Task, component_name

_log = logging.getLogger(__name__)
_S, _E, _C = RobotState, ComponentEvent, ComponentState
#: What a user can do when a robot cannot tell where it is from what its laser sees.
TOTAL_STATION_HINT = (
    "a total station gives every ground robot position fixes: the rehearsal profile has one (3 mm); "
    "check the run's settings.total_station_mm, or bimbot run BUILD --total-station-mm 3"
)
LOCALISATION_DOUBT_M = 0.5  # physics measured the robot this much farther than it believed: re-localise
MAX_SPREAD_M = 3.0  # the widest particle cloud a re-localisation draws (m, one standard deviation)
SPREAD_YAW_RAD = 0.2


class Handover:
    """Physics requests, drops and give-backs of the task in hand (see the module doc).

    Owns the request ids and the tasks given back; shares the robot (``context``) and the task cycle
    (``cycle``) with the executor."""

    def __init__(self, context: RobotContext, cycle: TaskCycle) -> None:
        self.context, self.cycle = context, cycle
        self.given_back: list[tuple[str, Reason]] = []  # (GUID, reason) of every task given back
        self._next_request = 1

    def ending(self, task: Task, latest: TaskMsg | None) -> bool:
        """Work on a task that is ending early or handed off: withdrawn by the planner (``latest``, its last
        task message), given back (until the agent confirms ``abandon``), its load being put down, or put
        down at the staging spot. True while it is: the task takes no other step."""
        context, cycle = self.context, self.cycle
        if self._withdrawn(task, latest):
            return True
        if task.abandoning:
            if not task.events:
                cycle.finish(None)
            elif context.sim_s - task.abandon_at_s > context.config.give_back_timeout_s:
                _log.error(
                    "%s: %s never confirmed the abandon; going idle", context.robot_id, task.message.guid
                )
                cycle.finish(None)
            return True
        if task.dropping is not None:
            self.drop(task, task.dropping)
            return True
        if task.handed_off:
            if _E.HAND_OFF not in task.events.unconfirmed:
                _log.info("%s: handed %s off", context.robot_id, task.message.guid)
                cycle.finish(_C.RELEASED)
            return True
        return False

    def _withdrawn(self, task: Task, latest: TaskMsg | None) -> bool:
        """The planner took the task back (given to another robot, released): stop and go idle."""
        robot_id = self.context.robot_id
        if latest is None or task.placed or latest.status is TaskStatus.DONE:
            return False
        if latest.status is TaskStatus.ASSIGNED and latest.robot_id == robot_id:
            return False
        if task.withdrawn:
            return False  # putting the load down (below)
        _log.warning("%s: task %s withdrawn (%s)", robot_id, task.message.task_id, latest.status.value)
        carrying = self.cycle.state in (_S.IDENTIFY_TARGET_LOCATION, _S.ASSEMBLE) and not task.abandoning
        if carrying and task.dropping is None:
            task.withdrawn = True  # never walk off with a load: put it down first, then go idle
            self.give_back(task, give_back.withdrawn(robot_id, component_name(task)))
            return True
        if task.dropping is None:
            self.cycle.finish(None)
        else:
            task.withdrawn = True
        return True

    def place_request(self, task: Task) -> PlaceRequest:
        """Where physics is to place the task's component (offset on a first attempt when errors are
        injected), from where the robot believes it stands."""
        context = self.context
        target = task.component.target_pose_world
        x, y, z = target.position_m
        cfg = context.config
        if injected(
            task.message.guid,
            task.message.attempt,
            error_m=cfg.placement_error_m,
            guids=cfg.inject_guids,
            fraction=cfg.inject_fraction,
            seed=cfg.seed,
        ):
            x += cfg.placement_error_m
            _log.info(
                "%s: placing %s %.3f m off (injected)",
                context.robot_id,
                task.message.guid,
                cfg.placement_error_m,
            )
        pose = PoseMsg(position_m=(x, y, z), quat_xyzw=target.quat_xyzw)
        return PlaceRequest(
            robot_id=context.robot_id,
            guid=task.message.guid,
            pose=pose,
            duration_s=cfg.place_duration_s,
            believed_xy_yaw=self._believed_pose(task),
        )

    def _believed_pose(self, task: Task) -> tuple[float, float, float] | None:
        """Where the robot believes it stands as it places, after a fine alignment to what its laser sees
        (:mod:`.fine_alignment`): physics puts the component there relative to where it really stands. A
        machine that stands fixed knows its pose (None)."""
        context = self.context
        if not context.description.can(Capability.DRIVE):
            return None
        robot_id, navigator = context.robot_id, context.navigator
        alignment = navigator.align()
        _log.info(
            "%s: aligned on %d laser hits before placing %s: %s (moved the estimate %.1f mm, rms %.1f mm)",
            robot_id,
            alignment.hits,
            task.message.guid,
            "trusted"
            if alignment.trusted
            else f"not trusted, placed from the mean of {alignment.fixes} fixes"
            if alignment.fixes
            else "not trusted, the filter's estimate stands",
            1000.0 * alignment.shift_m,
            1000.0 * alignment.rms_m,
        )
        task.placement_note = (
            ""
            if alignment.trusted or alignment.fixes
            else f"{robot_id} could not align to what its laser sees before placing ({alignment.hits} "
            "laser hits matched to mapped outlines, too few or too scattered to trust) and placed from its "
            "localisation estimate alone: nothing its laser sees stands near enough (a site with nothing "
            f"standing nearby needs other positioning: {TOTAL_STATION_HINT})"
        )
        return navigator.pose_xy_yaw

    def attached(self, task: Task) -> None:
        """The component is on the robot: ``attach``, and on to its target (a fresh count of tries); a
        clear-away tells the failed component nothing."""
        if task.message.kind is not TaskKind.CLEAR:
            self.context.queue_event(task, _E.ATTACH)
        self.cycle.fire(Trigger.ATTACHED)
        task.tries, task.reselections, task.approach, task.retry_at_s = 0, 0, None, -math.inf
        task.failed_xy_m, task.misses = [], 0
        self.context.navigator.cancel()

    def take_result(self, result: PhysicsResult) -> None:
        """Physics' reply to the task's request (or a timeout): the task moves on, or tries again, or is
        given back after ``max_tries`` refusals."""
        context, cycle = self.context, self.cycle
        robot_id = context.robot_id
        task = cycle.task
        if task is None or task.request is None or task.request.request_id != result.request_id:
            return
        kind, task.request = task.request.kind, None
        if result.reply is not None and result.reply.ok:
            if kind == "drop" and task.dropping is None and task.message.kind is TaskKind.CLEAR:
                _log.info("%s: put %s down at its yard slot, out of the way", robot_id, task.message.guid)
                cycle.clear_ended(ok=True)
            elif kind == "drop" and task.dropping is None and task.message.kind is TaskKind.HAND_OFF:
                _log.info("%s: put %s down at the staging spot", robot_id, task.message.guid)
                task.handed_off = True
                context.queue_event(task, _E.HAND_OFF)
            elif kind == "drop" and task.dropping is not None:
                _log.info("%s: put %s down", robot_id, task.message.guid)
                if task.withdrawn:
                    cycle.finish(None)
                else:
                    self.give_up(task, task.dropping)
            elif kind == "attach" and cycle.state is _S.PICK_UP:
                self.attached(task)
            elif kind == "place" and cycle.state is _S.ASSEMBLE:
                task.placed = True
                # Stamped when physics fixed the component, not at the last tick: the agent judges the first
                # pose stamped at or after ``place``, which must not be one from the assembly motion.
                context.queue_event(
                    task, _E.PLACE, max(context.sim_s, result.reply.sim_time_s), note=task.placement_note
                )
            return
        why = result.reply.reason if result.reply is not None else result.error
        if result.reply is not None and result.reply.wait_s is not None:
            # not now: another robot stands where the load goes (physics bounds the wait); no failed try
            if task.waiting_since_s is None:
                task.waiting_since_s = context.sim_s
                _log.info("%s: %s of %s waits: %s", robot_id, kind, task.message.guid, why)
            task.retry_at_s = context.sim_s + result.reply.wait_s
            return None
        task.waiting_since_s = None
        _log.warning("%s: %s of %s refused: %s", robot_id, kind, task.message.guid, why)
        if result.reply is not None and result.reply.distance_m is not None:
            self._check_localisation(task, kind, result.reply.distance_m)
        if kind == "drop":
            task.drop_tries += 1
            task.retry_at_s = context.sim_s + context.config.retry_delay_s
            return None
        task.tries += 1
        if task.tries >= context.config.max_tries:
            if task.localisation_off_m > LOCALISATION_DOUBT_M:
                why += (
                    f"; {robot_id}'s localisation was off by {task.localisation_off_m:.1f} m or more "
                    f"({TOTAL_STATION_HINT})"
                )
            refused = give_back.physics_refused(robot_id, kind, component_name(task), task.tries, why)
            return self.give_back(task, refused)
        task.retry_at_s = context.sim_s + context.config.retry_delay_s * min(task.tries, 10)
        task.approach = None  # maybe too far: look for an approach pose again
        context.navigator.cancel()
        return None

    def _check_localisation(self, task: Task, kind: str, measured_m: float) -> None:
        """Physics measured the robot ``measured_m`` from the footprint where the robot believed it was within
        reach: its localisation is off by at least the difference, so it re-localises (a wider particle cloud
        the laser narrows again) instead of asking again from the same wrong place."""
        context = self.context
        footprint = task.target if kind == "place" else context.site_map.footprints.get(task.message.guid)
        if footprint is None:
            return
        believed_m = float(footprint.distance_m(np.asarray(context.navigator.pose_xy_yaw[:2]))[0])
        off_m = measured_m - believed_m
        task.localisation_off_m = max(task.localisation_off_m, off_m)
        if off_m > LOCALISATION_DOUBT_M:
            _log.warning(
                "%s: physics measured %.2f m to %s where %s believed %.2f m: localisation off by %.2f m+",
                context.robot_id,
                measured_m,
                task.message.guid,
                context.robot_id,
                believed_m,
                off_m,
            )
            context.navigator.localiser.spread(min(MAX_SPREAD_M, off_m), SPREAD_YAW_RAD)

    def request(self, task: Task, kind: str, message: AttachRequest | PlaceRequest | DropRequest) -> None:
        """Ask physics (sent by the executor's next poll, without blocking; the reply comes to
        :meth:`take_result`)."""
        task.request = PhysicsRequest(
            kind, self._next_request, message, self.context.config.request_timeout_s
        )
        task.request_sent = False
        self._next_request += 1

    def give_back(self, task: Task, reason: Reason) -> None:
        """Give the task back with ``reason``; a carried load is put down first (:meth:`drop`)."""
        carrying = self.cycle.state in (_S.IDENTIFY_TARGET_LOCATION, _S.ASSEMBLE) and not task.placed
        if not carrying:
            return self.give_up(task, reason)
        _log.warning("%s: putting %s down: %s", self.context.robot_id, task.message.guid, reason.line())
        self.context.navigator.cancel()
        task.dropping, task.request, task.drop_tries, task.retry_at_s = reason, None, 0, -math.inf
        return self.drop(task, reason)

    def drop(self, task: Task, reason: Reason) -> None:
        """Ask physics to put the load down (again after a refusal, ``max_tries`` times), then give back."""
        context = self.context
        if task.request is not None or context.sim_s < task.retry_at_s:
            return None
        if task.drop_tries >= context.config.max_tries:
            _log.error(
                "%s: physics did not take %s off it; giving it back", context.robot_id, task.message.guid
            )
            return self.cycle.finish(None) if task.withdrawn else self.give_up(task, reason)
        return self.request(task, "drop", DropRequest(robot_id=context.robot_id, guid=task.message.guid))

    def give_up(self, task: Task, reason: Reason) -> None:
        """``abandon`` with ``reason`` (after ``pick``: only legal from there on); idle once applied."""
        context = self.context
        _log.error(
            "%s: giving %s (%s) back: %s",
            context.robot_id,
            task.message.task_id,
            task.message.guid,
            reason.line(),
        )
        context.navigator.cancel()
        task.request, task.dropping = None, None
        reason = reason if reason.robot_id else reason.model_copy(update={"robot_id": context.robot_id})
        self.given_back.append((task.message.guid, reason))
        if reason.code is ReasonCode.ROBOT_TRAPPED and context.cut_off_from_depot():
            self.cycle.walled_in(reason.message)
        if (
            task.message.kind is TaskKind.CLEAR
        ):  # its component is failed: the planner hears it from the robot
            return self.cycle.clear_ended(ok=False, reason=reason)
        if _E.PICK not in task.events.queued:
            context.queue_event(task, _E.PICK)  # abandon is only legal once the component is picking
        context.queue_event(task, _E.ABANDON, reason=reason)
        task.abandoning, task.abandon_at_s = True, context.sim_s
