"""Giving released tasks to robots: nearest idle robot, or the capable robot with the best bid (a mixin).

Why apart from :mod:`.scheduler`: the scheduler follows the construction protocol (release, follow-up,
give-backs, bounds); this part only decides which robot gets which released task, and sends the
assignment. Without the site's robots (unit tests, a planner that got no site info) a task goes to the
nearest idle robot; with them, to the capable robot whose bid (estimated finish time) is lowest, or as a
hand-off to a crane's staging spot (:mod:`.assignment`).
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from functools import partial
from typing import TYPE_CHECKING

from bimbot.shared.manifest import Component
from bimbot.shared.messages import ComponentState, RobotState, TaskKind, TaskMsg, TaskStatus
from bimbot.shared.reasons import Reason, ReasonCode
from bimbot.shared.site_plan import YardSlot

from .assignment import choose, staged_where
from .capability import SiteRobot, Where, target_centre_xy
from .feasibility import slot_where
from .records import FINAL, ComponentRecord, Pending, Phase, RobotRecord, TaskRecord, distance
from .sources import Plan

_log = logging.getLogger(__name__)

MAX_HAND_OFFS = 2  # hand-off tasks per component; a third would be a loop: failed out_of_reach


class Dispatch:
    """Assignment of released tasks, for :class:`.scheduler.PlannerCore`."""

    _plan: Plan
    _tasks: dict[str, TaskRecord]
    _components: dict[str, ComponentRecord]
    _robots: dict[str, RobotRecord]
    _manifest: dict[str, Component]
    _site: Mapping[str, SiteRobot] | None
    _slots: Mapping[str, YardSlot]
    _pending: dict[tuple[str, str], Pending]
    sim_time_s: float
    revision: int

    if TYPE_CHECKING:  # defined by :class:`.scheduler.PlannerCore`

        def _task_msg(self, task: TaskRecord, status: TaskStatus) -> TaskMsg: ...

        def _fail(self, guid: str, reason: Reason, *, block: bool = True) -> None: ...

    def _assign(self) -> None:
        if self._site is not None:
            return self._assign_by_bids()
        for guid in self._plan.order:
            task = self._tasks[guid]
            component = self._components[guid]
            if task.phase is not Phase.RELEASED or component.state is not ComponentState.RELEASED:
                continue
            idle = [robot for robot in self._robots.values() if self._is_idle(robot)]
            if not idle:
                return
            # a robot that gave this task back gets it again only when no other alive robot could take it
            others_alive = any(
                r.alive and r.robot_id not in task.given_back_by for r in self._robots.values()
            )
            fresh = [robot for robot in idle if robot.robot_id not in task.given_back_by]
            if not fresh and others_alive:
                continue
            idle = fresh or idle
            where = component.position_xy or target_centre_xy(self._manifest[guid])
            robot = min(idle, key=lambda item: (distance(item.pose_xy_yaw, where), item.robot_id))
            self._give_to(task, robot, TaskKind.BUILD, None, estimate_s=0.0)

    def _assign_by_bids(self) -> None:
        """Every released task to the capable robot with the best bid (:mod:`.assignment`)."""
        assert self._site is not None
        if not any(self._is_idle(robot) for robot in self._robots.values()):
            return  # (before the staging spots in use: a pass over every component)
        promised: dict[str, float] = {}
        taken = self._taken_spots()
        for guid in self._plan.order:
            task = self._tasks[guid]
            component = self._components[guid]
            if task.phase is not Phase.RELEASED or component.state is not ComponentState.RELEASED:
                continue
            if not any(self._is_idle(robot) for robot in self._robots.values()):
                return
            item = self._manifest[guid]
            choice = choose(
                item,
                self._lies(guid),
                [robot for robot in self._robots.values() if self.sim_time_s >= robot.held_until_s],
                self._site,
                now_s=self.sim_time_s,
                promised_s=promised,
                avoid=task.given_back_by,
                taken_spots=taken,
            )
            if choice is None:
                continue
            if choice.kind is TaskKind.HAND_OFF and task.hand_offs >= MAX_HAND_OFFS:
                self._fail(guid, self._hand_offs_exhausted(task, item))
                continue
            robot = self._robots[choice.robot_id]
            if not choice.idle or not self._is_idle(robot):
                promised[choice.robot_id] = promised.get(choice.robot_id, 0.0) + choice.estimate_s
                continue
            if choice.put_down_xy_m is not None:
                taken.append(choice.put_down_xy_m)
            self._give_to(task, robot, choice.kind, choice.put_down_xy_m, estimate_s=choice.estimate_s)

    def _lies(self, guid: str) -> Where:
        """Where ``guid`` lies now: its last pose, else its yard slot (else its target)."""
        item, xy = self._manifest[guid], self._components[guid].position_xy
        return staged_where(item, xy) if xy is not None else slot_where(item, self._slots.get(guid))

    @staticmethod
    def _hand_offs_exhausted(task: TaskRecord, item: Component) -> Reason:
        return Reason(
            code=ReasonCode.OUT_OF_REACH,
            message=(
                f"{item.name or item.guid} was handed off {task.hand_offs} time(s) and still lies beyond the "
                f"hook of every crane that could place its {item.mass_kg:,.0f} kg"
            ),
        )

    def _taken_spots(self) -> list[tuple[float, float]]:
        """Staging spots in use: a hand-off on its way there, or a component lying in a staging area."""
        spots = [task.put_down_xy for task in self._tasks.values() if task.put_down_xy is not None]
        areas = [robot.staging for robot in (self._site or {}).values() if robot.staging is not None]
        for guid, component in self._components.items():
            xy = component.position_xy
            if xy is None or self._tasks[guid].phase in FINAL:
                continue
            if any(
                a.min_xy[0] <= xy[0] <= a.max_xy[0] and a.min_xy[1] <= xy[1] <= a.max_xy[1] for a in areas
            ):
                spots.append(xy)
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
        component = self._components[task.guid]
        task.kind, task.put_down_xy = kind, put_down_xy
        if kind is TaskKind.HAND_OFF:
            task.hand_offs += 1
        task.robot_id, robot.task_guid = robot.robot_id, task.guid
        robot.busy_until_s = self.sim_time_s + estimate_s
        task.phase = Phase.ASSIGNED
        self.revision += 1
        task.changed_sim_s = self.sim_time_s
        if task.assigned_sim_s is None:
            task.assigned_sim_s = self.sim_time_s
        what = f"hand-off to {put_down_xy[0]:.1f}, {put_down_xy[1]:.1f}" if put_down_xy else "build"
        _log.info(
            "%s (%s, %s) assigned to %s at %.1f s of sim time (estimate %.0f s)",
            task.active_id,
            task.guid,
            what,
            robot.robot_id,
            self.sim_time_s,
            estimate_s,
        )
        settled = partial(self._assignment_settled, task, robot, component, robot.robot_id, task.active_id)
        self._pending[(task.guid, "task")] = Pending(self._task_msg(task, TaskStatus.ASSIGNED), settled)

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
        return (
            robot.alive
            and robot.state is RobotState.IDLE
            and robot.task_guid is None
            and self.sim_time_s >= robot.held_until_s
        )
