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

:class:`PlannerCore` is the adapter's one entry: it takes the observations and runs the steps in order.
Each step is a part of its own, built here on the shared :class:`.planner_state.PlannerState` (records,
clocks) and the :class:`.outbox.Outbox` (what is sent): :mod:`.release` (1, with the curing holds),
:mod:`.dispatch` (2), :mod:`.follow_up` (3), :mod:`.give_backs` and :mod:`.failures` (3-5),
:mod:`.watchdog` (5), :mod:`.quiet` (skips).

Delivery is at least once: each event and each ``assigned`` task is re-sent unchanged (same ``event_id``)
every ``resend_s`` wall seconds until its effect is observed (the component leaves ``planned`` after a
release, ``misplaced`` after a retry, the carrying states after an abandon; the robot reports the task or
the component leaves ``released`` after an assignment).
"""

from __future__ import annotations

import logging
import uuid
from collections.abc import Callable
from typing import TYPE_CHECKING

from bimbot.shared.footprint import body_centre_xy
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import (
    ComponentPoseMsg,
    ComponentState,
    ComponentStateMsg,
    CuringHold,
    ProgressMsg,
    RobotStateMsg,
    TwinMsg,
)
from bimbot.shared.reasons import Reason

from .capability import SiteRobot
from .clear_away import ClearAways
from .curing import CuringHolds, Hold, constructed_time_s
from .dispatch import Dispatch
from .failures import Failures
from .follow_up import FollowUp
from .give_backs import GiveBacks
from .outbox import Outbox
from .planner_state import PlannerState
from .quiet import MIN_SKIP_S, Quiet, Skip
from .records import FINAL, TERMINAL, Outgoing, Phase, PlannerLimits
from .release import Release
from .shut_in import ShutInHolds
from .sources import Plan
from .watchdog import Watchdog
from .work_in_place import cure_s

if TYPE_CHECKING:
    from .access_hold import AccessGuard

__all__ = ["Outgoing", "Phase", "PlannerCore", "PlannerLimits", "Skip"]

_log = logging.getLogger(__name__)


class PlannerCore:
    """The planner for its adapter: observations in, messages out (see the module docstring); no bus, no
    files, no clock. It keeps no records itself: its parts share one :class:`.planner_state.PlannerState`
    and one :class:`.outbox.Outbox`, and each part receives the others it calls when it is built."""

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
        access: AccessGuard | None = None,
    ) -> None:
        """``robots``: the robots on site with their types (:func:`.capability.site_robots`); with them a
        task goes to the capable robot with the best bid (:mod:`.assignment`), without them to the nearest
        idle robot. ``slots``: the yard slots of the site plan (where a component lies before any pose).
        ``access``: with it, a ready task waits while placing it would cut off work still to be built
        (:mod:`.access_hold`)."""
        state = PlannerState.start(manifest, plan, limits or PlannerLimits(), robots, slots or {})
        self._state = state
        self._outbox = Outbox(state, resend_s=resend_s, new_id=new_id)
        self._failures = Failures(state, self._outbox)
        self._clear_aways = ClearAways(state, self._outbox)
        self._give_backs = GiveBacks(state, self._outbox, self._failures, holds=self._clear_aways.holds)
        self._watchdog = Watchdog(state, self._give_backs)
        # when each cast component was constructed: the follow-up records it, the release waits for it
        self._curing = CuringHolds(
            {guid: cure_s(item) for guid, item in state.manifest.items() if cure_s(item) > 0}
        )
        self._release = Release(state, self._outbox, self._curing, access)
        self._follow_up = FollowUp(state, self._outbox, self._curing, self._failures, self._give_backs)
        shut_in = ShutInHolds(state, access)
        self._dispatch = Dispatch(
            state,
            self._outbox,
            self._failures,
            holds=lambda task: self._clear_aways.holds(task) or shut_in.holds(task),
        )
        self._quiet = Quiet(state, self._outbox, self._release, self._watchdog)

    @property
    def limits(self) -> PlannerLimits:
        return self._state.limits

    @property
    def sim_time_s(self) -> float:
        return self._state.sim_time_s

    @property
    def revision(self) -> int:
        """Bumped by every change of a component's state or a task's phase: the per-loop passes over every
        task (release, the watchdog, progress) run again only when something they read has changed."""
        return self._state.revision

    @revision.setter
    def revision(self, value: int) -> None:
        self._state.revision = value

    # --- observations ----------------------------------------------------------------------------------

    def observe_clock(self, sim_time_s: float) -> None:
        self._state.sim_time_s = max(self._state.sim_time_s, sim_time_s)

    def observe_component_state(self, msg: ComponentStateMsg) -> None:
        component = self._state.components.get(msg.guid)
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
        self._follow_up.apply(
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
        component = self._state.components.get(twin.guid)
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
            item = self._state.manifest[twin.guid]
            component.position_xy = body_centre_xy(item, pose.position_m, pose.quat_xyzw)
            component.pose = (pose.position_m, pose.quat_xyzw)
        event = twin.history[-1].event if twin.history else "sync"
        self._follow_up.apply(
            twin.guid,
            twin.state,
            event=event,
            attempt=twin.attempt,
            robot_id=twin.robot_id,
            sim_s=self._state.sim_time_s,
            reason=twin.reason,
        )

    def observe_component_pose(self, msg: ComponentPoseMsg) -> None:
        component = self._state.components.get(msg.guid)
        if component is not None:  # where its body lies (its frame's origin may be 100 m away)
            pose = msg.pose
            item = self._state.manifest[msg.guid]
            component.position_xy = body_centre_xy(item, pose.position_m, pose.quat_xyzw)
            component.pose = (pose.position_m, pose.quat_xyzw)
            self.observe_clock(msg.sim_time_s)

    def observe_robot_state(self, msg: RobotStateMsg) -> None:
        robot = self._state.robot(msg.robot_id)
        robot.state = msg.state
        robot.reported_task_id = msg.task_id
        if robot.rejoined and robot.alive:
            robot.rejoined = False
            task = self._state.tasks.get(robot.task_guid) if robot.task_guid is not None else None
            if task is not None and task.phase is Phase.ASSIGNED and msg.task_id != task.active_id:
                self._give_backs.give_back(
                    task.guid, f"robot {msg.robot_id} came back without its task (restarted)"
                )
        robot.pose_xy_yaw = msg.pose_xy_yaw
        robot.reported_busy_until_s = msg.busy_until_s
        if (robot.walled_in_since_s is None) != (msg.walled_in_since_s is None):
            x, y, _ = msg.pose_xy_yaw
            if msg.walled_in_since_s is not None:
                _log.warning(
                    "%s is walled in at (%.2f, %.2f) since %.1f s of sim time: no new task for it until it "
                    "can move again (unless no other robot can take one)",
                    msg.robot_id,
                    x,
                    y,
                    msg.walled_in_since_s,
                )
            else:
                _log.info("%s can move again (at (%.2f, %.2f)): it takes tasks again", msg.robot_id, x, y)
        robot.walled_in_since_s = msg.walled_in_since_s
        self.observe_clock(msg.sim_time_s)
        self._clear_aways.observe_robot(msg)

    def robot_liveliness(self, robot_id: str, alive: bool) -> None:
        """A robot's liveliness token appeared (``alive``) or disappeared (its task is given back)."""
        robot = self._state.robot(robot_id)
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
            robot.lost_wall_s = self._state.wall_s  # given back after the grace (GiveBacks.give_back_lost)

    def fail_at_start(self, reasons: dict[str, Reason]) -> None:
        """Fail, before anything is released, the components no robot on site can build (and block their
        dependents); components already terminal (a restarted planner) are left as they are."""
        tasks = self._state.tasks
        failing = [
            guid for guid in self._state.plan.order if guid in reasons and tasks[guid].phase not in FINAL
        ]
        for guid in failing:  # every one with its own reason first: a heavy wall on a heavy slab is too heavy
            _log.warning("%s cannot be built: %s", guid, reasons[guid].line())
            self._failures.fail(guid, reasons[guid], block=False)
        for guid in failing:
            self._failures.block_dependents(guid)

    def finish_sync(self) -> None:
        """Start-up sync is over: tasks held by robots that are not alive are given back."""
        self._state.synced = True
        for task in self._state.tasks.values():
            robot = self._state.robots.get(task.robot_id) if task.robot_id else None
            if task.phase is Phase.ASSIGNED and robot is not None and not robot.alive:
                self._give_backs.give_back(task.guid, f"robot {task.robot_id} is not alive")

    # --- decisions -------------------------------------------------------------------------------------

    def step(self, wall_time_s: float) -> list[Outgoing]:
        """Release the ready set, assign idle robots, (re)send what is due; the messages to publish."""
        self._state.wall_s = wall_time_s
        self._give_backs.give_back_lost()
        self._watchdog.watch()
        self._release.release_ready()
        self._clear_aways.step()  # before the build tasks: a body in the way first
        self._dispatch.assign()
        return self._outbox.due(wall_time_s)

    def quiet_until(self, min_skip_s: float = MIN_SKIP_S) -> Skip | None:
        """The skip the site allows now (:mod:`.quiet`), or None."""
        return self._quiet.quiet_until(min_skip_s)

    # --- queries ---------------------------------------------------------------------------------------

    @property
    def done(self) -> bool:
        """Every task final, and no failed body being carried out of the way."""
        return self._state.done and not self._clear_aways.in_flight()

    @property
    def clear_aways(self) -> ClearAways:
        """The clear-aways of failed bodies in the robots' way (:mod:`.clear_away`)."""
        return self._clear_aways

    def confirmed(self) -> bool:
        """Whether every component's agent said it is terminal (constructed, failed, blocked): a planner
        that decided everything at once must not end before the agents took what it sent."""
        return all(component.state in TERMINAL for component in self._state.components.values())

    def phase(self, guid: str) -> Phase:
        return self._state.tasks[guid].phase

    def in_flight(self) -> list[str]:
        """Components released or worked on: a state message of theirs that went missing would hold the
        build up, so the adapter asks their twins now and then."""
        tasks = self._state.tasks
        return [
            guid for guid in self._state.plan.order if tasks[guid].phase in (Phase.RELEASED, Phase.ASSIGNED)
        ]

    def robot_of(self, guid: str) -> str | None:
        return self._state.tasks[guid].robot_id

    def failed(self) -> list[str]:
        return [guid for guid in self._state.plan.order if self._state.tasks[guid].phase is Phase.FAILED]

    def blocked(self) -> list[str]:
        return [guid for guid in self._state.plan.order if self._state.tasks[guid].phase is Phase.BLOCKED]

    def alive_robots(self) -> list[str]:
        return sorted(robot.robot_id for robot in self._state.robots.values() if robot.alive)

    def progress(self) -> ProgressMsg:
        """Counts by component state, percent constructed, estimated sim time of the finish."""
        state = self._state
        counts = {component_state.value: 0 for component_state in ComponentState}
        for component in state.components.values():
            counts[component.state.value] += 1
        total = len(state.tasks)
        durations = [task.duration_sim_s for task in state.tasks.values() if task.duration_sim_s is not None]
        remaining = sum(1 for task in state.tasks.values() if task.phase not in FINAL)
        estimate = None
        if remaining == 0:
            estimate = state.sim_time_s
        elif durations:
            mean_s = sum(durations) / len(durations)
            estimate = state.sim_time_s + mean_s * remaining / max(1, len(self.alive_robots()))
        return ProgressMsg(
            total=total,
            counts=counts,
            percent_constructed=100.0 * counts[ComponentState.CONSTRUCTED.value] / total if total else 100.0,
            sim_time_s=state.sim_time_s,
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
        return self._release.curing_holds()

    def next_own_event_s(self) -> float | None:
        """The earliest sim time after now at which the planner acts with nothing heard: a curing hold ends
        (its task is released) or a robot's hold after its give-backs does (it may take a task again); None
        when none is ahead. Physics' plan fidelity jumps its clock no further (``StepDoneMsg.next_event_s``):
        it knows the robots' timed work, not these."""
        state = self._state
        ends = [hold.until_s for hold in self.curing_holds()]
        ends += [robot.held_until_s for robot in state.robots.values() if robot.alive]
        return min((end for end in ends if end > state.sim_time_s), default=None)

    def reasons(self) -> dict[str, Reason]:
        """GUID → why, for every failed and blocked component."""
        return {
            guid: task.reason
            for guid, task in self._state.tasks.items()
            if task.phase in (Phase.FAILED, Phase.BLOCKED) and task.reason is not None
        }

    def reason_of(self, guid: str) -> Reason | None:
        return self._state.tasks[guid].reason
