"""The plan fidelity's physics (``--fidelity plan``): kinematic robots, no laser, a clock jumping by events.

Why: a scenario study needs many runs; the full simulation steps every robot's wheels, casts its laser
and waits for its particle filter every 0.2 s of sim time. :class:`PlanSimulation` keeps the scene, the
handling, placing, pits, joints, connections and their reasons, and changes three things:

* **Robots move kinematically.** A ground robot's path (its ``PlanMsg``, :meth:`PlanSimulation.hear`) is
  timed by :func:`bimbot.shared.plan_motion.trajectory`, the same function its executor moves by; each
  period its body is set where the motion has it (collisions off: it neither pushes nor is pushed). No
  laser scans go out, and odometry is the true pose (the robot ignores it).
* **Physics only where an answer needs it.** Bullet is stepped only while a released component settles
  (stability at release, supports, drift); otherwise a period is kinematic: carried and assembling loads
  are set where they are at its end, reach checks read the robots' poses as always.
* **Time advances by events.** Once nothing was heard for ``quiet_periods`` periods (no new path, task,
  robot or component state, request), no component event waits for its agent's answer (a state of that
  component, for at most ``EVENT_WAIT_PERIODS`` periods: a robot waiting for one must not see the clock
  leap) and nothing settles, the clock jumps so that the next period ends at the earliest known event: a
  drive's end, an assembly motion's end (a crane's lift), a connection's hold, a robot's timed work
  (``busy_until_s``), and the planner's next own event, which its answer to each step says
  (``StepDoneMsg.next_event_s``: a curing's end releases a task; while a robot drives the planner asks
  no skip, and a jump past that end would release the task late). The services see a
  clock that leaps, as after a skip over a quiet site (:meth:`~.simulation.Simulation.skip`); the
  protocol's own exchanges still run period by period, so a hand-off between services costs the sim time
  it costs in the physics fidelity.
* **Same seed, same jumps.** What is heard is taken at a defined step (:mod:`.stepped_news`: before
  advancing from ``k``, what was stamped at ``k − 1`` or before), never as it happens to arrive. What the
  services say at step ``k`` is therefore not known when physics advances from ``k``: the clock never
  jumps from a step at which a known event fell (its robot acts on it at that step), nor from a step a
  skip landed on or the one after it (what the planner skipped to, a curing's end, is no event physics
  knows).
* **A sleeping driver wakes for a part set down in its way.** A robot asleep through its drive is woken
  alone, at a defined step, when a part comes to rest across the rest of its path (:mod:`.crossed_drives`),
  as a driver on site sees it: it plans round it instead of driving through it.
* **Fewer poses.** A carried load's pose goes out when it is taken up and then once a second of sim time
  (:mod:`.carried_poses`), and one resting pose is repeated a period (``PLAN_POSE_REFRESH_MAX``).
* **The clock stops when the build is over.** Once the planner has said it is done (every task settled)
  and the site waits for nothing it knows (no news, nothing settling, no event ahead), nothing can happen
  any more: :attr:`PlanSimulation.over_at` is set and physics advances no further (:mod:`.app`), so the
  services stop stepping an empty site while the run audits, reports and stops them.
"""

from __future__ import annotations

import logging
import math
from dataclasses import replace
from typing import TYPE_CHECKING

from bimbot.shared.fidelity import FIDELITIES
from bimbot.shared.footprint import posed_footprint
from bimbot.shared.messages import (
    PLANNER_PARTICIPANT,
    AttachRequest,
    BuildRequest,
    ComponentEventMsg,
    ComponentPoseMsg,
    ComponentState,
    ComponentStateMsg,
    DropRequest,
    PhysicsReply,
    PlaceRequest,
    PlanMsg,
    RobotStateMsg,
    ScanMsg,
    SkipRequest,
    StepDoneMsg,
    TaskMsg,
)
from bimbot.shared.plan_motion import Trajectory, standing, trajectory
from bimbot.shared.site_access import AccessConfig

from .carried_poses import CarriedPoses
from .client import p
from .crossed_drives import CrossedDrives
from .handling_state import Item, Phase
from .odometry import Odometry, OdomReading
from .scene import compose, yaw_quat
from .simulation import Outgoing, PeriodResult, Simulation
from .stepped_news import SteppedNews

if TYPE_CHECKING:
    from .robots import Robot

_log = logging.getLogger(__name__)

QUIET_PERIODS = 4  # periods without news before the clock may jump (answers come 2 periods later)
# Poses of components at rest repeated a period at most (5 in the physics fidelity, on a large site): each
# repeat costs every subscriber a decode, a sleeping robot's too, and the plan fidelity sends a pose at
# once where one is needed (a verification).
PLAN_POSE_REFRESH_MAX = 1
ROBOTS_BAND = AccessConfig()  # the robots' height band (what of a part blocks their way)
EVENT_WAIT_PERIODS = 50  # at most this long a component event unanswered by its agent holds the clock


class ExactOdometry(Odometry):
    """Odometry that is the true pose (the plan fidelity's robot knows where it is), speeds 0: a drive's
    motion between two periods the clock jumped over is no speed a message may carry."""

    def update(
        self, previous: tuple[float, float, float], current: tuple[float, float, float], period_s: float
    ) -> OdomReading:
        self.pose_xy_yaw = current
        return OdomReading(current, 0.0, 0.0)


class PlanSimulation(Simulation):
    """:class:`.simulation.Simulation` in the plan fidelity (see the module doc)."""

    quiet_periods = QUIET_PERIODS

    def _build(self) -> None:
        refresh_max = min(self.config.pose_refresh_max, PLAN_POSE_REFRESH_MAX)
        self.config = replace(self.config, compiled_laser=False, pose_refresh_max=refresh_max)
        super()._build()
        self.motions: dict[str, Trajectory] = {}
        self._ended: set[str] = set()  # robots whose motion ended and was noted as news
        self._heard: dict[str, tuple[object, ...]] = {}  # last state of each robot, task, component
        self._busy_until: dict[str, float] = {}  # robot → its timed work's end (its state says)
        # participant → (the step it answered last, when it acts next of its own accord: a curing's end)
        self._own_events: dict[str, tuple[int, float | None]] = {}
        self._since_news = 0  # periods advanced since something was heard
        self._unanswered: dict[str, tuple[str, int]] = {}  # guid → (event id, period heard): no state yet
        self._answered: set[str] = set()  # event ids a state answered (a late repeat holds nothing)
        self.jumps, self.jumped_s, self.physics_periods = 0, 0.0, 0
        self.news: dict[str, int] = {}  # what held the clock, by kind (the log line at the end)
        self.stepped_for: dict[str, int] = {}  # why a period did not jump, by cause
        self.heard = SteppedNews()  # what is heard, until the advance that takes it
        self._step_start_s: float | None = None  # the sim time the previous step went out at
        self._skipped_at = -2  # the step a skip landed on (no jump from it nor from the next)
        self._planner_done = False  # the planner said it is done (taken as news are: at a defined step)
        self.over_at: int | None = None  # the step at which the build was over (the clock stops there)
        self.crossed = CrossedDrives()  # parts that came to rest, for the sleeping drivers' ways
        self._radius_m = {robot_id: robot.description.radius_m for robot_id, robot in self.robots.items()}
        self._resting: set[str] = set()  # parts whose fixed pose went out, not carried nor moved since
        self.woken_drivers = 0
        self.carried_poses = CarriedPoses()  # a carried load's pose goes out now and then
        cid = self.client_id
        for robot_id, robot in self.robots.items():
            if not robot.drives:
                continue
            self._odometry[robot_id] = ExactOdometry(robot.start_xy_yaw, 0.0, self._odometry[robot_id]._rng)
            for link in range(-1, p.getNumJoints(robot.body_id, physicsClientId=cid)):
                p.setCollisionFilterGroupMask(robot.body_id, link, 0, 0, physicsClientId=cid)
        _log.info("plan fidelity: robots move kinematically, no laser, the clock jumps by events")

    # --- what is heard -------------------------------------------------------------------------------

    def hear(self, message: object) -> None:
        """A message of the site as it arrives: held until the advance that takes it (:meth:`take_heard`)."""
        self.heard.put(message)

    def take_heard(self) -> None:
        """Take what is due before advancing from this step (see :mod:`.stepped_news`); the adapter calls it
        before physics' requests of the step are answered, :meth:`advance` again (nothing new then)."""
        self.heard.clock(self.step, self.sim_time_s)
        for message in self.heard.take(self.step):
            self._take(message)

    def _take(self, message: object) -> None:
        """A message of the site: a robot's path (its motion from then), or news that holds the clock."""
        if isinstance(message, PlanMsg):
            self._plan(message)
            self._news("path")
        elif isinstance(message, RobotStateMsg):
            self._changed(
                "robot",
                message.robot_id,
                (message.state, message.task_id, message.guid, message.busy_until_s),
            )
            if message.busy_until_s is not None:
                self._busy_until[message.robot_id] = message.busy_until_s
            else:
                self._busy_until.pop(message.robot_id, None)
        elif isinstance(message, TaskMsg):
            self._changed("task", message.task_id, (message.status, message.robot_id, message.attempt))
        elif isinstance(message, StepDoneMsg):
            self._answered_step(message)
        elif isinstance(message, ComponentEventMsg):
            if message.event_id not in self._answered:
                self._unanswered[message.guid] = (message.event_id, self.step)
        elif isinstance(message, ComponentStateMsg):
            answered = self._unanswered.pop(message.guid, None)
            if answered is not None:
                self._answered.add(answered[0])
            self._changed("component", message.guid, (message.state,))
            if message.state is ComponentState.VERIFYING and message.guid in self.handling.items:
                # its agent verifies on a pose stamped after the placement: send one now, not at the next
                # repeat (which a jump of the clock would put off)
                self.handling.changed.add(message.guid)

    def _answered_step(self, answer: StepDoneMsg) -> None:
        """A participant's answer to a step: when it acts next of its own accord (no news: it comes every
        step). An answer said again for an older step (physics repeated that step's clock) changes nothing;
        one that is done has no event ahead."""
        last = self._own_events.get(answer.participant)
        if last is not None and answer.step < last[0]:
            return
        if answer.done and answer.participant == PLANNER_PARTICIPANT:
            self._planner_done = True
        self._own_events[answer.participant] = (answer.step, None if answer.done else answer.next_event_s)

    def _changed(self, kind: str, name: str, signature: tuple[object, ...]) -> None:
        if self._heard.get(f"{kind}/{name}") != signature:
            self._heard[f"{kind}/{name}"] = signature
            self._news(kind)

    def _news(self, why: str = "") -> None:
        self._since_news = 0
        if why:
            self.news[why] = self.news.get(why, 0) + 1

    def _plan(self, message: PlanMsg) -> None:
        robot = self.robots.get(message.robot_id)
        if robot is None or not robot.drives or not message.path_xy_m:
            return
        yaw = self._motion(message.robot_id).pose_at(message.sim_time_s)[2]
        description = robot.description
        self.motions[message.robot_id] = trajectory(
            message.path_xy_m,
            yaw,
            message.sim_time_s,
            speed_mps=description.max_speed_mps,
            turn_radps=description.max_turn_radps,
        )
        self._ended.discard(message.robot_id)

    def _motion(self, robot_id: str) -> Trajectory:
        """The robot's motion; standing where its body is until its first path (a restarted physics has
        put it where its record says)."""
        motion = self.motions.get(robot_id)
        if motion is None:
            robot = self.robots[robot_id]
            motion = self.motions[robot_id] = standing(robot.pose_xy_yaw(self.client_id), self.sim_time_s)
        return motion

    # --- requests are news too -----------------------------------------------------------------------

    def attach(self, request: AttachRequest) -> PhysicsReply:
        self._news("request")
        return super().attach(request)

    def drop(self, request: DropRequest) -> PhysicsReply:
        self._news("request")
        return super().drop(request)

    def place(self, request: PlaceRequest, tag: object = None) -> PhysicsReply | None:
        self._news("request")
        return super().place(request, tag)

    def build(self, request: BuildRequest) -> PhysicsReply:
        self._news("request")
        return super().build(request)

    def skip(self, request: SkipRequest) -> PhysicsReply:
        """As :meth:`.simulation.Simulation.skip`; where it lands, the clock goes on period by period until
        what the services say there is heard (:meth:`_jump`)."""
        before = self.sim_time_s
        reply = super().skip(request)
        if self.sim_time_s > before:
            self._skipped_at = self.step
        return reply

    def quiet(self) -> str | None:
        """As :meth:`.simulation.Simulation.quiet`, and a robot on its way is no quiet site."""
        now = self.sim_time_s
        for robot_id, motion in sorted(self.motions.items()):
            if motion.end_s > now:
                return f"{robot_id} is driving"
        return super().quiet()

    # --- the clock -----------------------------------------------------------------------------------

    def _settling(self) -> bool:
        return any(not watch.settled for watch in self.handling.watch.values())

    def _known_events(self) -> list[float]:
        """A drive's end, an assembly motion's end, a connection's hold, a robot's timed work, and what a
        participant said it does next of its own accord (the planner: a curing's end) (sim s)."""
        events = [motion.end_s for motion in self.motions.values()]
        events += [item.motion_start_s + item.motion_duration_s for item in self._assembling()]
        events += [watch.hold_until_s for watch in self.handling.watch.values() if watch.tag is not None]
        events += [at_s for _, at_s in self._own_events.values() if at_s is not None]
        return events + list(self._busy_until.values())

    def next_event_s(self) -> float | None:
        """The earliest known event after now; None when none is known."""
        now = self.sim_time_s
        ahead = [event for event in self._known_events() if event > now + 1e-9]
        return min(ahead) if ahead else None

    def _event_fell_now(self, start_s: float | None) -> bool:
        """Whether a known event fell in the period that ended at this step (after ``start_s``, the previous
        step's time): its robot acts on it at this step, which physics hears only at the next."""
        now = self.sim_time_s
        since = now - self.config.control_period_s if start_s is None else start_s
        return any(since < event <= now + 1e-9 for event in self._known_events())

    def _jump(self, start_s: float | None = None) -> None:
        """Jump the clock so that this period ends at the next event, when the site waits for one.
        ``start_s``: the sim time of the previous step."""
        if self._since_news < self.quiet_periods:
            return self._count("news")
        if self.step - self._skipped_at <= 1:
            return self._count("skip landed")
        if self._event_fell_now(start_s):
            return self._count("event now")
        if self._late_replies or self._settling():
            return self._count("settling")
        if any(self.step - heard < EVENT_WAIT_PERIODS for _, heard in self._unanswered.values()):
            return self._count("event unanswered")
        event = self.next_event_s()
        if event is None:
            if self._planner_done and self.over_at is None:
                self.over_at = self.step
                _log.info(
                    "plan fidelity: the build is over at step %d (%.1f s of sim time): the planner is done "
                    "and nothing is known ahead; the clock stops after this period",
                    self.step,
                    self.sim_time_s,
                )
            return self._count("no event")
        period = self.config.control_period_s
        # whole periods, so that this period ends at the event or just after it
        gap = math.ceil((event - self.sim_time_s) / period - 1e-9) - 1
        if gap < 1:
            return self._count("event next")
        self.skipped_s += gap * period
        self.jumps += 1
        self.jumped_s += gap * period

    def _count(self, why: str) -> None:
        self.stepped_for[why] = self.stepped_for.get(why, 0) + 1

    def _motions_ended(self) -> None:
        """A drive that ended by now is news: its robot acts on it (a request, an event) soon."""
        now = self.sim_time_s
        for robot_id, motion in self.motions.items():
            if robot_id not in self._ended and motion.end_s <= now:
                self._ended.add(robot_id)
                self._news("arrival")

    def _pose_robots(self, sim_s: float) -> None:
        cid = self.client_id
        for robot_id, robot in self.robots.items():
            if robot.drives:
                _set_base(cid, robot, self._motion(robot_id).pose_at(sim_s))

    def advance(self, real_time_factor: float | None = None) -> PeriodResult:
        """One period, after a jump over a site that only waits: Bullet stepped while something settles,
        otherwise the loads set where they are at its end."""
        self.take_heard()
        start_s, self._step_start_s = self._step_start_s, self.sim_time_s
        self._jump(start_s)
        end_s = self.sim_time_s + self.config.control_period_s
        self._pose_robots(end_s)
        if self._settling() or self._assembly_ends_by(end_s):
            self.physics_periods += 1
            result = super().advance(real_time_factor)
            self._pose_robots(self.sim_time_s)
        else:
            replies, self._late_replies = self._late_replies, []
            self.step += 1
            if self.handling.carrying:
                replies.extend(self.handling.follow(self.robots, self.sim_time_s))
            replies.extend(self.handling.watch_placed(self.sim_time_s, self.robots))
            self.handling.pose_hooks(self.robots)
            self.handling.settle_separated()
            result = PeriodResult(self._period_messages(real_time_factor, odometry=True), replies)
        self._since_news += 1
        self._motions_ended()
        if result.replies:
            self._news("placed")
        self._note_rests(result.messages)
        return result

    def _note_rests(self, messages: list[Outgoing]) -> None:
        """The parts whose pose now says they are fixed where they were not before (placed, cast, set up
        again), with their outlines in the robots' height band (:mod:`.crossed_drives`)."""
        band = ROBOTS_BAND
        for item in messages:
            pose = item.message
            if not isinstance(pose, ComponentPoseMsg):
                continue
            if not pose.fixed or pose.attached_to is not None:
                self._resting.discard(pose.guid)
                continue
            if pose.guid in self._resting or pose.guid not in self.handling.items:
                continue
            self._resting.add(pose.guid)
            component = self.handling.items[pose.guid].component
            footprint = posed_footprint(component, pose.pose.position_m, pose.pose.quat_xyzw)
            outlines = footprint.outlines_meeting(band.band_min_z_m, band.band_max_z_m)
            self.crossed.came_to_rest(self.step, pose.guid, outlines)

    def crossed_drivers(self, step: int, asleep_driving: dict[str, int]) -> list[str]:
        """The robots asleep through a drive (robot → the step it fell asleep after) that clock ``step``
        wakes: a part that came to rest covers the rest of their way (:mod:`.crossed_drives`)."""
        woken = self.crossed.to_wake(step, self.sim_time_s, asleep_driving, self.motions, self._radius_m)
        for robot_id in woken:
            _log.debug("plan fidelity: %s wakes at step %d: a part came to rest in its way", robot_id, step)
        self.woken_drivers += len(woken)
        return woken

    def __exit__(self, *exc: object) -> None:
        _log.info(
            "plan fidelity: %d period(s), %d with Bullet stepped; %d jump(s) over %.0f s of sim time; "
            "periods without a jump: %s; news: %s; %d sleeping driver(s) woken for a part in their way",
            self.step,
            self.physics_periods,
            self.jumps,
            self.jumped_s,
            ", ".join(f"{count} {why}" for why, count in sorted(self.stepped_for.items())) or "none",
            ", ".join(f"{count} {why}" for why, count in sorted(self.news.items())) or "none",
            self.woken_drivers,
        )
        super().__exit__(*exc)  # type: ignore[arg-type]

    def _assembly_ends_by(self, end_s: float) -> bool:
        """A placement's motion ends within the period: its release is stepped (it settles from there)."""
        return any(item.motion_start_s + item.motion_duration_s <= end_s for item in self._assembling())

    def _assembling(self) -> list[Item]:
        """The items in their assembly motion: among the moving ones (carried or assembling), not every
        item of the site (each period asks twice; 9,802 items made it a tenth of physics' time)."""
        items = self.handling.items
        return [items[guid] for guid in self.handling.state.moving if items[guid].phase is Phase.ASSEMBLING]

    # --- no laser ------------------------------------------------------------------------------------

    def _scan(self, robot: Robot, now: float) -> Outgoing:
        return Outgoing(
            "",
            ScanMsg(
                robot_id=robot.robot_id,
                angle_min_rad=0.0,
                angle_increment_rad=0.0,
                range_max_m=1.0,
                ranges_m=[],
                sim_time_s=now,
            ),
        )

    def _period_messages(self, real_time_factor: float | None, *, odometry: bool) -> list[Outgoing]:
        messages = super()._period_messages(real_time_factor, odometry=odometry)
        due = self.carried_poses.due
        return [item for item in messages if not isinstance(item.message, ScanMsg) and due(item.message)]


def _set_base(client_id: int, robot: Robot, pose: tuple[float, float, float]) -> None:
    """Put a robot's base at ``pose`` on the ground, at rest."""
    base = ((pose[0], pose[1], robot.base_height_m), yaw_quat(pose[2]))
    com = compose(base, robot.base_inertial)
    p.resetBasePositionAndOrientation(robot.body_id, com[0], com[1], physicsClientId=client_id)
    p.resetBaseVelocity(robot.body_id, [0, 0, 0], [0, 0, 0], physicsClientId=client_id)


def simulation_class(fidelity: str) -> type[Simulation]:
    """The simulation of a fidelity: ``physics`` (the full simulation) or ``plan``."""
    if fidelity not in FIDELITIES:
        raise ValueError(f"fidelity {fidelity!r}: expected one of {', '.join(FIDELITIES)}")
    return PlanSimulation if fidelity == "plan" else Simulation
