"""A machine that builds components where they stand: a pump and its crew cast concrete, a block layer lays
masonry, a piling rig drives piles. The executor of a robot type that can ``pour``, ``lay`` or ``pile`` (no
bus; the adapter is the robot's).

It never drives under its own control: it stands where the site plan set it up and works within its boom's
reach. A truck-mounted one that may ``relocate`` moves first when its boom does not cover the component from
where it stands: to the set-up position of the site plan's that covers it and is reached soonest
(:meth:`~bimbot.shared.robot_description.RobotDescription.setup_for`), busy for the relocation's time
(stow, drive, set up: ``relocation_s``) once its first event has started the component's work, then
physics moves its base there (``physics/relocate``). A task is timed work in sim time, through the
construction protocol:

* cast in place — ``form`` (formwork and reinforcement, ``cast.formwork_s``), ``pour`` (``cast.pour_s``),
  then physics builds it whole (``physics/build``) and ``place`` hands it to its agent's verification;
* laid — ``lay``, then course by course: each course takes its blocks at the type's rate
  (``laying.blocks_per_h``) and physics raises the wall to that course (``height_fraction``); after the
  last course ``place``;
* driven — ``drive``: the pile is pitched and driven (``piling.pitch_s``, then its length at
  ``piling.penetration_m_per_h``), then physics builds it whole and ``place``.

What cures is the planner's business (it holds what rests on a cast component). While a timer runs the
robot's state says until when (``busy_until_s``), so a site where nothing else moves can skip to it; a step's
timer runs from when the step became the one under way, not from its event's answer. Every
wait is bounded: a physics request by ``request_timeout_s`` of wall time and ``max_tries`` refusals, an
event by the agent's confirmation (resent at least once), the verdict by the agent's own bound; a task it
cannot do (out of its boom's reach, another method) is given back at once with the reason.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, replace

import numpy as np

from bimbot.shared.component_states import ComponentStates
from bimbot.shared.construction_methods import ConstructionMethod
from bimbot.shared.errors import InputError
from bimbot.shared.footprint import posed_footprint
from bimbot.shared.manifest import Component, Manifest
from bimbot.shared.messages import (
    BuildRequest,
    ClockMsg,
    CmdVelMsg,
    ComponentEvent,
    ComponentState,
    ComponentStateMsg,
    RobotState,
    RobotStateMsg,
    SetUpRequest,
    SiteInfoMsg,
    TaskMsg,
    TaskStatus,
    TwinMsg,
)
from bimbot.shared.reasons import Reason, ReasonCode
from bimbot.shared.robot_description import Capability, RobotDescription
from bimbot.shared.site_plan import machine_setups
from bimbot.shared.work_methods import WORK_CAPABILITY, pile_length_m

from .protocol import VERDICTS, EventQueue, Outgoing, PhysicsRequest, PhysicsResult, assignment_waiting
from .task_machine import TaskMachine, Trigger
from .task_state import ExecutorConfig, task_event

_log = logging.getLogger(__name__)
_E, _C = ComponentEvent, ComponentState


@dataclass(frozen=True)
class Step:
    """One timed step of work in place: the event that starts it (None: goes on in the same state), how
    long it takes (sim s) and the height physics raises the component to at its end (None: nothing yet)."""

    event: ComponentEvent | None
    duration_s: float
    height_fraction: float | None
    what: str
    relocate_to: tuple[float, float, float] | None = None  # at its end physics sets the machine up here


def work_steps(component: Component, description: RobotDescription) -> list[Step]:
    """The steps of building ``component`` in place with a robot of ``description``."""
    if component.method is ConstructionMethod.CAST_IN_PLACE:
        cast = component.cast
        formwork_s, pour_s = (cast.formwork_s, cast.pour_s) if cast is not None else (0.0, 0.0)
        return [
            Step(_E.FORM, formwork_s, None, "formwork and reinforcement"),
            Step(_E.POUR, pour_s, 1.0, "pour"),
        ]
    if component.method is ConstructionMethod.DRIVEN:
        piling = description.piling
        if piling is None:
            return []
        length_m = pile_length_m(component)
        return [Step(_E.DRIVE, piling.drive_s(length_m), 1.0, f"pitching and driving {length_m:.1f} m")]
    laying = description.laying
    if component.method is not ConstructionMethod.LAID or laying is None:
        return []
    height_m = max(component.bbox_world.max_m[2] - component.bbox_world.min_m[2], laying.block_height_m)
    courses = max(1, math.ceil(height_m / laying.block_height_m - 1e-6))
    block_m3 = laying.block_length_m * laying.block_height_m * laying.block_width_m
    blocks = max(courses, math.ceil(component.volume_m3 / block_m3))
    course_s = 3600.0 * blocks / courses / laying.blocks_per_h
    return [
        Step(_E.LAY if index == 0 else None, course_s, (index + 1) / courses, f"course {index + 1}/{courses}")
        for index in range(courses)
    ]


@dataclass
class Job:
    """One task of work in place: where it stands in its steps."""

    message: TaskMsg
    component: Component
    steps: list[Step]
    events: EventQueue
    index: int = 0  # the step under way
    started_s: float | None = None  # sim time the step's timer started (its event confirmed)
    ready_s: float | None = None  # sim time the step became the one under way (its timer cannot start before)
    request: PhysicsRequest | None = None
    request_sent: bool = False
    tries: int = 0
    placed: bool = False
    verdict: ComponentState | None = None
    abandoning: bool = False
    abandon_at_s: float = math.inf


class SiteWorkExecutor:
    """Timed work in place for one pump or block layer, fed messages, answering one command per step."""

    def __init__(
        self,
        manifest: Manifest,
        info: SiteInfoMsg,
        config: ExecutorConfig,
        *,
        start_xy_yaw: tuple[float, float, float] | None = None,
    ) -> None:
        if config.robot_id not in info.robot_ids:
            raise InputError(f"robot {config.robot_id!r} is not on site (physics has {info.robot_ids})")
        self.config, self.robot_id = config, config.robot_id
        self.description = info.robot_types[info.robot_type_of[self.robot_id]]
        self.home_xy_yaw = info.robot_starts_xy_yaw[info.robot_ids.index(self.robot_id)]
        machines = [
            robot_id
            for robot_id in info.robot_ids
            if info.robot_types[info.robot_type_of[robot_id]].can(Capability.STAND_FIXED)
        ]
        self.setups = machine_setups(info.layout, machines.index(self.robot_id), self.home_xy_yaw)
        if start_xy_yaw is not None:
            self.home_xy_yaw = start_xy_yaw
        self.relocations = 0  # moves to another set-up so far
        self.components = {component.guid: component for component in manifest.components}
        self.component_states = ComponentStates({c.guid: c.key for c in manifest.components})
        self.tasks: dict[str, TaskMsg] = {}
        self.performed: set[tuple[str, int, float]] = set()
        self.done: list[tuple[str, ComponentState]] = []
        self.given_back: list[tuple[str, Reason]] = []
        self.job: Job | None = None
        self.sim_s, self.step, self.distance_m = 0.0, -1, 0.0
        self.localisation_error_m = self.max_localisation_error_m = 0.0  # it never drives
        self._wall_s = 0.0
        self._out: list[Outgoing] = []
        self._last_state: tuple[RobotState, str | None, float | None] | None = None
        self._last_state_wall_s = -math.inf
        self._next_request = 1
        self.machine = TaskMachine()

    @property
    def state(self) -> RobotState:
        return self.machine.state

    # --- inputs and outputs ------------------------------------------------------------------------------

    def handle(self, message: object) -> None:
        if isinstance(message, ComponentStateMsg):
            self.component_states.hear(message)
        elif isinstance(message, TwinMsg):
            self.component_states.take_twin(message)
        elif isinstance(message, TaskMsg):
            if message.robot_id == self.robot_id or message.task_id in self.tasks:
                self.tasks[message.task_id] = message
            if message.status is TaskStatus.RELEASED and self.job is None:
                self._last_state_wall_s = -math.inf  # say idle now: the planner assigns to the idle
        elif isinstance(message, PhysicsResult):
            self._physics_result(message)

    def tick(self, clock: ClockMsg, wall_s: float) -> list[Outgoing]:
        self.sim_s, self.step, self._wall_s = clock.sim_time_s, clock.step, wall_s
        self._progress()
        command = CmdVelMsg(
            robot_id=self.robot_id, v_mps=0.0, w_radps=0.0, sim_time_s=self.sim_s, step=clock.step
        )
        return [*self.poll(wall_s), command]

    def after_tick(self) -> None:
        """Nothing to localise: it stands where it was set up."""

    def sleeps_until_s(self) -> float | None:
        """Never asleep at work (see :meth:`.executor.Executor.sleeps_until_s`)."""
        return None

    def can_sleep(self) -> bool:
        """Idle with nothing ahead of its own accord (see :meth:`.executor.Executor.can_sleep`)."""
        return (
            self.job is None
            and not self.component_states.asking
            and not assignment_waiting(self.tasks, self.robot_id, self.performed)
        )

    def poll(self, wall_s: float) -> list[Outgoing]:
        self._wall_s = wall_s
        job = self.job
        if job is not None:
            if job.request is not None and not job.request_sent:
                job.request_sent = True
                self._out.insert(0, job.request)
            event = job.events.due(wall_s)
            if event is not None:
                self._out.append(event)
            if job.events.unconfirmed_for_s(wall_s) >= self.config.confirm_ask_s:
                self.component_states.ask(job.message.guid)
        busy_until = self._busy_until()
        signature = (self.state, job.message.task_id if job else None, busy_until)
        if signature != self._last_state or wall_s - self._last_state_wall_s >= self.config.state_period_s:
            self._out.append(self.state_message(wall_s))
            self._last_state, self._last_state_wall_s = signature, wall_s
        self._out.extend(self.component_states.questions(wall_s))
        out, self._out = self._out, []
        return out

    def state_message(self, wall_s: float) -> RobotStateMsg:
        job = self.job
        step = job.steps[job.index] if job is not None and job.index < len(job.steps) else None
        return RobotStateMsg(
            robot_id=self.robot_id,
            state=self.state,
            task_id=job.message.task_id if job else None,
            guid=job.message.guid if job else None,
            pose_xy_yaw=self.home_xy_yaw,
            sim_time_s=self.sim_s,
            wall_time_s=wall_s,
            activity=step.what if step is not None and job is not None and job.started_s is not None else "",
            busy_until_s=self._busy_until(),
            relocations=self.relocations,
        )

    # --- the job -----------------------------------------------------------------------------------------

    def _busy_until(self) -> float | None:
        """When the step under way ends; before its timer starts (its event's answer awaited), the earliest
        it can end, so that a clock jumping over a quiet site never leaps past it. None while physics is
        asked something (its answer is news that holds the clock) or when no timed step is under way."""
        job = self.job
        if job is None or job.index >= len(job.steps) or job.request is not None:
            return None
        start_s = job.started_s if job.started_s is not None else job.ready_s
        return None if start_s is None else start_s + job.steps[job.index].duration_s

    def _progress(self) -> None:
        if self.job is None:
            self._maybe_start()
            return
        job = self.job
        latest = self.component_states.state(job.message.guid)
        job.events.confirm(latest, verdict_seen=job.verdict is not None)
        if job.abandoning:
            if not job.events:
                self._finish(None)
            elif self.sim_s - job.abandon_at_s > self.config.give_back_timeout_s:
                _log.error("%s: %s never confirmed the abandon; going idle", self.robot_id, job.message.guid)
                self._finish(None)
            return
        if self._withdrawn(job):
            return
        if job.placed:
            if latest in VERDICTS:
                job.verdict = latest
            if job.verdict is not None and _E.PLACE not in job.events.unconfirmed:
                _log.info("%s: %s %s", self.robot_id, job.message.guid, job.verdict.value)
                self._finish(job.verdict)
            return
        if job.request is not None or job.events:
            return  # a physics reply or an event's confirmation is awaited
        if job.index >= len(job.steps):
            self._queue_event(job, _E.PLACE)
            job.placed = True
            return
        step = job.steps[job.index]
        if job.started_s is None:
            # the work began when the step became the one under way (its event bears that time): the
            # state said it ends by then plus its duration, and a quiet site's clock may have jumped there
            # while the event's answer was awaited
            job.started_s = job.ready_s if job.ready_s is not None else self.sim_s
            _log.info(
                "%s: %s of %s, %.0f s of sim time",
                self.robot_id,
                step.what,
                job.message.guid,
                step.duration_s,
            )
            return
        if self.sim_s < job.started_s + step.duration_s - 1e-9:
            return
        if step.relocate_to is not None:
            move = SetUpRequest(robot_id=self.robot_id, pose_xy_yaw=step.relocate_to)
            job.request = PhysicsRequest("relocate", self._request_id(), move, self.config.request_timeout_s)
            job.request_sent = False
            return
        if step.height_fraction is not None:
            build = BuildRequest(
                robot_id=self.robot_id, guid=job.message.guid, height_fraction=step.height_fraction
            )
            job.request = PhysicsRequest("build", self._request_id(), build, self.config.request_timeout_s)
            job.request_sent = False
            return
        self._next_step(job)

    def _next_step(self, job: Job) -> None:
        job.index += 1
        job.started_s, job.ready_s = None, self.sim_s
        if job.index < len(job.steps) and (event := job.steps[job.index].event) is not None:
            self._queue_event(job, event)

    def _maybe_start(self) -> None:
        for message in self.tasks.values():
            if message.status is not TaskStatus.ASSIGNED or message.robot_id != self.robot_id:
                continue
            assignment = (message.task_id, message.attempt, message.wall_time_s)
            if assignment in self.performed or message.guid not in self.components:
                continue
            if self.component_states.state(message.guid) not in (None, _C.RELEASED):
                continue  # the assignment is ahead of the component's release: wait for it
            self.performed.add(assignment)
            component = self.components[message.guid]
            job = Job(
                message,
                component,
                work_steps(component, self.description),
                EventQueue(self.config.resend_s),
                ready_s=self.sim_s,
            )
            self.job = job
            self.machine.fire(Trigger.WORK_ASSIGNED)
            _log.info(
                "%s: task %s (%s, %s)", self.robot_id, message.task_id, message.guid, component.method.value
            )
            why = self._cannot(component)
            if why is not None:
                self._give_back(job, why)
                return
            self._relocation_first(job)
            first = job.steps[0].event
            if first is not None:
                self._queue_event(job, first)
            return

    def _cannot(self, component: Component) -> Reason | None:
        needs = WORK_CAPABILITY.get(component.method)
        name = component.name or component.guid
        if needs is None or not self.description.can(needs):
            return Reason(
                code=ReasonCode.PHYSICS_REFUSED,
                robot_id=self.robot_id,
                message=f"{self.robot_id} ({self.description.name}) cannot build {name}, which is "
                f"{component.method.value}",
            )
        polygon = _target_polygon(component)
        if self.description.setup_for(self.setups, self.home_xy_yaw[:2], polygon) is None:
            far_m = min(
                max(math.dist(corner, pose[:2]) for corner in polygon.tolist()) for pose in self.setups
            )
            where = (
                f" (the nearest of its {len(self.setups)} set-up positions)" if len(self.setups) > 1 else ""
            )
            return Reason(
                code=ReasonCode.OUT_OF_REACH,
                robot_id=self.robot_id,
                message=f"{name} reaches {far_m:.1f} m from {self.robot_id} ({self.description.name})"
                f"{where}, whose boom reaches {self.description.reach_m:g} m",
            )
        return None

    def _relocation_first(self, job: Job) -> None:
        """When its boom does not cover the component from where it stands: a relocation to the set-up that
        does first, started by the work's first event (the component's work has begun: the machine is on
        its way to it)."""
        polygon = _target_polygon(job.component)
        pose = self.description.setup_for(self.setups, self.home_xy_yaw[:2], polygon)
        if pose is None or not job.steps:
            return
        duration_s = self.description.relocation_s(self.home_xy_yaw[:2], pose[:2])
        if duration_s <= 0.0:
            return
        first = job.steps[0]
        drive_m = abs(pose[0] - self.home_xy_yaw[0]) + abs(pose[1] - self.home_xy_yaw[1])
        what = f"relocating to ({pose[0]:.1f}, {pose[1]:.1f}): stow, drive {drive_m:.0f} m, set up"
        job.steps[0] = replace(first, event=None)
        job.steps.insert(0, Step(first.event, duration_s, None, what, relocate_to=pose))

    def _withdrawn(self, job: Job) -> bool:
        latest = self.tasks.get(job.message.task_id)
        if latest is None or latest.status is TaskStatus.DONE:
            return False
        if latest.status is TaskStatus.ASSIGNED and latest.robot_id == self.robot_id:
            return False
        _log.warning("%s: task %s withdrawn (%s)", self.robot_id, job.message.task_id, latest.status.value)
        self._finish(None)
        return True

    def _physics_result(self, result: PhysicsResult) -> None:
        job = self.job
        if job is None or job.request is None or job.request.request_id != result.request_id:
            return
        kind, job.request = job.request.kind, None
        reply = result.reply
        if reply is not None and reply.ok:
            moved_to = job.steps[job.index].relocate_to if job.index < len(job.steps) else None
            if moved_to is not None:
                self.home_xy_yaw = moved_to
                self.relocations += 1
                _log.info("%s: set up at (%.1f, %.1f)", self.robot_id, moved_to[0], moved_to[1])
            self._next_step(job)
            return
        job.tries += 1
        why = reply.reason if reply is not None else result.error
        _log.warning("%s: physics refused %s for %s: %s", self.robot_id, kind, job.message.guid, why)
        if job.tries >= self.config.max_tries:
            self._give_back(
                job,
                Reason(
                    code=ReasonCode.PHYSICS_REFUSED,
                    robot_id=self.robot_id,
                    message=f"physics refused the {kind} {job.tries} times; last: {why}",
                ),
            )

    def _give_back(self, job: Job, reason: Reason) -> None:
        _log.warning("%s: giving %s back: %s", self.robot_id, job.message.guid, reason.message)
        self.given_back.append((job.message.guid, reason))
        job.abandoning, job.abandon_at_s, job.request = True, self.sim_s, None
        first = next((step.event for step in job.steps if step.event is not None), None)
        if first is not None and first not in job.events.queued:
            self._queue_event(job, first)  # abandon is only legal once the work has begun
        self._queue_event(job, _E.ABANDON, reason)

    def _queue_event(self, job: Job, event: ComponentEvent, reason: Reason | None = None) -> None:
        job.events.push(
            task_event(
                job.message, event, self.robot_id, sim_s=self.sim_s, wall_s=self._wall_s, reason=reason
            )
        )

    def _finish(self, verdict: ComponentState | None) -> None:
        job = self.job
        if job is not None and verdict is not None:
            self.done.append((job.message.guid, verdict))
        self.job = None
        self.machine.fire(Trigger.FINISHED if verdict is not None else Trigger.ABORTED)

    def _request_id(self) -> int:
        self._next_request += 1
        return self._next_request - 1


def _target_polygon(component: Component) -> np.ndarray:
    """The component's footprint at its target, seen from above (its corners, world xy)."""
    target = component.target_pose_world
    return posed_footprint(component, target.position_m, target.quat_xyzw).polygon_xy_m
