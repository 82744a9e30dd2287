"""Giving released tasks to robots: nearest idle robot, or the capable robot with the best bid (step 2).

Why apart from the rest of the protocol (release, follow-up, give-backs, bounds): this part only decides
which robot gets which released task, and sends the assignment. Without the site's robots (unit tests, a
planner that got no site info) a task goes to the nearest idle robot; with them, to the capable robot
whose bid (estimated finish time) is lowest, or as a hand-off to a crane's staging spot
(:mod:`.assignment`). A robot that gave the task back, or says it is walled in (no way to its depot), gets
it only when no other robot can take it; and a robot walled in for less than ``WALLED_IN_WAIT_S`` of sim
time gets no task at all: a way is often shut only for a while (a crane's load passing, a panel being set
beside it), and giving it the one task only it could take burned that task's three give-backs in 200 s
(the Revit duplex's 4.8 m window, failed ``robot_trapped`` while its carrier was out again 700 s later).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from functools import partial

from bimbot.shared.manifest import Component
from bimbot.shared.messages import ComponentState, RobotState, TaskKind
from bimbot.shared.reasons import CANNOT_GET_THERE, Reason, ReasonCode

from .assignment import StagedLoad, choose, lying_half_m
from .capability import SiteRobot, Where, can_build_from, can_carry, relocation_to_s, target_centre_xy
from .failures import Failures
from .outbox import Outbox
from .planner_state import PlannerState
from .records import FINAL, ComponentRecord, Phase, RobotRecord, TaskRecord, distance
from .work_in_place import works_in_place

_log = logging.getLogger(__name__)

MAX_HAND_OFFS = 2  # hand-off tasks per component; a third would be a loop: failed out_of_reach
# while no component or task changed and the same robots are idle, the bids are asked again only this often
# (sim s): they still move with time and the robots' poses (a busy robot's bid can come to lose to an idle
# one's), but a pass over every released task and robot at every 0.2 s period was most of the planner's
# time on a 988-component site
REBID_S = 2.0
# sim s a robot that says it is walled in gets no task: its way out may open again (bounded: after this, it
# bids as a robot to avoid, and a task it cannot do fails with its reason after its give-backs)
WALLED_IN_WAIT_S = 1800.0


class Dispatch:
    """Assigns released tasks to idle robots (in the records of ``state``); sends each assignment through
    ``outbox``, and fails through ``failures`` a component handed off too often."""

    def __init__(
        self,
        state: PlannerState,
        outbox: Outbox,
        failures: Failures,
        *,
        holds: Callable[[TaskRecord], bool] = lambda _task: False,
    ) -> None:
        """``holds``: whether a released task waits for a failed body to be cleared out of the way."""
        self._state = state
        self._outbox = outbox
        self._failures = failures
        self._holds = holds
        # (robot, component, where it lies) → whether the robot can build it from there: asked for every
        # released task and robot at every step, and unchanged while the site's robots are the same
        self._able: dict[tuple[str, str, Where], bool] = {}
        self._able_site: object = None
        self._last_bids: tuple[int, frozenset[str], float] | None = None  # revision, idle robots, sim s

    def _can_build(self, robot: SiteRobot, component: Component, where: Where) -> bool:
        """:func:`.capability.can_build_from`, remembered for the site's robots in force."""
        if self._able_site is not self._state.site:
            self._able.clear()
            self._able_site = self._state.site
        key = (robot.robot_id, component.guid, where)
        able = self._able.get(key)
        if able is None:
            able = self._able[key] = can_build_from(robot, component, where)
        return able

    def assign(self) -> None:
        """Give every released task whose component reports released to a robot, if one can take it."""
        state = self._state
        if state.site is not None:
            return self._assign_by_bids()
        for guid in state.plan.order:
            task = state.tasks[guid]
            component = state.components[guid]
            if not self._released(guid):
                continue
            if self._holds(task):
                continue
            idle = [robot for robot in state.robots.values() if self._is_idle(robot)]
            if not idle:
                return
            # a robot that gave this task back, or is walled in, gets it only when no other alive robot could
            avoid = self._avoid(task)
            others_alive = any(r.alive and r.robot_id not in avoid for r in state.robots.values())
            fresh = [robot for robot in idle if robot.robot_id not in avoid]
            if not fresh and others_alive:
                continue
            idle = fresh or idle
            where = component.position_xy or target_centre_xy(state.manifest[guid])
            robot = min(idle, key=lambda item: (distance(item.pose_xy_yaw, where), item.robot_id))
            self._give_to(task, robot, TaskKind.BUILD, None, estimate_s=0.0)

    def _assign_by_bids(self) -> None:
        """Every released task to the capable robot with the best bid (:mod:`.assignment`)."""
        state = self._state
        assert state.site is not None
        idle = frozenset(robot.robot_id for robot in state.robots.values() if self._is_idle(robot))
        if not idle:
            return  # (before the staging spots in use: a pass over every component)
        last = self._last_bids
        if last is not None and last[:2] == (state.revision, idle) and state.sim_time_s - last[2] < REBID_S:
            return  # nothing changed since the last pass but the clock, by less than REBID_S
        self._last_bids = (state.revision, idle, state.sim_time_s)
        bidders = self._could_win(idle)
        promised: dict[str, float] = {}
        taken = self._taken_spots()
        for guid in self._round_order(idle):
            task = state.tasks[guid]
            if self._holds(task):
                continue
            if not any(self._is_idle(state.robots[robot_id]) for robot_id in bidders):
                return  # the rest of the round would only promise work to busy robots
            item = state.manifest[guid]
            choice = choose(
                item,
                state.lies(guid),
                [
                    robot
                    for robot in state.robots.values()
                    if self._may_bid(robot) and self._may_retry(task, robot)
                ],
                state.site,
                now_s=state.sim_time_s,
                promised_s=promised,
                avoid=self._avoid(task),
                taken_spots=taken,
                able_to_build=self._can_build,
                crane_first=guid in state.plan.from_above or _target_out_of_ground_reach(task),
            )
            if choice is None:
                continue
            if choice.kind is TaskKind.HAND_OFF and task.hand_offs >= MAX_HAND_OFFS:
                self._failures.fail(guid, self._hand_offs_exhausted(task, item))
                continue
            robot = state.robots[choice.robot_id]
            if not choice.idle or not self._is_idle(robot):
                promised[choice.robot_id] = promised.get(choice.robot_id, 0.0) + choice.estimate_s
                continue
            if choice.put_down_xy_m is not None:
                taken.append(StagedLoad(choice.put_down_xy_m, lying_half_m(item)))
            self._give_to(task, robot, choice.kind, choice.put_down_xy_m, estimate_s=choice.estimate_s)

    def _round_order(self, idle: frozenset[str]) -> list[str]:
        """The released tasks a round offers, in plan order, except that an idle machine that relocates
        between set-ups works out the set-up it stands at first: the work only it can do that it would
        relocate for goes after the work its boom covers from where it stands. (A piling rig was offered
        the structural sample's 216 piles in the model's order, across the site and back: 11 relocations
        of half an hour.) Work another machine can also do keeps its place: deferred, a pour the boom pump
        would relocate for went to the slower line pump, and the restaurant took 5.7 % longer."""
        state = self._state
        assert state.site is not None
        order = [guid for guid in state.plan.order if self._released(guid)]
        manifest = state.manifest
        for robot_id in sorted(idle):
            robot = state.site.get(robot_id)
            pose = state.robots[robot_id].pose_xy_yaw
            if robot is None or not robot.description.relocates or pose is None:
                continue
            others = [
                other
                for other in state.site.values()
                if other.robot_id != robot_id
                and (record := state.robots.get(other.robot_id)) is not None
                and record.alive
            ]
            mine = [
                guid
                for guid in order
                if works_in_place(manifest[guid]) and self._can_build(robot, manifest[guid], state.lies(guid))
            ]
            later = {
                guid
                for guid in mine
                if relocation_to_s(robot, pose[:2], manifest[guid]) > 0.0
                and not any(self._can_build(other, manifest[guid], state.lies(guid)) for other in others)
            }
            if later and len(later) < len(mine):
                order = [g for g in order if g not in later] + [g for g in order if g in later]
        return order

    def _released(self, guid: str) -> bool:
        """Its task released and its agent reporting released: a task a round may give out."""
        state = self._state
        return (
            state.tasks[guid].phase is Phase.RELEASED
            and state.components[guid].state is ComponentState.RELEASED
        )

    def _could_win(self, idle: frozenset[str]) -> list[str]:
        """The idle robots that can build or carry some released component where it lies: only they can
        be given a task this round. (A machine with nothing of its kind left, a pump once the pours are
        done, stays idle all run: the round went on through every released component, bids and all, for
        a winner that could never be it.)"""
        state = self._state
        assert state.site is not None
        order = state.plan.order
        released = [(state.manifest[guid], state.lies(guid)) for guid in order if self._released(guid)]
        robots = [state.site[robot_id] for robot_id in sorted(idle) if robot_id in state.site]
        return [
            robot.robot_id
            for robot in robots
            if any(can_carry(robot, item) or self._can_build(robot, item, where) for item, where in released)
        ]

    def _may_bid(self, robot: RobotRecord) -> bool:
        """Not held after give-backs, nor walled in for less than ``WALLED_IN_WAIT_S`` (see the module)."""
        now_s = self._state.sim_time_s
        if now_s < robot.held_until_s:
            return False
        return robot.walled_in_since_s is None or now_s - robot.walled_in_since_s >= WALLED_IN_WAIT_S

    def _may_retry(self, task: TaskRecord, robot: RobotRecord) -> bool:
        """Not a robot that gave ``task`` back less than the limits' ``hold_s`` ago: its way was shut, and
        the world it found unchanged two seconds later shuts it again (FZK-Haus's roof panel: its carrier
        found the crane's staging spot cut off, was given the hand-off again 2.4 s later, found the same
        and spent the panel's last hand-off; 60 s later the way was open)."""
        return (
            robot.robot_id not in task.given_back_by
            or task.given_back_s is None
            or self._state.sim_time_s - task.given_back_s >= self._state.limits.hold_s
        )

    def _avoid(self, task: TaskRecord) -> set[str]:
        """The robots that bid for ``task`` only when no other can take it: those that gave it back, and
        those that say they are walled in (they would give it back too)."""
        walled_in = {r.robot_id for r in self._state.robots.values() if r.walled_in_since_s is not None}
        return task.given_back_by | walled_in

    @staticmethod
    def _hand_offs_exhausted(task: TaskRecord, item: Component) -> Reason:
        """Why the hand-offs ran out: the last give-back when none was put down, else the crane's reach."""
        last = task.last_give_back
        if last is not None and task.hand_offs_given_back >= task.hand_offs:
            message = (
                f"every hand-off of it to a crane ({task.hand_offs}) was given back by the robot carrying "
                f"it; last: {last.message}"
            )
            return last.model_copy(update={"message": message[:2000]})
        return Reason(
            code=ReasonCode.OUT_OF_REACH,
            message=(
                f"{item.name or item.guid} was handed off {task.hand_offs} time(s) and still lies beyond the "
                f"hook of every crane that could place its {item.mass_kg:,.0f} kg"
            ),
        )

    def _taken_spots(self) -> list[StagedLoad]:
        """Staging spots in use: a hand-off on its way there, or a component lying in a staging area."""
        state = self._state
        spots = [
            StagedLoad(task.put_down_xy, lying_half_m(state.manifest[guid]))
            for guid, task in state.tasks.items()
            if task.put_down_xy is not None
        ]
        areas = [robot.staging for robot in (state.site or {}).values() if robot.staging is not None]
        for guid, component in state.components.items():
            xy = component.position_xy
            if xy is None or state.tasks[guid].phase in FINAL:
                continue
            if any(
                a.min_xy[0] <= xy[0] <= a.max_xy[0] and a.min_xy[1] <= xy[1] <= a.max_xy[1] for a in areas
            ):
                spots.append(StagedLoad(xy, lying_half_m(state.manifest[guid])))
        return spots

    def _give_to(
        self,
        task: TaskRecord,
        robot: RobotRecord,
        kind: TaskKind,
        put_down_xy: tuple[float, float] | None,
        *,
        estimate_s: float,
    ) -> None:
        state = self._state
        component = state.components[task.guid]
        task.kind, task.put_down_xy = kind, put_down_xy
        if kind is TaskKind.HAND_OFF:
            task.hand_offs += 1
        task.robot_id, robot.task_guid = robot.robot_id, task.guid
        robot.busy_until_s = state.sim_time_s + estimate_s
        task.phase = Phase.ASSIGNED
        state.revision += 1
        task.changed_sim_s = state.sim_time_s
        if task.assigned_sim_s is None:
            task.assigned_sim_s = state.sim_time_s
        what = f"hand-off to {put_down_xy[0]:.1f}, {put_down_xy[1]:.1f}" if put_down_xy else "build"
        _log.info(
            "%s (%s, %s) assigned to %s at %.1f s of sim time (estimate %.0f s)",
            task.active_id,
            task.guid,
            what,
            robot.robot_id,
            state.sim_time_s,
            estimate_s,
        )
        settled = partial(self._assignment_settled, task, robot, component, robot.robot_id, task.active_id)
        self._outbox.send_assignment(task, settled)

    @staticmethod
    def _assignment_settled(
        task: TaskRecord, robot: RobotRecord, component: ComponentRecord, robot_id: str | None, task_id: str
    ) -> bool:
        return (
            task.phase is not Phase.ASSIGNED
            or task.robot_id != robot_id
            or task.active_id != task_id
            or robot.reported_task_id == task_id
            or component.state is not ComponentState.RELEASED
        )

    def _is_idle(self, robot: RobotRecord) -> bool:
        """Alive, reported idle, holding no task of the planner's and not held after give-backs."""
        return (
            robot.alive
            and robot.state is RobotState.IDLE
            and robot.task_guid is None
            and self._state.sim_time_s >= robot.held_until_s
        )


def _target_out_of_ground_reach(task: TaskRecord) -> bool:
    """The task's last give-back says a ground robot could not get to it: a crane is asked first."""
    last = task.last_give_back
    return last is not None and last.code in CANNOT_GET_THERE
