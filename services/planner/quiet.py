"""Quiet-site skips: when nothing on site can happen before a known sim time, say until when (pure).

Why: a cast slab cures for days and a crew pours for hours; stepped at the physics rate, a real building
would take weeks of wall time waiting. When the planner sees that nothing can happen before a known sim
time, it asks physics to skip its clock there (``physics/skip``; physics refuses if anything moves). The
decision is the planner's own, from its core, so a skip never jumps over something it would do.

The site is **quiet** (:meth:`Quiet.quiet_until`) when, with the robots' types known:

* no event or assignment of the planner is still on its way (each one is waiting for its effect);
* every alive robot is idle (holding no task of the planner's), or in timed work: state
  ``work_in_place`` with a ``busy_until_s`` after now (its own word: nothing of it changes before), or
  placing a component (state ``assemble``, the component ``assembling``): once set down at its target
  the robot holds it while its connection is made, for as long as the connection's kind takes. Only
  physics knows whether the load is still on its way or already held, and until when: the skip names
  those robots (:attr:`Skip.holding`) and physics refuses it unless each holds its load, and ends it at
  the earliest hold's end;
* no component is being carried, placed, verified or retried (picking, transporting, assembling,
  verifying, misplaced); a component worked on in place (forming, pouring, laying) is worked on by a
  robot in timed work; no assigned task waits for its robot to start;
* no released task could be taken by an idle robot now (one that can build it, or carry it for a
  hand-off); an idle robot that could but is held after give-backs makes its hold's end an event.

Then the next event is the earliest of: a curing hold's end, a robot's ``busy_until_s``, a held robot's
release, and the no-progress bound of a task worked on in place or being placed. A skip to it is
returned when it lies at least ``min_skip_s`` ahead; else None (not quiet, or nothing known to wait for).
"""

from __future__ import annotations

from dataclasses import dataclass

from bimbot.shared.messages import ComponentState, RobotState

from .capability import can_build_from, can_carry
from .outbox import Outbox
from .planner_state import PlannerState
from .records import FINAL, WORKING, Phase, RobotRecord
from .release import Release
from .watchdog import Watchdog

MIN_SKIP_S = 1.0  # a skip shorter than this is not worth a question to physics

#: Components something happens to soon: carried, placed, verified, or about to be retried.
MOVING = frozenset(
    {
        ComponentState.PICKING,
        ComponentState.TRANSPORTING,
        ComponentState.ASSEMBLING,
        ComponentState.VERIFYING,
        ComponentState.MISPLACED,
    }
)


@dataclass(frozen=True)
class Skip:
    """Nothing on site can happen before ``to_sim_s``; ``why`` names the event that ends the wait."""

    to_sim_s: float
    why: str
    holding: tuple[str, ...] = ()  # robots placing a load: physics skips only while each holds it


class Quiet:
    """The quiet-site decision over the records of ``state``: asks ``outbox`` what is on its way,
    ``release`` what cures until when, and ``watchdog`` the no-progress bound of timed work."""

    def __init__(self, state: PlannerState, outbox: Outbox, release: Release, watchdog: Watchdog) -> None:
        self._state = state
        self._outbox = outbox
        self._release = release
        self._watchdog = watchdog

    def quiet_until(self, min_skip_s: float = MIN_SKIP_S) -> Skip | None:
        """The skip the site allows now (see the module docstring), or None."""
        state = self._state
        if state.site is None or state.done or self._outbox.unsettled():
            return None
        events: list[tuple[float, str]] = []
        holding: list[str] = []
        for robot in state.robots.values():
            if not robot.alive:
                continue
            if self._in_timed_work(robot):
                assert robot.reported_busy_until_s is not None
                what = state.describe(robot.task_guid) if robot.task_guid else "its work"
                events.append((robot.reported_busy_until_s, f"{robot.robot_id} at work on {what}"))
            elif self._placing(robot):
                holding.append(robot.robot_id)
            elif robot.state is not RobotState.IDLE or robot.task_guid is not None:
                return None  # driving, lifting, not heard from, or about to take up a task
        for guid in state.plan.order:
            found = self._task_events(guid)
            if found is None:
                return None
            events.extend(found)
        events.extend(
            (hold.until_s, f"curing of {state.describe(hold.cast_guid)} (holds {state.describe(hold.guid)})")
            for hold in self._release.curing_holds()
        )
        if not events:
            return None
        to_sim_s, why = min(events)
        if to_sim_s - state.sim_time_s < min_skip_s:
            return None
        return Skip(to_sim_s, f"{why} until {to_sim_s:.0f} s", tuple(holding))

    def _task_events(self, guid: str) -> list[tuple[float, str]] | None:
        """What ``guid``'s task waits for (events), or None when something can happen to it now."""
        task, component_state = self._state.tasks[guid], self._state.components[guid].state
        if task.phase in FINAL or task.phase is Phase.WAITING:
            return []
        robot = self._state.robots.get(task.robot_id or "")
        placer = robot is not None and robot.task_guid == guid and self._placing(robot)
        if component_state is ComponentState.ASSEMBLING and placer:
            bound_s = self._watchdog.task_bound_s(task)
            return [(task.changed_sim_s + bound_s, f"the no-progress bound of {task.active_id}")]
        if component_state in MOVING:
            return None
        if task.phase is Phase.ASSIGNED:
            if component_state not in WORKING or robot is None or not self._in_timed_work(robot):
                return None  # not started yet, or worked on without a known end
            bound_s = self._watchdog.task_bound_s(task)
            return [(task.changed_sim_s + bound_s, f"the no-progress bound of {task.active_id}")]
        if component_state is not ComponentState.RELEASED:
            return None  # its release is on its way
        return self._held_takers(guid)

    def _held_takers(self, guid: str) -> list[tuple[float, str]] | None:
        """A released task: None when an idle robot could take it now; else the ends of the holds of the
        idle robots that could once held (none: it waits for a busy robot, or for none at all)."""
        state = self._state
        assert state.site is not None
        item, where = state.manifest[guid], state.lies(guid)
        events: list[tuple[float, str]] = []
        for robot in state.robots.values():
            site_robot = state.site.get(robot.robot_id)
            if not robot.alive or site_robot is None or robot.state is not RobotState.IDLE:
                continue
            if robot.task_guid is not None:
                continue
            if not (can_build_from(site_robot, item, where) or can_carry(site_robot, item)):
                continue
            if state.sim_time_s >= robot.held_until_s:
                return None
            events.append((robot.held_until_s, f"the hold of {robot.robot_id} after its give-backs"))
        return events

    def _placing(self, robot: RobotRecord) -> bool:
        """The robot places the component of its task (which it may hold while its connection is made)."""
        guid = robot.task_guid
        return (
            robot.state is RobotState.ASSEMBLE
            and guid is not None
            and guid in self._state.components
            and self._state.components[guid].state is ComponentState.ASSEMBLING
        )

    def _in_timed_work(self, robot: RobotRecord) -> bool:
        """The robot says it works in place until a sim time still ahead."""
        return (
            robot.state is RobotState.WORK_IN_PLACE
            and robot.reported_busy_until_s is not None
            and robot.reported_busy_until_s > self._state.sim_time_s
        )
