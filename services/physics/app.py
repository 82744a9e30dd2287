"""The physics Zenoh adapter: one session around a :class:`.simulation.Simulation`, paced by the sim clock.

Declared on the session (callbacks only enqueue into a :class:`bimbot.shared.bus.Inbox`; the loop changes
state):

* subscriber ``bimbot/<site>/robots/*/cmd_vel`` (CmdVelMsg; a command whose key names another robot than
  its ``robot_id`` is counted invalid; robots physics did not spawn are ignored, logged once);
* liveliness subscriber ``bimbot/<site>/alive/robot/*``: a robot that disappears (for ``lost_grace_s``)
  stops and drops its load;
* subscriber ``bimbot/<site>/components/*/state`` (ComponentStateMsg): a component its agent declared
  constructed can no longer be attached (a misplaced one can, for its retry). Each message is judged as the
  robots and ``bimbot run`` judge it (:mod:`bimbot.shared.component_states`): a
  terminal claim, or a message that does not follow, is asked of the component's twin (``get
  components/<key>/twin``, answered through the inbox) and only the twin's answer is acted on;
* queryables ``physics/info`` (SiteInfoMsg), ``physics/attach`` (AttachRequest → PhysicsReply),
  ``physics/drop`` (DropRequest → PhysicsReply: a robot that cannot deliver its load puts it down) and
  ``physics/place`` (PlaceRequest → PhysicsReply), ``physics/build`` (BuildRequest → PhysicsReply: a
  component built where it stands), ``physics/relocate`` (SetUpRequest → PhysicsReply: a truck-mounted
  machine set up at another of its set-up positions) and ``physics/skip`` (SkipRequest → PhysicsReply:
  the clock jumps over a quiet site). The loop answers them; a place reply is held back
  until the assembly motion ends (a querier's timeout must exceed ``duration_s`` / rtf). An invalid
  payload is counted and answered ``ok=False`` with the reason;
* liveliness token ``bimbot/<site>/alive/physics/main``.

Loop: publish step 0 (clock, sensors, every component), then repeatedly — drain the inbox; in lock-step,
wait until every alive robot that is not busy placing has answered the open clock step (a CmdVelMsg with
``step >= k``) or ``lock_step_timeout_s`` passed (warn, go on with the last commands); wait for the
real-time factor's due time (``rtf`` 0: no wait); advance one control period; publish; reply to finished
placements. For reproducible lock-step runs, a robot sends its attach/place request *before* its command
for that step and counts it there (``CmdVelMsg.requests``), the planner its skip request before its answer
(``StepDoneMsg.requests``); physics does not advance past the request's turn before it came. A robot
waiting for a place reply need not answer clock steps meanwhile: it holds still and is not waited for.
While the lock-step waits, the open step's clock and sensors go out again every ``REANNOUNCE_S``: a
participant that (re)started, or that a router restart cut off, missed them and answers only a step it
hears (the others ignore a step heard twice and say their last answer again), so a restart costs its own
start-up, not the wait's bound.
"""

from __future__ import annotations

import itertools
import logging
import math
import threading
import time
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import zenoh
from pydantic import BaseModel

from bimbot.shared.bus import (
    Answer,
    BusOptions,
    Inbox,
    IncomingQuery,
    InvalidPayloads,
    LivelinessChange,
    Received,
    decode,
    encode,
    open_session,
)
from bimbot.shared.component_states import ComponentStates
from bimbot.shared.messages import (
    ALIVE_KEY,
    COMPONENT_EVENT,
    COMPONENT_STATE,
    PHYSICS_ATTACH,
    PHYSICS_BUILD,
    PHYSICS_DROP,
    PHYSICS_INFO,
    PHYSICS_PLACE,
    PHYSICS_POSES,
    PHYSICS_RELOCATE,
    PHYSICS_SKIP,
    PLANNER_PREPARING,
    ROBOT_CMD_VEL,
    ROBOT_PLAN,
    ROBOT_STATE,
    STEP_DONE,
    TASK,
    AttachRequest,
    BuildRequest,
    ClockMsg,
    CmdVelMsg,
    ComponentState,
    ComponentStateMsg,
    DropRequest,
    PhysicsReply,
    PlaceRequest,
    PreparingMsg,
    SensorsMsg,
    SetUpRequest,
    SkipRequest,
    StepDoneMsg,
    TwinMsg,
    key,
)
from bimbot.shared.period_times import PeriodTimes
from bimbot.shared.service_runner import BuildInput
from bimbot.shared.step_gate import DELAY_STEPS
from bimbot.shared.twin_query import answered_on_its_key, ask_twin, ask_twins

from .clock import LockStepBarrier, Pacer, RtfMeter
from .latency import Pipeline
from .outbox import bundle
from .plan_fidelity import PlanSimulation, simulation_class
from .profiles import FINE
from .restore import restore_site
from .simulation import Outgoing, SimConfig, Simulation
from .sleepers import Sleepers
from .snapshot import SnapshotRecorder, load_snapshot
from .stepped_states import SteppedStates

_log = logging.getLogger(__name__)

TWINS_TIMEOUT_S = 10.0  # a restarted physics asks the agents what is constructed, this long at most
LOOP_WAIT_S = 0.05  # longest blocking wait, so a stop request is seen quickly
STATUS_EVERY_S = 30.0
REANNOUNCE_S = 1.0  # wall s a lock-step wait lasts before the open step's clock and sensors go out again


@dataclass(frozen=True)
class RunConfig:
    rtf: float = FINE.rtf  # real-time factor; 0: as fast as possible
    # a robot alive but silent this long (wall s) is left behind: long enough for ten robot processes on two
    # cores to plan at once (2 s was not), short of a hang
    lock_step_timeout_s: float = 10.0
    max_steps: int | None = None  # stop after this many control periods (benches, tests)
    gui: bool = False
    # hold the clock at 0 until every robot is alive (at most this long)
    wait_for_robots_s: float = FINE.wait_for_robots_s
    # also until the planner is alive (within the same bound): its start-up (the access check of the plan,
    # 20 s of wall time on a 988-component site) is not sim time, and the idle site would step meanwhile
    wait_for_planner: bool = False
    state_dir: Path | None = None  # where physics keeps its record of the site (None: no record, no restart)
    # lock-step participants besides the robots (the planner, each agents shard: StepDoneMsg), waited for
    # like a robot until they say they are done, so what they decide happens at the same step in every run
    step_with: tuple[str, ...] = ()
    # a robot whose liveliness went stays on site this long (wall s), still waited for in lock-step and still
    # holding its load, before it is stopped and its load dropped: a site across hosts rides out a link or
    # router that is down for seconds; 0 (one host: a lost robot is a dead process): at once
    lost_grace_s: float = 0.0
    fidelity: str = "physics"  # or "plan": kinematic robots, a clock that jumps by events (.plan_fidelity)


def main(
    options: BusOptions,
    build: BuildInput,
    sim_config: SimConfig,
    run: RunConfig,
    stop: threading.Event,
) -> int:
    """Build the scene and serve it on the bus until ``stop`` is set; 0 on a clean stop.

    With ``run.state_dir``, physics keeps its record of the site there (:mod:`.snapshot`) and, when it finds
    one left by an earlier physics of this run, continues from it (:mod:`.restore`)."""
    with (
        simulation_class(run.fidelity)(build.manifest, build.dir, sim_config, gui=run.gui) as sim,
        open_session(options) as session,
    ):
        recorder, twins = None, []
        if run.state_dir is not None:
            snapshot = load_snapshot(run.state_dir)
            if snapshot is not None:
                twins = ask_twins(session, sim.site, TWINS_TIMEOUT_S)
                _log.info("%d twin(s) answered", len(twins))
                restore_site(sim, snapshot, twins)
            recorder = SnapshotRecorder(run.state_dir, sim.epoch)
        try:
            loop = _Loop(session, sim, run, stop, recorder)
            for twin in twins:  # what a restarted physics learnt from the twins is what it trusts
                loop.states.take_twin(twin)
            loop.serve()
        finally:
            if recorder is not None:
                recorder.close()
    return 0


class _Loop:
    def __init__(
        self,
        session: zenoh.Session,
        sim: Simulation,
        run: RunConfig,
        stop: threading.Event,
        recorder: SnapshotRecorder | None = None,
    ) -> None:
        self.recorder = recorder
        self.session = session
        self.sim = sim
        self.run = run
        self.stop = stop
        self.site = sim.site
        self.inbox = Inbox(InvalidPayloads(), in_order=True)
        self.barrier = LockStepBarrier(run.lock_step_timeout_s)
        self._lost_since: dict[str, float] = {}  # robot → wall time its liveliness went (lost_grace_s)
        # a command or request answering step k acts from step k + latency (latency.py)
        self.pipeline: Pipeline[IncomingQuery] = Pipeline(sim.config.command_latency_steps)
        self.pacer = Pacer(run.rtf)
        self.rtf = RtfMeter(run.rtf)
        self.times = PeriodTimes()
        self.pending: dict[object, zenoh.Query] = {}  # place ticket → its query, answered when placed
        self._tickets = itertools.count(1)
        self._publishers: dict[str, zenoh.Publisher] = {}
        self._place_key = PHYSICS_PLACE.key(site=self.site)
        self.errors = 0
        self._warned_step = -1
        self._robots_deadline: float | None = None  # while holding the clock for the robots to come up
        self._planner_alive = False  # (heard only with RunConfig.wait_for_planner)
        self._held = False  # the clock was held at step 0 for the robots
        self._participants = set(run.step_with)  # lock-step participants still answering (step_with)
        # judged state messages: a forged constructed must not join a placement that is still settling
        self.states = ComponentStates({c.guid: c.key for c in sim.manifest.components})
        self._keys = {c.guid: c.key for c in sim.manifest.components}
        # lock-step with participants: component states taken at defined steps (.stepped_states)
        self.stepped_states = SteppedStates(self.states) if self._participants else None
        self._states_held_since: float | None = None
        # sender (a robot, a participant) → step → physics requests its answer said were sent for that step
        # and that have not come
        self._requests_due: dict[str, dict[int, int]] = {}
        self._announced: list[Outgoing] = []  # the open step's clock and sensors, as they went out
        self._clock_times: dict[int, float] = {}  # recent clock steps → their sim time (_vouched)
        self._reannounced_wall_s = -math.inf

    def serve(self) -> None:
        site, inbox, session = self.site, self.inbox, self.session
        declarations: list[object] = [
            inbox.subscribe(session, ROBOT_CMD_VEL, site=site, robot_id="*"),
            inbox.subscribe_liveliness(session, key(ALIVE_KEY, site=site, kind="robot", id="*")),
            inbox.subscribe(session, COMPONENT_STATE, site=site, key="*"),
        ]
        if self._participants:
            declarations.append(inbox.subscribe(session, STEP_DONE, site=site, participant="*"))
        if isinstance(self.sim, PlanSimulation):  # robots' paths, and the news that holds its clock
            declarations += [
                inbox.subscribe(session, ROBOT_PLAN, site=site, robot_id="*"),
                inbox.subscribe(session, ROBOT_STATE, site=site, robot_id="*"),
                inbox.subscribe(session, TASK, site=site, task_id="*"),
                inbox.subscribe(session, COMPONENT_EVENT, site=site, key="*"),
            ]
        if self.run.wait_for_planner:
            planner = key(ALIVE_KEY, site=site, kind="planner", id="*")
            declarations.append(inbox.subscribe_liveliness(session, planner))
            declarations.append(inbox.subscribe(session, PLANNER_PREPARING, site=site))
        declarations += [
            inbox.serve(session, PHYSICS_INFO, complete=True, site=site),
            inbox.serve(session, PHYSICS_ATTACH, complete=True, site=site),
            inbox.serve(session, PHYSICS_PLACE, complete=True, site=site),
            inbox.serve(session, PHYSICS_DROP, complete=True, site=site),
            inbox.serve(session, PHYSICS_BUILD, complete=True, site=site),
            inbox.serve(session, PHYSICS_SKIP, complete=True, site=site),
            inbox.serve(session, PHYSICS_RELOCATE, complete=True, site=site),
            inbox.serve(session, PHYSICS_POSES, complete=True, site=site),
        ]
        declarations.append(
            session.liveliness().declare_token(key(ALIVE_KEY, site=site, kind="physics", id="main"))
        )
        self._publish(self.sim.start_messages())
        self.barrier.open(self.sim.step, time.monotonic())
        if self.stepped_states is not None:
            self.stepped_states.clock(self.sim.step, self.sim.sim_time_s)
        _log.info(
            "physics serving site %s: robots %s, rtf %s, lock-step %s",
            site,
            ", ".join(self.sim.robot_ids) or "none",
            self.run.rtf or "max",
            self.sim.config.lock_step,
        )
        last_status = time.monotonic()
        try:
            while not self.stop.is_set():
                if self.run.max_steps is not None and self.sim.step >= self.run.max_steps:
                    break
                started = time.monotonic()
                wait_s = self._wait_s(started)
                if wait_s > 0.0:
                    self._drain(min(wait_s, LOOP_WAIT_S))
                    self.times.add("wait", time.monotonic() - started)
                    continue
                self._advance()
                started = time.monotonic()
                self._drain(None)
                self.times.add("drain", time.monotonic() - started)
                if time.monotonic() - last_status > STATUS_EVERY_S:
                    last_status = time.monotonic()
                    self._status()
        finally:
            for query in self.pending.values():
                self._reply(
                    query,
                    self._place_key,
                    PhysicsReply(ok=False, reason="physics stopped", sim_time_s=self.sim.sim_time_s),
                )
            self.pending.clear()
            self._status()
            _log.info(
                "physics stepping: %d steps in %.2f s wall (bare stepSimulation, %.3f ms a step)",
                self.sim.steps_taken,
                self.sim.stepping_wall_s,
                1000.0 * self.sim.stepping_wall_s / max(1, self.sim.steps_taken),
            )
            _log.info(
                "physics laser: %d scans in %.2f s wall (%.3f ms a scan)",
                self.sim.scans_taken,
                self.sim.scan_wall_s,
                1000.0 * self.sim.scan_wall_s / max(1, self.sim.scans_taken),
            )
            del declarations

    # --- pacing --------------------------------------------------------------------------------------

    def _holding_clock(self, now: float) -> bool:
        """Whether the clock still waits at step 0 for robots that are not alive yet (``wait_for_robots_s``),
        and with ``wait_for_planner`` for the planner: a run then starts when its robots can act and its
        planner hands out work, not after sim time nobody used."""
        if self.run.wait_for_robots_s <= 0.0 or self.sim.step > 0:
            return False
        missing = [f"robot {robot_id}" for robot_id in sorted(set(self.sim.robot_ids) - self.sim.alive)]
        if self.run.wait_for_planner and not self._planner_alive:
            missing.append("the planner")
        if not missing:
            return False
        if self._robots_deadline is None:
            self._robots_deadline = now + self.run.wait_for_robots_s
            _log.info("holding the clock until %s are alive", _and(missing))
        if now < self._robots_deadline:
            return True
        if self._robots_deadline != -math.inf:
            _log.warning(
                "%s not alive after %.0f s; starting without them",
                _and(missing),
                self.run.wait_for_robots_s,
            )
            self._robots_deadline = -math.inf
        return False

    def _planner_preparing(self, preparing: PreparingMsg) -> None:
        """The planner still prepares its plan: the wait for it starts again (its bound is for a planner
        nobody hears from, not for one that works)."""
        if self._robots_deadline is not None and self._robots_deadline != -math.inf:
            self._robots_deadline = time.monotonic() + self.run.wait_for_robots_s
            _log.debug("planner preparing: %s (%d of %d)", preparing.stage, preparing.done, preparing.total)

    def _wait_s(self, now: float) -> float:
        """How long to wait before the next period may run (0: run it now)."""
        if self._lost_since:
            self._expire_lost(now)
        if self._holding_clock(now):
            self._held = True
            return LOOP_WAIT_S
        if isinstance(self.sim, PlanSimulation) and self.sim.over_at is not None:
            return LOOP_WAIT_S  # the plan fidelity's build is over: another period would change nothing
        if self._held:  # the robots are up: step 0 again for them, and their answers waited for from now
            self._held = False
            self._publish(self.sim.start_messages())
            self.barrier.open(self.sim.step, now)
        if self.sim.config.lock_step:
            # with participants (a reproducible run) a robot whose placement runs is waited for too: left
            # behind, its first request after the placement was taken at whichever step physics had reached
            busy = set() if self.run.step_with else self.sim.busy_robots()
            waited_for = (self.sim.alive - busy) | self._participants
            missing = self.barrier.missing(waited_for)
            if missing:
                if not self.barrier.timed_out(now):
                    self._reannounce(now)
                    return max(self.barrier.remaining_s(now), 1e-3)
                silent = self._participants.intersection(missing)
                if silent:  # not waited for again until they answer (a robot: until alive again)
                    self._participants -= silent
                if self._warned_step != self.barrier.step:
                    self._warned_step = self.barrier.step
                    _log.warning(
                        "lock-step: no command for step %d from %s within %.1f s; going on with their last commands",  # noqa: E501
                        self.barrier.step,
                        ", ".join(missing),
                        self.barrier.timeout_s,
                    )
        if self._states_wait(now) or self._requests_wait():
            return LOOP_WAIT_S
        return self.pacer.delay_s(self.sim.sim_time_s + self.sim.config.control_period_s, now)

    def _reannounce(self, now: float) -> None:
        """The open step's clock and sensors again, once the wait for its answers has lasted
        ``REANNOUNCE_S`` and every ``REANNOUNCE_S`` after (not recorded: they are the same messages)."""
        if self.barrier.waited_s(now) < REANNOUNCE_S or now - self._reannounced_wall_s < REANNOUNCE_S:
            return
        self._reannounced_wall_s = now
        for item in self._announced:
            self._put(item)

    def _count_request(self, sender: str, step: int, count: int) -> None:
        """``count`` more (an answer said so) or fewer (one came) requests of ``sender`` for ``step``."""
        due = self._requests_due.setdefault(sender, {})
        due[step] = due.get(step, 0) + count
        if due[step] == 0:
            del due[step]

    def _requests_wait(self) -> bool:
        """Whether a request a robot's command or a participant's answer announced for a step now due has not
        come yet (its query travels apart from the answer); after the barrier's bound physics goes on
        without it."""
        limit = self.pipeline.target(self.sim.step)
        missing = [
            (robot_id, step)
            for robot_id, due in self._requests_due.items()
            for step, n in due.items()
            if n > 0 and step <= limit
        ]
        if not missing:
            return False
        if not self.barrier.timed_out(time.monotonic()):
            return True
        _log.warning("lock-step: going on without the request(s) announced by %s", missing)
        for robot_id, step in missing:
            del self._requests_due[robot_id][step]
        return False

    def _states_wait(self, now: float) -> bool:
        """Whether the advance waits for a twin's answer to a claim due at this step (bounded)."""
        stepped = self.stepped_states
        if stepped is None or stepped.ready(self.sim.step):
            self._states_held_since = None
            return False
        if self._states_held_since is None:
            self._states_held_since = now
        if now - self._states_held_since < self.barrier.timeout_s:
            stepped.to_ask.extend(stepped.claims.ask_again(self._states_held_since, now))
            return True
        _log.warning(
            "lock-step: step %d goes on without the twins of %s",
            self.sim.step,
            ", ".join(stepped.claims.guids()),
        )
        return False

    def _advance(self) -> None:
        started = time.monotonic()
        step = self.sim.step
        stepped = self.stepped_states
        if stepped is not None:
            forced = not stepped.ready(step)
            for guid, state in stepped.take(step, force=forced):
                self.sim.handling.note_constructed(guid, state == ComponentState.CONSTRUCTED)
            self._states_held_since = None
        if isinstance(self.sim, PlanSimulation):  # what it heard, taken before the step's requests
            self.sim.take_heard()
        for command in self.pipeline.due_commands(step):
            self.sim.command(command)
        for held in self.pipeline.due_requests(step):
            self._answer(held, held=True)
        result = self.sim.advance(self.rtf.value)
        now = time.monotonic()
        self.times.add("advance", now - started)
        self.times.period()
        self.rtf.record(self.sim.sim_time_s, now)
        self._publish(result.messages)
        self.times.add("publish", time.monotonic() - now)
        for ticket, reply in result.replies:
            query = self.pending.pop(ticket, None)
            if query is not None:
                self._reply(query, self._place_key, reply)
        self.barrier.open(self.pipeline.target(self.sim.step), now)
        if stepped is not None:
            stepped.clock(self.sim.step, self.sim.sim_time_s)

    # --- input ---------------------------------------------------------------------------------------

    def _drain(self, first_timeout_s: float | None) -> None:
        for item in self.inbox.drain(first_timeout_s=first_timeout_s or 0.0):
            try:
                self._handle(item)
            except Exception:
                self.errors += 1
                _log.exception("handling %s failed; going on", type(item).__name__)
            if self.stop.is_set():
                break
        self._ask_twins()

    def _handle(self, item: object) -> None:
        if isinstance(self.sim, PlanSimulation) and isinstance(item, Received):
            self.sim.hear(item.message)
        match item:
            case Received(message=CmdVelMsg() as command, key=key_expr):
                if key_expr.rsplit("/", 2)[-2] != command.robot_id:
                    self.inbox.invalid.record(
                        key_expr, f"robot_id {command.robot_id!r} on another robot's key"
                    )
                    return
                if not self.sim.known(command.robot_id):
                    return
                self.barrier.record(
                    command.robot_id, command.step, sleeps=command.sleeps, wakes_at_s=command.wakes_at_s
                )
                if command.requests and command.step is not None and self.run.step_with:
                    self._count_request(command.robot_id, command.step, command.requests)
                if self.pipeline.command_now(command):
                    self.sim.command(command)
            case Received(message=StepDoneMsg() as answer):
                if answer.participant in self.run.step_with:
                    self.barrier.record(answer.participant, answer.step)
                    if (
                        answer.wakes
                    ):  # a task message: the sleeping robots answer again from the step taking it
                        self.barrier.wake_sleepers(answer.step + DELAY_STEPS)
                    if answer.requests:  # a skip it asked: not stepped past before it came
                        self._count_request(answer.participant, answer.step, answer.requests)
                    if answer.done:
                        self._participants.discard(answer.participant)
                        _log.info("lock-step: %s is done; not waited for any more", answer.participant)
                    else:
                        self._participants.add(answer.participant)
            case Received(message=ComponentStateMsg() as message) if self.stepped_states is not None:
                self.stepped_states.hear(message)
            case Answer(message=TwinMsg() as twin) if (
                self.stepped_states is not None and self.stepped_states.answer(twin)
            ):
                pass  # taken at its claim's step
            case Received(message=ComponentStateMsg() as message):
                if (state := self.states.hear(message)) is not None:
                    self.sim.handling.note_constructed(message.guid, state == ComponentState.CONSTRUCTED)
            case Answer(key=reply_key, message=TwinMsg() as twin):
                if not answered_on_its_key(self.site, reply_key, twin):
                    self.inbox.invalid.record(reply_key, "a twin answered on another component's key")
                elif (state := self.states.take_twin(twin)) is not None:
                    self.sim.handling.note_constructed(twin.guid, state == ComponentState.CONSTRUCTED)
            case Received(message=PreparingMsg() as preparing):
                self._planner_preparing(preparing)
            case LivelinessChange() if item.kind == "planner":
                self._planner_alive = item.alive
                _log.info("planner %s", "alive" if item.alive else "gone")
            case LivelinessChange():
                if item.alive:
                    self._lost_since.pop(item.id, None)
                elif self.sim.known(item.id) and self.run.lost_grace_s > 0.0:
                    _log.warning(
                        "robot %s out of reach: lost unless back within %g s", item.id, self.run.lost_grace_s
                    )
                    self._lost_since.setdefault(item.id, time.monotonic())
                    return
                self._robot_liveliness(item.id, item.alive)
            case IncomingQuery():
                self._answer(item)

    def _arrived(self, request: BaseModel) -> bool:
        """Count a robot's or a participant's request in as it comes (True: go on handling it)."""
        step = getattr(request, "step", None)
        sender = getattr(request, "robot_id", None) or getattr(request, "participant", None)
        if step is not None and sender is not None and self.run.step_with:
            self._count_request(sender, step, -1)
        return True

    def _robot_liveliness(self, robot_id: str, alive: bool) -> None:
        if self.sim.known(robot_id):
            _log.info("robot %s %s", robot_id, "alive" if alive else "lost")
            if not alive:
                self.pipeline.forget([robot_id])
        self._publish(self.sim.set_alive(robot_id, alive))

    def _expire_lost(self, now: float) -> None:
        """Robots out of reach for ``lost_grace_s`` are lost: stopped, their loads dropped."""
        for robot_id, since in list(self._lost_since.items()):
            if now - since >= self.run.lost_grace_s:
                del self._lost_since[robot_id]
                self._robot_liveliness(robot_id, False)

    def _ask_twins(self) -> None:
        """Ask the twins of the components whose state messages did not fit (non-blocking, bounded)."""
        if self.stepped_states is not None:
            asked, self.stepped_states.to_ask = self.stepped_states.to_ask, []
            for guid in dict.fromkeys(asked):
                ask_twin(self.inbox, self.session, self.site, self._keys[guid])
        for question in self.states.questions(time.monotonic()):
            ask_twin(self.inbox, self.session, self.site, question.key)

    def _answer(self, item: IncomingQuery, *, held: bool = False) -> None:
        """Answer a query; a robot's request stamped with a step not due yet waits for it (``held``: it
        waited and is due now)."""
        now, served, query = self.sim.sim_time_s, item.queryable, item.query
        reply_key = served.key(site=self.site)
        if served is PHYSICS_POSES:
            self._reply(query, reply_key, self.sim.poses())
            return
        if served.request is None:
            participants = list(self.run.step_with)
            self._reply(
                query,
                reply_key,
                self.sim.info().model_copy(
                    update={"lock_step_participants": participants, "fidelity": self.run.fidelity}
                ),
            )
            return
        payload = query.payload.to_bytes() if query.payload is not None else b""
        request = decode(served.request, reply_key, payload, self.inbox.invalid)
        if request is None:
            model = served.request
            reason = f"invalid {model.__name__} payload (expected JSON with {', '.join(model.model_fields)})"
            self._reply(query, reply_key, PhysicsReply(ok=False, reason=reason, sim_time_s=now))
        elif (
            not held
            and self._arrived(request)
            and not self.pipeline.request_now(getattr(request, "step", None), self.sim.step, item)
        ):
            return  # held until its step is due (_advance)
        elif isinstance(request, AttachRequest):
            self._reply(query, reply_key, self.sim.attach(request))
        elif isinstance(request, DropRequest):
            self._reply(query, reply_key, self.sim.drop(request))
        elif isinstance(request, BuildRequest):
            self._reply(query, reply_key, self.sim.build(request))
        elif isinstance(request, SetUpRequest):
            self._reply(query, reply_key, self.sim.relocate(request))
        elif isinstance(request, SkipRequest):
            skipped = self.sim.skip(request)
            if skipped.ok:
                self.pacer.rebase()  # paced runs go on from the new sim time, not sleep through the jump
            self._reply(query, reply_key, skipped)
        elif isinstance(request, PlaceRequest):
            ticket = next(self._tickets)
            reply = self.sim.place(request, ticket)
            if reply is None:
                self.pending[ticket] = query
            else:
                self._reply(query, reply_key, reply)

    # --- output --------------------------------------------------------------------------------------

    def _reply(self, query: zenoh.Query, reply_key: str, message: BaseModel) -> None:
        try:
            query.reply(reply_key, encode(message))
        except Exception as error:  # the querier may be gone (timed out): nothing to answer
            _log.debug("reply on %s not delivered: %s", reply_key, error)
        finally:
            query.drop()

    def _publish(self, messages: Iterable[Outgoing]) -> None:
        """Record, then publish: the record is never behind what the bus heard (:mod:`.snapshot`). A
        sleeping robot is sent its sensors only where it needs them (``Sleepers.sends_sensors``)."""
        messages = self._vouched(list(messages))
        if self.recorder is not None and messages:
            self.recorder.record(item.message for item in messages)
            self.recorder.write()
        bundled = bundle(messages)
        if self.run.step_with:
            sleepers = self.barrier.sleepers
            bundled = [
                _woken_alone(item, sleepers)
                for item in bundled
                if not isinstance(sensors := item.message, SensorsMsg)
                or sleepers.sends_sensors(sensors.robot_id, sensors.clock.step)
            ]
        if any(isinstance(item.message, ClockMsg) for item in bundled):  # a new step: what _reannounce says
            self._announced = [item for item in bundled if isinstance(item.message, ClockMsg | SensorsMsg)]
            self._reannounced_wall_s = -math.inf
        for item in bundled:
            self._put(item)

    def _vouched(self, messages: list[Outgoing]) -> list[Outgoing]:
        """With participants, each clock says up to when every participant's output has been sent (the sim
        time of step ``k − DELAY_STEPS``: physics heard their answers to it) and the latest wake at or
        before its step (:mod:`bimbot.shared.step_gate`)."""
        if not self.run.step_with:
            return messages
        out = []
        for item in messages:
            if isinstance(clock := item.message, ClockMsg):
                times = self._clock_times
                times[clock.step] = clock.sim_time_s
                for old in [step for step in times if step < clock.step - 2 * DELAY_STEPS]:
                    del times[old]
                self.barrier.publishing(clock.step, clock.sim_time_s)
                if isinstance(self.sim, PlanSimulation):  # a part came to rest across a sleeper's way
                    asleep = self.barrier.sleepers.asleep_driving()
                    for robot_id in self.sim.crossed_drivers(clock.step, asleep):
                        self.barrier.wake_one(robot_id, clock.step)
                update = {
                    "inputs_to_s": times.get(clock.step - DELAY_STEPS),
                    "last_wake_step": self.barrier.sleepers.latest_wake(clock.step),
                }
                out.append(Outgoing(item.key_expr, clock.model_copy(update=update)))
            else:
                out.append(item)
        return out

    def _put(self, item: Outgoing) -> None:
        payload = encode(item.message)
        # many keys, each rarely: no publisher per component; in a reproducible run none at all: Zenoh
        # keeps the order of one session's puts, not of puts through declared publishers (measured:
        # 130 to 240 of 20,000 overtaken), and a step's sensors must not overtake its poses
        if self.run.step_with:  # lock-step: one session, in order
            self.session.put(item.key_expr, payload)
            return
        if "/components/" in item.key_expr:
            self.session.put(item.key_expr, payload)
            return
        publisher = self._publishers.get(item.key_expr)
        if publisher is None:
            publisher = self._publishers[item.key_expr] = self.session.declare_publisher(item.key_expr)
        publisher.put(payload)

    def _status(self) -> None:
        _log.info(
            "physics: step %d, sim %.1f s, rtf %.1f, %d invalid payloads, %d handler errors; wall time: %s",
            self.sim.step,
            self.sim.sim_time_s,
            self.rtf.value,
            self.inbox.invalid.total,
            self.errors,
            self.times.take(),
        )


def _and(names: list[str]) -> str:
    """``robot r1, robot r2 and the planner``."""
    return names[0] if len(names) == 1 else f"{', '.join(names[:-1])} and {names[-1]}"


def _woken_alone(item: Outgoing, sleepers: Sleepers) -> Outgoing:
    """A robot's sensors whose clock names the latest wake that woke it, its own included
    (:meth:`.sleepers.Sleepers.latest_wake_for`); anything else as it is."""
    sensors = item.message
    if not isinstance(sensors, SensorsMsg) or sensors.robot_id not in sleepers.woken_alone:
        return item
    clock = sensors.clock
    wake = sleepers.latest_wake_for(sensors.robot_id, clock.step)
    if wake == clock.last_wake_step:
        return item
    clock = clock.model_copy(update={"last_wake_step": wake})
    return Outgoing(item.key_expr, sensors.model_copy(update={"clock": clock}))
