"""The robot's Zenoh adapter: one session around an :class:`~.executor.Executor`, paced by the sim clock.

Start-up, in order (nothing is ticked before the liveliness token, so lock-step physics never waits on a
robot that is still loading):

1. subscribe (callbacks only enqueue, :class:`bimbot.shared.bus.Inbox`): ``tasks/*``, ``components/*/state``,
   ``components/*/pose``, this robot's ``sensors`` (the clock step with its odometry and scan, one message a
   period), every robot's ``state`` (the other robots' pose estimates, for the traffic rules) and its own
   ``pose`` (ground truth, **only** for the localisation error that is logged; never used for control);
2. ask physics for the site (``get physics/info``, retried until it answers): robot ids, start poses, the
   control period and the reach;
3. build the executor (map, localiser at the start pose), its compiled kernels (A*, laser model) loaded;
4. declare ``alive/robot/<id>``.

Loop: drain the inbox into the executor; for each new clock step (it comes with the step's odometry and
scan), tick: the ``cmd_vel`` of every step is answered, whatever the task is doing; then the work that can
wait until the answer is out (:meth:`~.executor.Executor.after_tick`). Between steps
:meth:`~.executor.Executor.poll` re-sends events and the ~1 Hz state. Physics requests never block:
``session.get`` with a callback that enqueues the reply (and a drop callback that enqueues "no reply").
Requests are published before the step's ``cmd_vel``, as the physics contract asks for reproducible
lock-step runs.
"""

from __future__ import annotations

import logging
import threading
import time
from dataclasses import dataclass

import zenoh

from bimbot.shared.bus import (
    Answer,
    BusOptions,
    Inbox,
    Received,
    decode,
    encode,
    open_session,
    query_first,
)
from bimbot.shared.clock_guard import ClockGuard, Verdict
from bimbot.shared.component_states import TwinQuestion
from bimbot.shared.identifiers import guid_to_key
from bimbot.shared.keyspace import Topic
from bimbot.shared.messages import (
    ALIVE_KEY,
    COMPONENT_EVENT_KEY,
    COMPONENT_POSE,
    COMPONENT_STATE,
    PHYSICS_ATTACH,
    PHYSICS_BUILD,
    PHYSICS_DROP,
    PHYSICS_INFO,
    PHYSICS_PLACE,
    PHYSICS_POSES,
    PHYSICS_RELOCATE,
    ROBOT_CMD_VEL_KEY,
    ROBOT_PLAN_KEY,
    ROBOT_POSE,
    ROBOT_SENSORS,
    ROBOT_STATE,
    ROBOT_STATE_KEY,
    TASK,
    ClockMsg,
    CmdVelMsg,
    ComponentEventMsg,
    PlanMsg,
    RobotStateMsg,
    SensorsMsg,
    SitePosesMsg,
    TwinMsg,
    key,
)
from bimbot.shared.period_times import PeriodTimes
from bimbot.shared.service_runner import BuildInput
from bimbot.shared.twin_query import answered_on_its_key, ask_twin, ask_twins

from .executor import ExecutorConfig, executor_class
from .plan_executor import plan_executor_class
from .protocol import Outgoing, PhysicsRequest, PhysicsResult, RobotExecutor
from .stepped import SteppedTicks

_log = logging.getLogger(__name__)

SUBSCRIPTIONS: tuple[tuple[Topic, dict[str, str]], ...] = (
    (TASK, {"task_id": "*"}),
    (COMPONENT_STATE, {"key": "*"}),
    (COMPONENT_POSE, {"key": "*"}),
    (ROBOT_STATE, {"robot_id": "*"}),
)
STEPPED_REQUEST_TIMEOUT_S = 900.0  # wall seconds a lock-step robot waits for physics' reply (a hang)
POSES_TIMEOUT_S = 5.0  # wall seconds to ask physics where this robot is (at start)
TWINS_TIMEOUT_S = 5.0  # wall seconds to collect the twins' answers (at start)
_PHYSICS_REQUESTS = {
    "attach": PHYSICS_ATTACH,
    "place": PHYSICS_PLACE,
    "drop": PHYSICS_DROP,
    "build": PHYSICS_BUILD,
    "relocate": PHYSICS_RELOCATE,
}


@dataclass(frozen=True)
class RobotOptions:
    info_timeout_s: float = 120.0  # wall seconds to wait for physics to answer physics/info
    poll_s: float = 0.02  # longest wait for bus input per loop turn
    metric_log_s: float = 30.0  # wall seconds between progress lines (tasks, distance, localisation)
    # a lock-step participant whose inputs are taken at defined steps (:mod:`.stepped`; bimbot run)
    stepped: bool = False
    fidelity: str = "physics"  # or "plan": a robot that drives moves along its timed path (.plan_executor)


def main(
    bus: BusOptions,
    build: BuildInput,
    options: RobotOptions,
    executor_config: ExecutorConfig,
    stop: threading.Event,
) -> int:
    """Run one robot on the bus until ``stop``; 0 on a clean stop, 2 when physics never answered."""
    manifest = build.manifest
    site, robot_id = manifest.site, executor_config.robot_id
    inbox = Inbox(in_order=True)
    with open_session(bus) as session:
        subscribers = [inbox.subscribe(session, topic, site=site, **parts) for topic, parts in SUBSCRIPTIONS]
        subscribers += [
            inbox.subscribe(session, ROBOT_SENSORS, site=site, robot_id=robot_id),
            inbox.subscribe(session, ROBOT_POSE, site=site, robot_id=robot_id),  # its localisation metric
        ]
        info = query_first(
            session, PHYSICS_INFO, inbox.invalid, timeout_s=options.info_timeout_s, stop=stop, site=site
        )
        if info is None:
            return 0 if stop.is_set() else _no_physics(options.info_timeout_s)
        poses = query_first(session, PHYSICS_POSES, inbox.invalid, timeout_s=POSES_TIMEOUT_S, site=site)
        chosen = plan_executor_class if options.fidelity == "plan" else executor_class
        executor = chosen(info, robot_id)(
            manifest, info, executor_config, start_xy_yaw=_where_physics_has(poses, robot_id)
        )
        _learn_the_site(session, inbox, site, executor, poses)
        keys = {component.guid: component.key for component in manifest.components}
        stepped = keys if options.stepped and info.lock_step else None
        participants = list(info.lock_step_participants)
        loop = _Loop(session, site, executor, inbox, options, stepped=stepped, participants=participants)
        token = session.liveliness().declare_token(key(ALIVE_KEY, site=site, kind="robot", id=robot_id))
        _log.info(
            "robot %s on site %s: start %s, reach %.2f m",
            robot_id,
            site,
            executor.home_xy_yaw,
            info.robot_types[info.robot_type_of[robot_id]].reach_m,
        )
        try:
            loop.run(stop)
        finally:
            loop.publish([CmdVelMsg(robot_id=robot_id, v_mps=0.0, w_radps=0.0, sim_time_s=executor.sim_s)])
            token.undeclare()
            for subscriber in subscribers:
                subscriber.undeclare()
            loop.log_metrics("stopped")
    return 0


def _where_physics_has(poses: SitePosesMsg | None, robot_id: str) -> tuple[float, float, float] | None:
    """This robot's pose by physics (a robot restarted mid-build starts where its body is, not at the
    depot); None when physics does not say (the depot start then)."""
    robot = poses.robots.get(robot_id) if poses is not None else None
    return robot.pose_xy_yaw if robot is not None else None


def _learn_the_site(
    session: zenoh.Session, inbox: Inbox, site: str, executor: RobotExecutor, poses: SitePosesMsg | None
) -> None:
    """What a robot joining late must know before it acts: every component's state (its twin's last record)
    and pose (``poses``, physics' answer), so it neither plans through a placed column nor waits for a
    change that happened before it started."""
    twins = 0
    for twin in ask_twins(session, site, TWINS_TIMEOUT_S, inbox.invalid):
        if twin.history:
            executor.handle(twin)
            twins += 1
    for pose in poses.components.values() if poses is not None else ():
        executor.handle(pose)
    _log.info("%s learnt the state of %d component(s) from their twins", executor.robot_id, twins)


def _no_physics(timeout_s: float) -> int:
    _log.error("physics did not answer physics/info within %.0f s (is `bimbot physics` running?)", timeout_s)
    return 2


class _Loop:
    """Inbox → executor → bus, one ``cmd_vel`` per clock step."""

    def __init__(
        self,
        session: zenoh.Session,
        site: str,
        executor: RobotExecutor,
        inbox: Inbox,
        options: RobotOptions,
        *,
        stepped: dict[str, str] | None = None,
        participants: list[str] | None = None,
    ):
        """``stepped``: a lock-step participant (:mod:`.stepped`), with every component's bus key."""
        self.session, self.site, self.executor, self.inbox, self.options = (
            session,
            site,
            executor,
            inbox,
            options,
        )
        robot_id = executor.robot_id
        self._keys: dict[type, str] = {
            CmdVelMsg: key(ROBOT_CMD_VEL_KEY, site=site, robot_id=robot_id),
            RobotStateMsg: key(ROBOT_STATE_KEY, site=site, robot_id=robot_id),
            PlanMsg: key(ROBOT_PLAN_KEY, site=site, robot_id=robot_id),
        }
        self._publishers = {
            kind: session.declare_publisher(key_expr) for kind, key_expr in self._keys.items()
        }
        self._clock: ClockMsg | None = None
        self._sensors_wall_s = 0.0  # when this step's sensors were taken from the inbox
        self._answered_step = -1
        self.times = PeriodTimes()  # per step: sensors to answer, work after the answer
        self.clock_guard = ClockGuard(f"robot {robot_id} clock")
        self._metrics_wall_s = time.monotonic()
        self.stepped = (
            SteppedTicks(executor, self.publish, self._answered, stepped, participants or [])
            if stepped
            else None
        )

    def _answered(self) -> None:
        self.times.add("answer", time.monotonic() - self._sensors_wall_s)
        self.times.period()

    def run(self, stop: threading.Event) -> None:
        if self.stepped is not None:
            self._run_stepped(stop)
            return
        while not stop.is_set():
            for item in self.inbox.drain(first_timeout_s=self.options.poll_s):
                self._take(item)
            now = time.monotonic()
            clock = self._clock
            if clock is not None and clock.step > self._answered_step:
                self._answered_step = clock.step
                self.publish(self.executor.tick(clock, time.time()))
                answered = time.monotonic()
                self.times.add("answer", answered - self._sensors_wall_s)
                self.executor.after_tick()  # while physics steps the next period
                self.times.add("after", time.monotonic() - answered)
                self.times.period()
            else:
                self.publish(self.executor.poll(time.time()))
            if now - self._metrics_wall_s >= self.options.metric_log_s:
                self._metrics_wall_s = now
                self.log_metrics("progress")

    def _run_stepped(self, stop: threading.Event) -> None:
        """Every clock step ticked in order, with the inputs of a defined step (:mod:`.stepped`)."""
        stepped = self.stepped
        assert stepped is not None
        try:
            while not stop.is_set():
                for item in self.inbox.drain(
                    first_timeout_s=self.options.poll_s if not stepped.steps else 0.0
                ):
                    if isinstance(item, Received) and isinstance(item.message, SensorsMsg):
                        clock = item.message.clock
                        verdict = self.clock_guard.check(clock, time.monotonic())
                        if verdict is Verdict.OLD:  # physics says a step again: say the last answer again
                            stepped.answer_again()
                        if not verdict.accepted:
                            continue
                        self._sensors_wall_s = time.monotonic()
                    if not stepped.hear(item):
                        self._take(item)
                stepped.tick_ready()
                now = time.monotonic()
                if now - self._metrics_wall_s >= self.options.metric_log_s:
                    self._metrics_wall_s = now
                    self.log_metrics("progress")
        finally:
            stepped.finish()

    def _take(self, item: object) -> None:
        match item:
            case PhysicsResult():
                self.executor.handle(item)
            case Received(message=SensorsMsg() as sensors):
                clock = sensors.clock
                verdict = self.clock_guard.check(clock, time.monotonic())
                if verdict is Verdict.RESTARTED:  # physics restarted: answer its steps from here
                    self._answered_step = min(self._answered_step, clock.step - 1)
                if verdict.accepted:
                    self._clock, self._sensors_wall_s = clock, time.monotonic()
                    self.executor.handle(sensors.odom)
                    if sensors.fix is not None:  # before the scan: fused with it
                        self.executor.handle(sensors.fix)
                    if sensors.scan is not None:  # a crane has no laser
                        self.executor.handle(sensors.scan)
            case Answer(key=reply_key, message=TwinMsg() as twin):
                if answered_on_its_key(self.site, reply_key, twin):
                    self.executor.handle(twin)
                else:
                    self.inbox.invalid.record(reply_key, "a twin answered on another component's key")
            case Received(message=message):
                self.executor.handle(message)

    def publish(self, messages: list[Outgoing]) -> None:
        """Physics requests first, then events, state and plan, and the step's ``cmd_vel`` last (saying how
        many requests went before it)."""
        requests = sum(isinstance(message, PhysicsRequest) for message in messages)
        for item in sorted(messages, key=_send_order):
            message: Outgoing = item
            if requests and isinstance(item, CmdVelMsg) and item.step is not None:
                message = item.model_copy(update={"requests": requests})
            if isinstance(message, PhysicsRequest):
                self._request(message)
            elif isinstance(message, TwinQuestion):  # a state message that did not fit: ask the truth
                ask_twin(self.inbox, self.session, self.site, message.key)
            elif isinstance(message, ComponentEventMsg):
                event_key = key(COMPONENT_EVENT_KEY, site=self.site, key=guid_to_key(message.guid))
                self.session.put(event_key, encode(message))
            elif self.stepped is not None:  # in order with everything else it puts (see physics' _publish)
                self.session.put(self._keys[type(message)], encode(message))
            else:
                self._publishers[type(message)].put(encode(message))

    def _request(self, request: PhysicsRequest) -> None:
        inbox, request_id = self.inbox, request.request_id
        served = _PHYSICS_REQUESTS[request.kind]
        selector = served.key(site=self.site)
        replied = False

        def on_reply(reply: zenoh.Reply) -> None:
            nonlocal replied
            replied = True
            if reply.ok is None:
                error = reply.err.payload.to_string() if reply.err is not None else "error reply"
                inbox.put(PhysicsResult(request_id, None, error))
                return
            message = decode(served.reply, selector, reply.ok.payload.to_bytes(), inbox.invalid)
            inbox.put(PhysicsResult(request_id, message, "" if message else "invalid reply"))

        def on_done() -> None:  # the query is over: a result only when nothing came (a lock-step robot
            if not replied:  # takes a reply at the step after physics', so "none" must not overtake it)
                inbox.put(PhysicsResult(request_id, None, "no reply (timeout)"))

        handler = zenoh.handlers.Callback(on_reply, on_done, indirect=False)  # in order with the sensors
        # stamped with the step this robot answers: physics acts on it with that step's command (latency)
        message = request.message.model_copy(update={"step": max(0, self.executor.step)})
        # lock-step: physics answers in sim time (a placement with its connection takes 20 s of it), which
        # a loaded machine stretches; a wall-clock timeout would decide the task by the machine's load
        timeout_s = max(request.timeout_s, STEPPED_REQUEST_TIMEOUT_S) if self.stepped else request.timeout_s
        self.session.get(selector, handler, payload=encode(message), timeout=timeout_s)

    def log_metrics(self, when: str) -> None:
        executor = self.executor
        _log.info(
            "robot %s %s: %d task(s) done, %.1f m driven, sim %.1f s, "
            "localisation error %.2f m now, %.2f m at most (metrics only); wall time: %s",
            executor.robot_id,
            when,
            len(executor.done),
            executor.distance_m,
            executor.sim_s,
            executor.localisation_error_m,
            executor.max_localisation_error_m,
            self.times.take(),
        )


def _send_order(message: Outgoing) -> int:
    if isinstance(message, PhysicsRequest):
        return 0
    return 2 if isinstance(message, CmdVelMsg) else 1
