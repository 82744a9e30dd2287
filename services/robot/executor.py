"""One robot's construction work: the planner's tasks carried out through the construction protocol (no bus).

Why: the robot's behaviour as a core the tests drive with fake inputs. The adapter feeds it every validated
message (:meth:`Executor.handle`), calls :meth:`Executor.tick` once per clock step (the answer always holds
a ``cmd_vel`` stamped with the step, so lock-step physics never waits on this robot), then
:meth:`Executor.after_tick` once the answer is out (the localisation update on the step's scan, which need
not delay the command), and :meth:`Executor.poll` between steps, and publishes what they return. Nothing
blocks: physics requests go out as :class:`~.protocol.PhysicsRequest` and their replies come back as
:class:`~.protocol.PhysicsResult`.

A task (states from :mod:`.task_machine`, events through :class:`~.protocol.EventQueue`):

1. ``detect_component_position`` — where the component is now (physics' last pose, else its yard slot) and
   an approach pose beside it (:mod:`.approach`); ``pick`` is sent as the robot leaves (``pick_up``);
2. ``pick_up`` — there, once the component says ``picking``, physics is asked to attach it; accepted →
   ``attach`` is sent (``identify_target_location``); refused (out of reach) → another approach;
3. ``identify_target_location`` — drive to an approach pose of the BIM target; there (``assemble``)
   ``arrive`` is sent;
4. ``assemble`` — once the component says ``assembling``, physics is asked to place it at its BIM pose (offset
   on first attempts when errors are injected); done → ``place`` is sent; the component's verdict
   (constructed, misplaced or failed) ends the task: ``idle``. A misplaced component is retried by the
   planner and may come back: it is then picked up from where it lies.

Every wait is bounded in sim time and every retry counted (:class:`ExecutorConfig`), and a task the robot
cannot finish is **given back** with ``abandon`` carrying a :class:`~bimbot.shared.reasons.Reason`
(:mod:`.give_back` lists them; the planner fails a component after its bound of give-backs): no stand-point
or none it can get to (:mod:`.driving`; a crane's reach, :mod:`.crane_work`), navigation failed, physics
refused, or the **task watchdog** (no state change for ``task_timeout_s``). A robot that carries the
component puts it down first (:mod:`.handover`). An idle robot leaves the structure and parks
(:mod:`.parking`). Wall time drives resends and the ~1 Hz state; sim time drives everything else.

The parts share the robot through one :class:`~.robot_context.RobotContext` and the task through one
:class:`~.task_cycle.TaskCycle`; a robot type's executor chooses its parts (:class:`CraneExecutor`,
:class:`~.plan_executor.PlanExecutor`).
"""

from __future__ import annotations

import logging
import math

import numpy as np

from bimbot.shared.component_states import ComponentStates
from bimbot.shared.errors import InputError
from bimbot.shared.footprint import posed_footprint
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import (
    AttachRequest,
    ClockMsg,
    CmdVelMsg,
    ComponentEvent,
    ComponentPoseMsg,
    ComponentState,
    ComponentStateMsg,
    DropRequest,
    OdomMsg,
    PlanMsg,
    PositionFixMsg,
    RobotPoseMsg,
    RobotState,
    RobotStateMsg,
    ScanMsg,
    SiteInfoMsg,
    TaskKind,
    TaskMsg,
    TaskStatus,
    TwinMsg,
)
from bimbot.shared.reasons import Reason
from bimbot.shared.robot_description import Capability
from bimbot.shared.work_methods import WORK_METHOD

from . import give_back
from .approach import ApproachConfig
from .compiled_kernels import warm_up_kernels
from .crane_work import CraneHandover, CraneReach
from .driving import Driving
from .handover import Handover
from .navigator import Navigator, NavigatorConfig
from .parking import Parking
from .protocol import VERDICTS, EventQueue, Outgoing, PhysicsResult, assignment_waiting
from .robot_context import GettingThere, robot_context
from .shut_in_check import held, note_placing
from .site_map import MapConfig
from .site_work import SiteWorkExecutor
from .task_cycle import TaskCycle
from .task_machine import TaskMachine, Trigger
from .task_state import ExecutorConfig, Task, component_name, put_down_target

_log = logging.getLogger(__name__)

_S, _E, _C = RobotState, ComponentEvent, ComponentState
DEFAULT_MAP = MapConfig()


class Executor:
    """The robot's task execution and navigation, fed messages, answering one command per clock step.

    Owns what it hears (the tasks, the component states, odometry, ground truth) and the task's steps; its
    parts (built by the three methods a robot type's executor overrides) own the rest: the task cycle, the
    physics requests and give-backs (:class:`.handover.Handover`), getting to the work
    (:class:`.driving.Driving`) and parking (:class:`.parking.Parking`)."""

    def __init__(
        self,
        manifest: Manifest,
        info: SiteInfoMsg,
        config: ExecutorConfig,
        *,
        map_config: MapConfig = DEFAULT_MAP,
        nav_config: NavigatorConfig | None = None,
        approach_config: ApproachConfig | None = None,
        start_xy_yaw: tuple[float, float, float] | None = None,
    ) -> None:
        """``start_xy_yaw``: where the robot is (physics says so when a robot restarts mid-build); its depot
        start when None."""
        if config.robot_id not in info.robot_ids:
            raise InputError(f"robot {config.robot_id!r} is not on site (physics has {info.robot_ids})")
        warm_up_kernels()  # a tick never waits for a kernel to compile or load
        self.config, self.robot_id = config, config.robot_id
        self.components = {component.guid: component for component in manifest.components}
        self.context = robot_context(
            manifest,
            info,
            config,
            map_config=map_config,
            nav_config=nav_config,
            approach_config=approach_config,
            start_xy_yaw=start_xy_yaw,
        )
        # fixed for the robot's life: read here, owned by the context
        self.site_map, self.description = self.context.site_map, self.context.description
        self.home_xy_yaw = self.context.home_xy_yaw
        self.cycle = TaskCycle(self.context)
        self.handover = self._handover()
        self.getting_there = self._getting_there()
        self.parking = self._parking()
        self.tasks: dict[str, TaskMsg] = {}  # latest message per task id (assigned to this robot once)
        self._task_kinds: dict[str, TaskKind] = {}  # every task's kind, the others' too (what they set)
        # judged state messages, twins asked when one does not fit (a forged state must not stall a task)
        self.component_states = ComponentStates({c.guid: c.key for c in manifest.components})
        # assignments taken on: (task id, attempt, assignment stamp); a task given back and assigned again
        # (same attempt) is a new assignment with a new stamp, while a repeated delivery is not
        self.performed: set[tuple[str, int, float]] = set()
        self.step = -1
        # localisation error against ground truth: a metric for the logs, never used for control
        self.localisation_error_m = 0.0
        self.max_localisation_error_m = 0.0
        self._last_odom: np.ndarray | None = None

    # --- the parts of a robot type (a crane's and a plan-fidelity robot's replace some) -----------------

    def _handover(self) -> Handover:
        return Handover(self.context, self.cycle)

    def _getting_there(self) -> GettingThere:
        return Driving(self.context, self.cycle, self.handover)

    def _parking(self) -> Parking | None:
        return Parking(self.context, self.cycle)

    # --- what the adapter, the tests and the parts read -------------------------------------------------

    @property
    def navigator(self) -> Navigator:
        return self.context.navigator

    @property
    def sim_s(self) -> float:
        return self.context.sim_s

    @sim_s.setter
    def sim_s(self, sim_s: float) -> None:
        self.context.sim_s = sim_s

    @property
    def distance_m(self) -> float:
        return self.context.distance_m

    @distance_m.setter
    def distance_m(self, distance_m: float) -> None:
        self.context.distance_m = distance_m

    @property
    def machine(self) -> TaskMachine:
        return self.cycle.machine

    @property
    def task(self) -> Task | None:
        return self.cycle.task

    @property
    def done(self) -> list[tuple[str, ComponentState]]:
        return self.cycle.done

    @property
    def given_back(self) -> list[tuple[str, Reason]]:
        return self.handover.given_back

    # --- inputs and outputs ------------------------------------------------------------------------------

    def handle(self, message: object) -> None:
        """Take one validated message (or a :class:`~.protocol.PhysicsResult`)."""
        if isinstance(message, ScanMsg) and message.robot_id == self.robot_id:
            self.navigator.observe_scan(message, defer_localisation=True)
        elif isinstance(message, PositionFixMsg) and message.robot_id == self.robot_id:
            self.navigator.observe_fix(message)
        elif isinstance(message, OdomMsg) and message.robot_id == self.robot_id:
            odom = np.asarray(message.pose_xy_yaw, float)
            if self._last_odom is not None:
                self.distance_m += float(np.hypot(*(odom[:2] - self._last_odom[:2])))
            self._last_odom = odom
            self.navigator.observe_odom(message)
        elif isinstance(message, ComponentPoseMsg):
            self.site_map.observe_pose(message)
        elif isinstance(message, ComponentStateMsg):
            if (state := self.component_states.hear(message)) is not None:
                self._component_state(message.guid, state)
        elif isinstance(message, TwinMsg):
            if (state := self.component_states.take_twin(message)) is not None:
                self._component_state(message.guid, state)
        elif isinstance(message, TaskMsg):
            self._task_kinds[message.task_id] = message.kind
            if message.robot_id == self.robot_id or message.task_id in self.tasks:
                self.tasks[message.task_id] = message
            if message.status is TaskStatus.RELEASED and self.task is None:
                # The planner assigns a released task to a robot it has heard say idle: say it now, not at
                # the next periodic state (1 s of wall time is a minute of sim time on an idle site).
                self.cycle.say_state_soon()
        elif isinstance(message, PhysicsResult):
            self.handover.take_result(message)
        elif isinstance(message, RobotPoseMsg):
            self._ground_truth(message)
        elif isinstance(message, RobotStateMsg) and message.robot_id != self.robot_id:
            self.navigator.observe_robot(message.robot_id, message.pose_xy_yaw[:2], message.sim_time_s)
            x, y = message.pose_xy_yaw[:2]
            self.context.others_xy[message.robot_id] = (float(x), float(y))
            kind = self._task_kinds.get(message.task_id) if message.task_id else None
            note_placing(self.context, message, self.components.get(message.guid or ""), kind)

    def tick(self, clock: ClockMsg, wall_s: float) -> list[Outgoing]:
        """One control step: task progress, navigation, and the ``cmd_vel`` answering ``clock.step``."""
        self.sim_s, self.step, self.context.wall_s = clock.sim_time_s, clock.step, wall_s
        self.site_map.advance(self.sim_s)
        self._progress()
        command = self.navigator.step(self.sim_s)
        goal = self.navigator.goal
        if command.new_path_xy_m is not None and goal is not None:
            path = [(float(x), float(y)) for x, y in command.new_path_xy_m]
            goal_xy = (float(goal.xy[0]), float(goal.xy[1]))
            self.cycle.outbox.append(
                PlanMsg(robot_id=self.robot_id, path_xy_m=path, goal_xy_m=goal_xy, sim_time_s=self.sim_s)
            )
        cmd = CmdVelMsg(
            robot_id=self.robot_id,
            v_mps=command.v_mps,
            w_radps=command.w_radps,
            sim_time_s=self.sim_s,
            step=clock.step,
        )
        return [*self.poll(wall_s), cmd]

    def after_tick(self) -> None:
        """Work that may wait until the step's command is out: the localisation update on the step's scan
        (the robot's heaviest work; run while physics steps the next period, see :mod:`.localisation`)."""
        self.navigator.localise()

    def can_sleep(self) -> bool:
        """Idle with nothing ahead of its own accord (:mod:`bimbot.shared.step_gate`: it may sleep until a
        task message wakes it): no task and none assigned to it waiting to start, standing where it parks,
        nothing left to ask (what it had to say went out with the tick)."""
        return (
            self.task is None
            and self.machine.state is _S.IDLE
            and not assignment_waiting(self.tasks, self.robot_id, self.performed)
            and self.navigator.goal is None
            and (self.parking is None or self.parking.settled())
            and not self.component_states.asking
        )

    def sleeps_until_s(self) -> float | None:
        """The sim time until which it may sleep at work (a kinematic drive's end); None: it may not. A
        robot that steers by its laser answers every step of its drive."""
        return None

    def poll(self, wall_s: float) -> list[Outgoing]:
        """What is due regardless of the clock: a physics request, event (re)sends, the robot's state."""
        self.context.wall_s = wall_s
        cycle, task = self.cycle, self.task
        if task is not None:
            if task.request is not None and not task.request_sent:
                task.request_sent = True
                cycle.outbox.insert(0, task.request)  # before the step's command (physics contract)
            event = task.events.due(wall_s)
            if event is not None:
                cycle.outbox.append(event)
            if task.events.unconfirmed_for_s(wall_s) >= self.config.confirm_ask_s:
                self.component_states.ask(task.message.guid)
        cycle.say_state_if_due(wall_s)
        cycle.outbox.extend(self.component_states.questions(wall_s))
        return cycle.take_outbox()

    def state_message(self, wall_s: float) -> RobotStateMsg:
        return self.cycle.state_message(wall_s)

    # --- the task ----------------------------------------------------------------------------------------

    def _progress(self) -> None:
        if self.task is None:
            self._maybe_start()
            if self.task is None:
                if self.parking is not None:
                    self.parking.step()
                return
        task = self.task
        latest = self.component_states.state(task.message.guid)
        task.events.confirm(latest, verdict_seen=task.verdict is not None)
        if self.handover.ending(task, self.tasks.get(task.message.task_id)):
            return
        stalled_s = self.sim_s - self.cycle.state_since_s
        if stalled_s > self.config.task_timeout_s and task.request is None:
            why = give_back.stalled(self.robot_id, self.machine.state, stalled_s, self.config.task_timeout_s)
            if task.placed:  # nothing to give back: the agent verifies it (its own bound)
                _log.error("%s: no verdict on %s: %s", self.robot_id, task.message.guid, why.message)
                return self.cycle.finish(None)
            return self.handover.give_back(task, why)
        step = {
            _S.DETECT_COMPONENT_POSITION: self._detect,
            _S.PICK_UP: self._pick_up,
            _S.IDENTIFY_TARGET_LOCATION: self._to_target,
            _S.ASSEMBLE: self._assemble,
        }.get(self.machine.state)
        if step is not None:
            step(task)

    def _maybe_start(self) -> None:
        for message in self.tasks.values():
            if message.status is not TaskStatus.ASSIGNED or message.robot_id != self.robot_id:
                continue
            assignment = (message.task_id, message.attempt, message.wall_time_s)
            if assignment in self.performed or message.guid not in self.components:
                continue
            known = self.component_states.state(message.guid)
            expected = _C.FAILED if message.kind is TaskKind.CLEAR else _C.RELEASED
            if known is not None and known is not expected:
                continue  # the assignment is ahead of the component's release: wait for it
            self.performed.add(assignment)
            component = self.components[message.guid]
            target = component.target_pose_world
            footprint = posed_footprint(component, target.position_m, target.quat_xyzw)
            if message.kind is not TaskKind.BUILD and message.put_down_xy_m is not None:
                footprint = put_down_target(self.site_map.layout, message)
            self.cycle.start(Task(message, component, footprint, EventQueue(self.config.resend_s)))
            if self.parking is not None:
                self.parking.task_started()
            self.navigator.cancel()
            self.cycle.fire(Trigger.ASSIGNED)
            _log.info(
                "%s: task %s (%s, attempt %d)", self.robot_id, message.task_id, message.guid, message.attempt
            )
            return

    def _detect(self, task: Task) -> None:
        guid = task.message.guid
        carrier = self.site_map.carried.get(guid)
        if carrier is not None and carrier != self.robot_id:
            # just put down (a hand-off, a give-back): physics' pose saying so may still be on its way
            if task.carried_seen_s is None:
                task.carried_seen_s = self.sim_s
            if self.sim_s - task.carried_seen_s < self.config.carried_wait_s:
                return None
            return self.handover.give_up(
                task, give_back.carried_by(self.robot_id, component_name(task), carrier)
            )
        if self.sim_s < task.retry_at_s:
            return None
        footprint = self.site_map.footprints.get(guid)
        if carrier is None and footprint is None:
            return self.handover.give_up(
                task, give_back.position_unknown(self.robot_id, component_name(task))
            )
        unreachable = self.getting_there.target_cut_off(task)
        if unreachable is not None:
            return self.handover.give_up(task, unreachable)
        if carrier is None and footprint is not None and not self.getting_there.approach(task, footprint):
            return None
        if task.message.kind is not TaskKind.CLEAR:  # a failed component hears of no clear-away
            self.context.queue_event(task, _E.PICK)
        self.cycle.fire(Trigger.LOCATED)
        return None

    def _pick_up(self, task: Task) -> None:
        if self.site_map.carried.get(task.message.guid) == self.robot_id and task.request is None:
            return self.handover.attached(task)  # physics has it on this robot already (a reply got lost)
        if not self.getting_there.drive(task, self.site_map.footprints.get(task.message.guid)):
            return None
        if _E.PICK in task.events.unconfirmed or task.request is not None:
            return None
        attach = AttachRequest(robot_id=self.robot_id, guid=task.message.guid)
        return self.handover.request(task, "attach", attach)

    def _to_target(self, task: Task) -> None:
        if not self.getting_there.drive(task, task.target):
            return
        if task.message.kind is not TaskKind.BUILD:  # at the staging spot or yard slot: put it down there
            if task.request is None and not task.events.unconfirmed & {_E.ATTACH}:
                drop = DropRequest(
                    robot_id=self.robot_id, guid=task.message.guid, near_xy_m=task.message.put_down_xy_m
                )
                self.handover.request(task, "drop", drop)
            return
        self.cycle.fire(Trigger.ARRIVED)
        self.context.queue_event(task, _E.ARRIVE)

    def _assemble(self, task: Task) -> None:
        if not task.placed:
            if task.request is not None and task.request.kind == "place":
                # set down and held while its connection is made (physics answers at the hold's end): its
                # stand-point is not chosen again. On the Revit house r2, holding a panel it had set, found
                # the panel now closed the room it stood in, gave the standing panel back and was walled in
                return
            if not self.getting_there.drive(task, task.target):
                return  # a refused placement sent the robot to another approach pose
            waiting = task.events.unconfirmed & {_E.ATTACH, _E.ARRIVE}
            # standing still, and not told to wait (another robot stands where the load goes)
            ready = self.navigator.ready_to_place and self.sim_s >= task.retry_at_s
            if task.request is None and not waiting and ready and not self._would_shut_in(task):
                self.handover.request(task, "place", self.handover.place_request(task))
            return
        if task.verdict is not None and _E.PLACE not in task.events.unconfirmed:
            _log.info("%s: %s %s", self.robot_id, task.message.guid, task.verdict.value)
            self.cycle.finish(task.verdict)

    # --- helpers -----------------------------------------------------------------------------------------

    def _would_shut_in(self, task: Task) -> bool:
        """Whether the placement waits: it would shut another robot in (:func:`.shut_in_check.held`)."""
        return held(self.context, task, self.config)

    def _component_state(self, guid: str, state: ComponentState) -> None:
        """A trusted state change (a judged message, or a twin's answer)."""
        self.site_map.observe_state(guid, state, self.sim_s)
        task = self.task
        if task is not None and task.placed and guid == task.message.guid and state in VERDICTS:
            task.verdict = state  # kept: a retry may move the state on before the next tick

    def _ground_truth(self, message: RobotPoseMsg) -> None:
        """Physics' ground truth of this robot: its localisation error, a metric for the logs and the
        benchmarks, never used for control."""
        if message.robot_id != self.robot_id:
            return
        x, y, _ = message.pose_xy_yaw
        believed = self.navigator.pose_xy_yaw
        self.localisation_error_m = math.hypot(believed[0] - x, believed[1] - y)
        self.max_localisation_error_m = max(self.max_localisation_error_m, self.localisation_error_m)


class CraneExecutor(Executor):
    """The executor of a tower crane: the same task cycle, with reach checks instead of driving, a lift
    that lasts what the crane's motion takes, and no parking (it stays where it stands)."""

    def _handover(self) -> Handover:
        return CraneHandover(self.context, self.cycle)

    def _getting_there(self) -> GettingThere:
        return CraneReach(self.context, self.handover)

    def _parking(self) -> Parking | None:
        return None


def executor_class(info: SiteInfoMsg, robot_id: str) -> type[Executor] | type[SiteWorkExecutor]:
    """The executor of a robot's capabilities: work in place (pour, lay, pile), lifting by hook, or
    carrying."""
    description = info.robot_types[info.robot_type_of[robot_id]]
    if any(description.can(work) for work in WORK_METHOD):
        return SiteWorkExecutor
    return CraneExecutor if description.can(Capability.HOOK_LIFT) else Executor
