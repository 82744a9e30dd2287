"""Physics requests and giving a task back: attach, place, drop, abandon with a reason (a mixin).

Why apart from :mod:`.executor`: the part of a task that talks to physics and ends it early. Requests go
out without blocking (:class:`~.protocol.PhysicsRequest`; replies come back to :meth:`_physics_result`).
A refusal sends the robot to another approach pose; ``max_tries`` refusals give the task back
(``physics_refused``, physics' reason quoted). Giving back (:meth:`_give_back`): a robot that carries the
component first asks physics to put it down (``drop``: it rests beside the robot, free for any robot),
then sends ``abandon`` with the reason (:meth:`_give_up`), which the agent applies (back to released).
"""

from __future__ import annotations

import logging
import math
from typing import TYPE_CHECKING

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
)
from bimbot.shared.reasons import Reason
from bimbot.shared.robot_description import Capability, RobotDescription

from .task_state import ExecutorConfig, Task

if TYPE_CHECKING:
    from .navigator import Navigator
    from .site_map import SiteMap
    from .task_machine import TaskMachine

from . import give_back
from .protocol import PhysicsRequest, PhysicsResult, injected

_log = logging.getLogger(__name__)
_S, _E = RobotState, ComponentEvent
#: What a user can do when a robot cannot tell where it is from what its laser sees.
TOTAL_STATION_HINT = (
    "a total station gives every ground robot position fixes: the rehearsal profile has one (3 mm); "
    "check the run's settings.total_station_mm, or bimbot run BUILD --total-station-mm 3"
)
LOCALISATION_DOUBT_M = 0.5  # physics measured the robot this much farther than it believed: re-localise
MAX_SPREAD_M = 3.0  # the widest particle cloud a re-localisation draws (m, one standard deviation)
SPREAD_YAW_RAD = 0.2


class Handover:
    """Physics requests, drops and give-backs, for :class:`.executor.Executor`."""

    config: ExecutorConfig
    robot_id: str
    sim_s: float
    site_map: SiteMap
    navigator: Navigator
    description: RobotDescription
    machine: TaskMachine
    task: Task | None
    given_back: list[tuple[str, Reason]]
    _next_request: int

    if TYPE_CHECKING:  # defined by :class:`.executor.Executor`, which this is a mixin of

        def _attached(self, task: Task) -> None: ...

        def _queue_event(
            self,
            task: Task,
            event: ComponentEvent,
            sim_s: float | None = None,
            reason: Reason | None = None,
            note: str = "",
        ) -> None: ...

        def _finish(self, verdict: ComponentState | None) -> None: ...

    def _place_request(self, task: Task) -> PlaceRequest:
        target = task.component.target_pose_world
        x, y, z = target.position_m
        cfg = self.config
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
                self.robot_id,
                task.message.guid,
                cfg.placement_error_m,
            )
        pose = PoseMsg(position_m=(x, y, z), quat_xyzw=target.quat_xyzw)
        return PlaceRequest(
            robot_id=self.robot_id,
            guid=task.message.guid,
            pose=pose,
            duration_s=cfg.place_duration_s,
            believed_xy_yaw=self._believed_pose(task),
        )

    def _believed_pose(self, task: Task) -> tuple[float, float, float] | None:
        """Where the robot believes it stands as it places, after a fine alignment to what its laser sees
        (:mod:`.fine_alignment`): physics puts the component there relative to where it really stands. A
        machine that stands fixed knows its pose (None)."""
        if not self.description.can(Capability.DRIVE):
            return None
        alignment = self.navigator.align()
        _log.info(
            "%s: aligned on %d laser hits before placing %s: %s (moved the estimate %.1f mm, rms %.1f mm)",
            self.robot_id,
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
            else f"{self.robot_id} could not align to what its laser sees before placing ({alignment.hits} "
            "laser hits matched to mapped outlines, too few or too scattered to trust) and placed from its "
            "localisation estimate alone: nothing its laser sees stands near enough (a site with nothing "
            f"standing nearby needs other positioning: {TOTAL_STATION_HINT})"
        )
        return self.navigator.pose_xy_yaw

    def _physics_result(self, result: PhysicsResult) -> None:
        task = self.task
        if task is None or task.request is None or task.request.request_id != result.request_id:
            return
        kind, task.request = task.request.kind, None
        if result.reply is not None and result.reply.ok:
            if kind == "drop" and task.dropping is None and task.message.kind is TaskKind.HAND_OFF:
                _log.info("%s: put %s down at the staging spot", self.robot_id, task.message.guid)
                task.handed_off = True
                self._queue_event(task, _E.HAND_OFF)
            elif kind == "drop" and task.dropping is not None:
                _log.info("%s: put %s down", self.robot_id, task.message.guid)
                if task.withdrawn:
                    self._finish(None)
                else:
                    self._give_up(task, task.dropping)
            elif kind == "attach" and self.machine.state is _S.PICK_UP:
                self._attached(task)
            elif kind == "place" and self.machine.state is _S.ASSEMBLE:
                task.placed = True
                # Stamped when physics fixed the component, not at the last tick: the agent judges the first
                # pose stamped at or after ``place``, which must not be one from the assembly motion.
                self._queue_event(
                    task, _E.PLACE, max(self.sim_s, result.reply.sim_time_s), note=task.placement_note
                )
            return
        why = result.reply.reason if result.reply is not None else result.error
        _log.warning("%s: %s of %s refused: %s", self.robot_id, kind, task.message.guid, why)
        if result.reply is not None and result.reply.distance_m is not None:
            self._check_localisation(task, kind, result.reply.distance_m)
        if kind == "drop":
            task.drop_tries += 1
            task.retry_at_s = self.sim_s + self.config.retry_delay_s
            return None
        task.tries += 1
        if task.tries >= self.config.max_tries:
            if task.localisation_off_m > LOCALISATION_DOUBT_M:
                why += (
                    f"; {self.robot_id}'s localisation was off by {task.localisation_off_m:.1f} m or more "
                    f"({TOTAL_STATION_HINT})"
                )
            refused = give_back.physics_refused(self.robot_id, kind, self._name(task), task.tries, why)
            return self._give_back(task, refused)
        task.retry_at_s = self.sim_s + self.config.retry_delay_s * min(task.tries, 10)
        task.approach = None  # maybe too far: look for an approach pose again
        self.navigator.cancel()
        return None

    def _check_localisation(self, task: Task, kind: str, measured_m: float) -> None:
        """Physics measured the robot ``measured_m`` from the footprint where the robot believed it was within
        reach: its localisation is off by at least the difference, so it re-localises (a wider particle cloud
        the laser narrows again) instead of asking again from the same wrong place."""
        footprint = task.target if kind == "place" else self.site_map.footprints.get(task.message.guid)
        if footprint is None:
            return
        believed_m = float(footprint.distance_m(np.asarray(self.navigator.pose_xy_yaw[:2]))[0])
        off_m = measured_m - believed_m
        task.localisation_off_m = max(task.localisation_off_m, off_m)
        if off_m > LOCALISATION_DOUBT_M:
            _log.warning(
                "%s: physics measured %.2f m to %s where %s believed %.2f m: localisation off by %.2f m+",
                self.robot_id,
                measured_m,
                task.message.guid,
                self.robot_id,
                believed_m,
                off_m,
            )
            self.navigator.localiser.spread(min(MAX_SPREAD_M, off_m), SPREAD_YAW_RAD)

    def _request(self, task: Task, kind: str, message: AttachRequest | PlaceRequest | DropRequest) -> None:
        task.request = PhysicsRequest(kind, self._next_request, message, self.config.request_timeout_s)
        task.request_sent = False
        self._next_request += 1

    def _give_back(self, task: Task, reason: Reason) -> None:
        """Give the task back with ``reason``; a carried load is put down first (:meth:`_drop`)."""
        carrying = self.machine.state in (_S.IDENTIFY_TARGET_LOCATION, _S.ASSEMBLE) and not task.placed
        if not carrying:
            return self._give_up(task, reason)
        _log.warning("%s: putting %s down: %s", self.robot_id, task.message.guid, reason.line())
        self.navigator.cancel()
        task.dropping, task.request, task.drop_tries, task.retry_at_s = reason, None, 0, -math.inf
        return self._drop(task, reason)

    def _drop(self, task: Task, reason: Reason) -> None:
        """Ask physics to put the load down (again after a refusal, ``max_tries`` times), then give back."""
        if task.request is not None or self.sim_s < task.retry_at_s:
            return None
        if task.drop_tries >= self.config.max_tries:
            _log.error("%s: physics did not take %s off it; giving it back", self.robot_id, task.message.guid)
            return self._finish(None) if task.withdrawn else self._give_up(task, reason)
        return self._request(task, "drop", DropRequest(robot_id=self.robot_id, guid=task.message.guid))

    def _give_up(self, task: Task, reason: Reason) -> None:
        """``abandon`` with ``reason`` (after ``pick``: only legal from there on); idle once applied."""
        _log.error(
            "%s: giving %s (%s) back: %s",
            self.robot_id,
            task.message.task_id,
            task.message.guid,
            reason.line(),
        )
        self.navigator.cancel()
        task.request, task.dropping = None, None
        reason = reason if reason.robot_id else reason.model_copy(update={"robot_id": self.robot_id})
        self.given_back.append((task.message.guid, reason))
        if _E.PICK not in task.events.queued:
            self._queue_event(task, _E.PICK)  # abandon is only legal once the component is picking
        self._queue_event(task, _E.ABANDON, reason=reason)
        task.abandoning, task.abandon_at_s = True, self.sim_s

    def _name(self, task: Task) -> str:
        """The component as a user knows it: ``Column R1 (2O2Fr$t4X7Zf8NOew3FLOH)``."""
        name = task.component.name
        return f"{name} ({task.message.guid})" if name else task.message.guid
