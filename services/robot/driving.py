"""Getting there: the executor's drive to an approach pose, re-chosen after failures, bounded (a mixin).

Why apart from :mod:`.executor`: the part of a task that decides *where* to stand and what to do when the
navigator fails. A navigation failure (after the navigator's own recovery chain, :mod:`.recovery`) is
answered by re-choosing the approach pose away from the stand-points that failed (every side of the
component), at most ``max_tries`` times; a search that finds no stand-point is repeated at most
``max_approach_misses`` times; then the task is given back (:mod:`.handover`) with the reason. Before the
pick-up the target is checked on the static map, so nothing is carried to a target cut off already.

Traffic: when the static map has a stand-point the robot can drive to and only its laser marks (what it
sees and the site plan does not: other robots and their loads) cut every one off, the blockage passes as
the others move on. The robot then keeps looking, one second of sim time apart, for up to
``traffic_wait_s`` (120 s) before it gives the task back, the reason saying so: ten looks in ten seconds
gave tasks back while another robot merely stood at the neighbouring slot, and three give-backs fail a
component (a ten-robot yard failed five components so in 1,300 s).
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

from bimbot.shared.footprint import Footprint
from bimbot.shared.messages import RobotState
from bimbot.shared.occupancy_grid import OccupancyGrid
from bimbot.shared.reasons import Reason

from .task_state import ExecutorConfig, Task

if TYPE_CHECKING:
    from .navigator import Navigator
    from .site_map import SiteMap
    from .task_machine import TaskMachine

from . import give_back
from .approach import ApproachConfig, approach_pose, no_approach_reason, within_reach
from .navigator import NavStatus

_log = logging.getLogger(__name__)
_S = RobotState


class Driving:
    """Approach poses and the drive to them, for :class:`.executor.Executor`."""

    config: ExecutorConfig
    robot_id: str
    sim_s: float
    site_map: SiteMap
    navigator: Navigator
    machine: TaskMachine
    approach_config: ApproachConfig
    home_xy_yaw: tuple[float, float, float]

    if TYPE_CHECKING:  # defined by :class:`.handover.Handover`, the executor's other mixin

        def _give_back(self, task: Task, reason: Reason) -> None: ...

        def _name(self, task: Task) -> str: ...

    def _target_cut_off(self, task: Task) -> Reason | None:
        """Why the target has no approach the robot could drive to on the static map (walls, built parts,
        stacks; laser marks left out, they pass), or None: checked before the pick-up, so that a component
        is never carried to a target cut off already."""
        grid = self.site_map.inflated_grid()
        xy = self.navigator.pose_xy_yaw[:2]
        blocks = self.site_map.blocks(task.target)
        if approach_pose(grid, task.target, xy, blocks_band=blocks, config=self.approach_config) is not None:
            return None
        return self._no_approach(task, grid, task.target, f"the target of {self._name(task)}")

    def _no_approach(self, task: Task, grid: OccupancyGrid, footprint: Footprint, what: str) -> Reason:
        return no_approach_reason(
            grid,
            footprint,
            self.navigator.pose_xy_yaw[:2],
            blocks_band=self.site_map.blocks(footprint),
            config=self.approach_config,
            what=what,
            robot=self.robot_id,
            radius_m=self.site_map.config.inflation_m,
            home_xy_m=self.home_xy_yaw[:2],
        ).model_copy(update={"robot_id": self.robot_id})

    def _drive(self, task: Task, footprint: Footprint | None) -> bool:
        """Drive to an approach pose beside ``footprint`` (found again after a failure); True once there."""
        status = self.navigator.status
        if task.approach is not None and status is NavStatus.REACHED:
            return True
        if (
            task.approach is not None
            and self.navigator.goal_blocked
            and footprint is not None
            and task.reselections < self.config.max_reselections
        ):
            # Laser marks (another robot, a load) now cover the chosen cell: pick another at once, which is
            # no navigation failure (counting it as one gave tasks up that a step aside would have done).
            task.reselections += 1
            self.navigator.cancel()
            task.approach = None
            self._approach(task, footprint)
            return False
        if task.approach is not None and status is NavStatus.FAILED and footprint is not None:
            here = self.navigator.pose_xy_yaw[:2]
            blocks = self.site_map.blocks(footprint)
            if within_reach(footprint, here, blocks_band=blocks, config=self.approach_config):
                return True  # not on the stand-point, but the reach rule holds here: close enough
        if task.approach is not None and status is NavStatus.FAILED:
            # The navigator ran its recovery chain: re-choose the approach pose (any side, not this one).
            task.tries += 1
            task.failed_xy_m.append(task.approach.xy_m)
            if task.tries >= self.config.max_tries:
                what = (
                    self._name(task)
                    if self.machine.state is _S.PICK_UP
                    else f"the target of {self._name(task)}"
                )
                self._give_back(
                    task, give_back.navigation_failed(self.robot_id, what, task.tries, self.navigator.failure)
                )
                return False
            task.approach, task.retry_at_s = (
                None,
                self.sim_s + self.config.retry_delay_s * min(task.tries, 10),
            )
            self.navigator.cancel()
        if task.approach is None and self.sim_s >= task.retry_at_s and footprint is not None:
            self._approach(task, footprint)
        return False

    def _approach(self, task: Task, footprint: Footprint) -> bool:
        # The navigator's own planning grid (laser marks inflated by its dynamic margin): an approach pose
        # free only in a less inflated grid is a goal A* can never reach, chosen again on every retry.
        self.navigator.see()
        grid = self.site_map.planning_grid(self.navigator.marks, self.navigator.config.dynamic_margin_m)
        xy = self.navigator.pose_xy_yaw[:2]
        blocks = self.site_map.blocks(footprint)
        config = self.approach_config
        found = approach_pose(
            grid, footprint, xy, blocks_band=blocks, config=config, avoid_xy_m=task.failed_xy_m
        )
        if found is None and task.failed_xy_m:  # every other side tried: the failed ones again
            found = approach_pose(grid, footprint, xy, blocks_band=blocks, config=config)
        if found is None:
            task.retry_at_s = self.sim_s + self.config.retry_delay_s
            traffic = approach_pose(
                self.site_map.inflated_grid(), footprint, xy, blocks_band=blocks, config=config
            )
            if traffic is not None:  # free on the static map: only what the laser sees blocks it
                if task.traffic_since_s is None:
                    task.traffic_since_s = self.sim_s
                    _log.info(
                        "%s: every stand-point of %s is blocked by traffic: waiting",
                        self.robot_id,
                        self._name(task),
                    )
                waited_s = self.sim_s - task.traffic_since_s
                if waited_s < self.config.traffic_wait_s:
                    return False
            else:
                task.misses += 1
                if task.misses < self.config.max_approach_misses:
                    return False
            carrying = self.machine.state not in (_S.DETECT_COMPONENT_POSITION, _S.PICK_UP)
            what = f"the target of {self._name(task)}" if carrying else self._name(task)
            reason = self._no_approach(task, grid, footprint, what)
            if traffic is not None:
                why = (
                    f"; for {waited_s:.0f} s, by what the laser saw and the site plan does not have (other "
                    "robots, their loads): on the site plan there is a way"
                )
                reason = reason.model_copy(update={"message": reason.message + why})
            self._give_back(task, reason)
            return False
        task.approach, task.traffic_since_s = found, None
        self.navigator.set_goal(found.xy_m, found.yaw_rad, self.sim_s)
        return True
