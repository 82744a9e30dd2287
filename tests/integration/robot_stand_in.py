"""A test peer in the robot's (and the physics') role: performs construction tasks purely over the bus.

It announces itself with liveliness and an ``idle`` state, publishes a sim clock, takes tasks assigned to
it, drives the component through ``pick → attach → arrive → place`` (publishing the component's pose as
physics would: carried, then at its target, optionally with an injected error) and waits for the
component's verdict before going idle again. Events are sent at least once: repeated with the same
``event_id`` until the component's state shows them applied, so an agent process that is down for a
while loses nothing. What it waits for is looked up in every state published since it sent the event,
not only in the latest: a misplacement's ``verifying``, ``misplaced`` and (on the planner's retry)
``released`` can arrive together, and then the latest has already moved past what the robot waits for.
"""

from __future__ import annotations

import threading
import time
import uuid
from collections import defaultdict
from dataclasses import dataclass, field

import numpy as np
import zenoh
from wall_clock import bound_s

from bimbot.shared.bus import BusOptions, encode, open_session
from bimbot.shared.identifiers import guid_to_key
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import (
    ALIVE_KEY,
    CLOCK_KEY,
    COMPONENT_EVENT_KEY,
    COMPONENT_POSE_KEY,
    COMPONENT_STATE_KEY,
    ROBOT_STATE_KEY,
    TASK_KEY,
    ClockMsg,
    ComponentEvent,
    ComponentEventMsg,
    ComponentPoseMsg,
    ComponentState,
    ComponentStateMsg,
    PoseMsg,
    RobotState,
    RobotStateMsg,
    TaskMsg,
    TaskStatus,
    key,
)

EXPECTED_AFTER = {
    ComponentEvent.PICK: {ComponentState.PICKING},
    ComponentEvent.ATTACH: {ComponentState.TRANSPORTING},
    ComponentEvent.ARRIVE: {ComponentState.ASSEMBLING},
    ComponentEvent.PLACE: {
        ComponentState.VERIFYING,
        ComponentState.CONSTRUCTED,
        ComponentState.MISPLACED,
        ComponentState.FAILED,
    },
}
VERDICTS = {ComponentState.CONSTRUCTED, ComponentState.MISPLACED, ComponentState.FAILED}


@dataclass
class StandInRecord:
    """What the stand-in saw, for the test's assertions."""

    states: list[ComponentStateMsg] = field(default_factory=list)
    tasks_done: list[str] = field(default_factory=list)
    placements: dict[str, int] = field(default_factory=lambda: defaultdict(int))


class RobotStandIn:
    """``robot_ids`` robots sharing one session; each works on its own thread."""

    def __init__(
        self,
        manifest: Manifest,
        options: BusOptions,
        robot_ids: tuple[str, ...] = ("r1",),
        *,
        misplace_first_attempt: frozenset[str] = frozenset(),
        misplace_always: frozenset[str] = frozenset(),
        sim_seconds_per_wall_second: float = 20.0,
        resend_s: float = 0.5,
    ) -> None:
        self.manifest = manifest
        self.site = manifest.site
        self.options = options
        self.robot_ids = robot_ids
        self.misplace_first_attempt = misplace_first_attempt
        self.misplace_always = misplace_always
        self.rate = sim_seconds_per_wall_second
        self.resend_s = resend_s
        self.record = StandInRecord()
        self.stop = threading.Event()
        self._latest: dict[str, ComponentStateMsg] = {}
        self._changed = threading.Condition()
        self._tasks: dict[str, TaskMsg] = {}  # latest message per task id
        self._performed: set[tuple[str, str, int]] = set()  # (robot, task, attempt)
        self._started = time.monotonic()
        self._threads: list[threading.Thread] = []
        self._session: zenoh.Session | None = None

    # --- life cycle ---

    def __enter__(self) -> RobotStandIn:
        self._session = open_session(self.options)
        self._subscribers = [
            self._session.declare_subscriber(
                key(COMPONENT_STATE_KEY, site=self.site, key="*"), self._on_state
            ),
            self._session.declare_subscriber(key(TASK_KEY, site=self.site, task_id="*"), self._on_task),
        ]
        self._tokens = [
            self._session.liveliness().declare_token(
                key(ALIVE_KEY, site=self.site, kind="robot", id=robot_id)
            )
            for robot_id in self.robot_ids
        ]
        self._threads = [threading.Thread(target=self._clock_loop, daemon=True)]
        self._threads += [
            threading.Thread(target=self._robot_loop, args=(rid,), daemon=True) for rid in self.robot_ids
        ]
        for thread in self._threads:
            thread.start()
        return self

    def __exit__(self, *_: object) -> None:
        self.stop.set()
        with self._changed:
            self._changed.notify_all()
        for thread in self._threads:
            thread.join(timeout=bound_s(5))
        for token in self._tokens:
            token.undeclare()
        assert self._session is not None
        self._session.close()

    def sim_time(self) -> float:
        return (time.monotonic() - self._started) * self.rate

    # --- callbacks: record and notify only ---

    def _on_state(self, sample: zenoh.Sample) -> None:
        try:
            message = ComponentStateMsg.model_validate_json(sample.payload.to_bytes())
        except ValueError:
            return
        self.record_state(message)

    def record_state(self, message: ComponentStateMsg) -> None:
        """Record ``message`` and wake the robots that wait for a state."""
        with self._changed:
            self.record.states.append(message)
            self._latest[message.guid] = message
            self._changed.notify_all()

    def _on_task(self, sample: zenoh.Sample) -> None:
        try:
            task = TaskMsg.model_validate_json(sample.payload.to_bytes())
        except ValueError:
            return
        with self._changed:
            self._tasks[task.task_id] = task
            self._changed.notify_all()

    # --- loops ---

    def _clock_loop(self) -> None:
        step = 0
        while not self.stop.wait(0.05):
            step += 1
            self._put(
                key(CLOCK_KEY, site=self.site),
                ClockMsg(sim_time_s=self.sim_time(), step=step, real_time_factor=self.rate),
            )

    def _robot_loop(self, robot_id: str) -> None:
        pose = (float(self.robot_ids.index(robot_id)) * 2.0 - 10.0, -10.0, 0.0)
        last_state = 0.0
        while not self.stop.is_set():
            with self._changed:
                task = self._next_task(robot_id)
                if task is None:
                    self._changed.wait(timeout=0.2)
            if task is None:
                if time.monotonic() - last_state > 0.3:  # keep announcing idle (late subscribers, restarts)
                    self._robot_state(robot_id, RobotState.IDLE, None, pose)
                    last_state = time.monotonic()
                continue
            self._performed.add((robot_id, task.task_id, task.attempt))
            self._perform(robot_id, task, pose)

    def _next_task(self, robot_id: str) -> TaskMsg | None:
        """A task whose latest message assigns it to this robot, not yet performed at this attempt."""
        for task in self._tasks.values():
            if task.status != TaskStatus.ASSIGNED or task.robot_id != robot_id:
                continue
            if (robot_id, task.task_id, task.attempt) in self._performed:
                continue
            state = self._latest.get(task.guid)
            if state is None or state.state == ComponentState.RELEASED:
                return task
        return None

    def _perform(self, robot_id: str, task: TaskMsg, pose: tuple[float, float, float]) -> None:
        component = self.manifest.component(task.guid)
        target = component.target_pose_world
        self._robot_state(robot_id, RobotState.DETECT_COMPONENT_POSITION, task, pose)
        if not self._send(robot_id, task, ComponentEvent.PICK):
            return
        self._robot_state(robot_id, RobotState.PICK_UP, task, pose)
        carried = PoseMsg(position_m=(pose[0], pose[1], 0.5), quat_xyzw=(0.0, 0.0, 0.0, 1.0))
        self._pose(task.guid, carried, attached_to=robot_id)
        if not self._send(robot_id, task, ComponentEvent.ATTACH):
            return
        self._robot_state(robot_id, RobotState.IDENTIFY_TARGET_LOCATION, task, pose)
        if not self._send(robot_id, task, ComponentEvent.ARRIVE):
            return
        self._robot_state(robot_id, RobotState.ASSEMBLE, task, pose)
        self.record.placements[task.guid] += 1
        attempt = self.record.placements[task.guid]
        offset = np.zeros(3)
        if task.guid in self.misplace_always or (task.guid in self.misplace_first_attempt and attempt == 1):
            offset = np.array([0.05, 0.0, 0.0])  # 5 cm off: beyond the agent's position tolerance
        placed = PoseMsg(position_m=tuple(np.array(target.position_m) + offset), quat_xyzw=target.quat_xyzw)
        self._pose(task.guid, placed, fixed=True)
        placing = self.mark()
        if not self._send(robot_id, task, ComponentEvent.PLACE):
            return
        verdict = self.wait_for(task.guid, VERDICTS, since=placing, timeout_s=bound_s(60.0))
        if verdict is not None and verdict.state == ComponentState.CONSTRUCTED:
            self.record.tasks_done.append(task.guid)
        self._robot_state(robot_id, RobotState.IDLE, None, pose)

    # --- bus helpers ---

    def _send(self, robot_id: str, task: TaskMsg, event: ComponentEvent) -> bool:
        """Send until the component's state shows the event applied (same event_id each time)."""
        message = ComponentEventMsg(
            guid=task.guid,
            event=event,
            source=robot_id,
            event_id=uuid.uuid4().hex,
            task_id=task.task_id,
            robot_id=robot_id,
            sim_time_s=self.sim_time(),
            wall_time_s=time.time(),
        )
        sent = self.mark()
        deadline = time.monotonic() + bound_s(60.0)
        while not self.stop.is_set() and time.monotonic() < deadline:
            self._put(key(COMPONENT_EVENT_KEY, site=self.site, key=guid_to_key(task.guid)), message)
            if self.wait_for(task.guid, EXPECTED_AFTER[event], since=sent, timeout_s=self.resend_s):
                return True
        return False

    def mark(self) -> int:
        """Where the record of states stands now: :meth:`wait_for` looks at what was published after it."""
        with self._changed:
            return len(self.record.states)

    def wait_for(
        self, guid: str, states: set[ComponentState], *, since: int, timeout_s: float
    ) -> ComponentStateMsg | None:
        """The first state of ``guid`` in ``states`` published since the :meth:`mark` ``since``; None when
        none came within ``timeout_s`` (or the stand-in stops)."""
        deadline = time.monotonic() + timeout_s
        with self._changed:
            while not self.stop.is_set():
                for message in self.record.states[since:]:
                    if message.guid == guid and message.state in states:
                        return message
                since = len(self.record.states)  # the ones looked at did not match
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    return None
                self._changed.wait(timeout=remaining)
        return None

    def _pose(self, guid: str, pose: PoseMsg, *, attached_to: str | None = None, fixed: bool = False) -> None:
        message = ComponentPoseMsg(
            guid=guid, pose=pose, sim_time_s=self.sim_time(), attached_to=attached_to, fixed=fixed
        )
        self._put(key(COMPONENT_POSE_KEY, site=self.site, key=guid_to_key(guid)), message)

    def _robot_state(
        self, robot_id: str, state: RobotState, task: TaskMsg | None, pose: tuple[float, float, float]
    ) -> None:
        message = RobotStateMsg(
            robot_id=robot_id,
            state=state,
            task_id=task.task_id if task else None,
            guid=task.guid if task else None,
            pose_xy_yaw=pose,
            sim_time_s=self.sim_time(),
            wall_time_s=time.time(),
        )
        self._put(key(ROBOT_STATE_KEY, site=self.site, robot_id=robot_id), message)

    def _put(self, key_expr: str, message: object) -> None:
        assert self._session is not None
        self._session.put(key_expr, encode(message))  # type: ignore[arg-type]
