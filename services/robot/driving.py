"""Getting there: a ground robot's drive to an approach pose, re-chosen after failures, bounded.

Why apart from :mod:`.executor`: the part of a task that decides *where* to stand and what to do when the
navigator fails. A navigation failure (after the navigator's own recovery chain, :mod:`.recovery`) is
answered by re-choosing the approach pose away from the stand-points that failed (every side of the
component), at most ``max_tries`` times; a search that finds no stand-point is repeated at most
``max_approach_misses`` times; then the task is given back (:class:`.handover.Handover`) with the reason.
Before the pick-up the target is checked on the static map, so nothing is carried to a target cut off
already.

Traffic: when the static map has a stand-point the robot can drive to and only its laser marks (what it
sees and the site plan does not: other robots and their loads) cut every one off, the blockage passes as
the others move on. The robot then keeps looking, one second of sim time apart, for up to
``traffic_wait_s`` (120 s) before it gives the task back, the reason saying so: ten looks in ten seconds
gave tasks back while another robot merely stood at the neighbouring slot, and three give-backs fail a
component (a ten-robot yard failed five components so in 1,300 s).

Rooms about to close: the parts the other robots are setting at their targets now count as standing when a
stand-point is chosen (:func:`.shut_in_check.theirs_setting`). On the Revit house with three carriers, r2
drove into a room to take up a door the crane had misplaced there while r1 and r3 were setting the two
studs that closed it; their placement checks had passed with r2 outside, and r2 stood walled in for 19 min.
A stand-point that only their parts cut off is waited for as traffic is: they stand in a moment, and the
way round them, or the give-back, follows. A robot already inside such a room works on: the others' checks
wait for it to leave.
"""

from __future__ import annotations

import logging

import numpy as np
from numpy.typing import NDArray

from bimbot.shared.footprint import Footprint
from bimbot.shared.messages import RobotState
from bimbot.shared.occupancy_grid import OccupancyGrid
from bimbot.shared.reasons import Reason, ReasonCode

from . import give_back
from .approach import approach_pose, no_approach_reason, sets_from_outside, way_out_after, within_reach
from .handover import Handover
from .navigator import NavStatus
from .robot_context import RobotContext
from .shut_in_check import joined_near, theirs_setting
from .task_cycle import TaskCycle
from .task_state import Task, component_name

_log = logging.getLogger(__name__)
_S = RobotState


class Driving:
    """Approach poses and the drive to them (a :class:`.robot_context.GettingThere` for a ground robot).

    Reads the task's state from ``cycle`` (what it carries decides how a failure is named) and gives a task
    back through ``handover``; keeps no state of its own (the tries are the task's)."""

    def __init__(self, context: RobotContext, cycle: TaskCycle, handover: Handover) -> None:
        self.context, self.cycle, self.handover = context, cycle, handover

    def target_cut_off(self, task: Task) -> Reason | None:
        """Why the target has no approach the robot could drive to on the static map (walls, built parts,
        stacks; laser marks left out, they pass), or None: checked before the pick-up, so that a component
        is never carried to a target cut off already."""
        site_map = self.context.site_map
        grid = site_map.inflated_grid()
        xy = self.context.navigator.pose_xy_yaw[:2]
        blocks = site_map.blocks(task.target)
        config = self.context.approach_config
        if approach_pose(grid, task.target, xy, blocks_band=blocks, config=config) is not None:
            return None
        return self._no_approach(grid, task.target, f"the target of {component_name(task)}")

    def _way_out(
        self,
        grid: OccupancyGrid,
        footprint: Footprint | None,
        theirs: list[NDArray[np.float64]] | None = None,
    ) -> NDArray[np.bool_] | None:
        """Where the robot can still leave for its depot from once ``footprint`` (its band parts; None: no
        part of its own) and the parts of outlines ``theirs`` stand; None when neither has any."""
        site_map = self.context.site_map
        band = site_map.config
        outlines = footprint.outlines_meeting(band.band_min_z_m, band.band_max_z_m) if footprint else []
        outlines = outlines + (theirs or [])
        if not outlines:
            return None
        return way_out_after(grid, outlines, self.context.home_xy_yaw[:2], site_map.config.inflation_m)

    def _leaves_from(self, footprint: Footprint, xy_m: tuple[float, float]) -> bool:
        """Whether the robot, setting ``footprint`` from ``xy_m`` where it stands, still has a way back to
        its depot once it stands (always, when it is picking up or the component leaves its band free):
        a drive that failed short of its stand-point is close enough only then. A robot held in an inflated
        cell counts by the free cells within its inflation of it (on its own side of what it sets)."""
        placing = self.cycle.state not in (_S.DETECT_COMPONENT_POSITION, _S.PICK_UP)
        site_map = self.context.site_map
        if not placing or not site_map.blocks(footprint):
            return True
        grid = site_map.inflated_grid()
        way_out = self._way_out(grid, footprint)
        if way_out is None:
            return True  # no band outline: it closes nothing
        return joined_near(grid, way_out, xy_m, site_map.config.inflation_m)

    def _walls_itself_in(self, footprint: Footprint, xy: tuple[float, float]) -> bool:
        """Whether, on the static map (laser marks left out: they pass), no stand-point within reach of
        ``footprint`` keeps the robot a way back to its depot once it stands."""
        site_map, config = self.context.site_map, self.context.approach_config
        static = site_map.inflated_grid()
        way_out = self._way_out(static, footprint)
        if way_out is None:
            return True
        found = approach_pose(static, footprint, xy, blocks_band=True, config=config, way_out=way_out)
        return found is None or not _leaves(static, way_out, found.xy_m)

    def _no_approach(self, grid: OccupancyGrid, footprint: Footprint, what: str) -> Reason:
        """Why no stand-point beside ``footprint`` is found; a robot walled in names what stands beside it
        (the run summary's walled-in line sends the reader to this log for it)."""
        context = self.context
        here = context.navigator.pose_xy_yaw[:2]
        reason = no_approach_reason(
            grid,
            footprint,
            here,
            blocks_band=context.site_map.blocks(footprint),
            config=context.approach_config,
            what=what,
            robot=context.robot_id,
            radius_m=context.site_map.config.inflation_m,
            home_xy_m=context.home_xy_yaw[:2],
        )
        update: dict[str, object] = {"robot_id": context.robot_id}
        if reason.code is ReasonCode.ROBOT_TRAPPED:
            update["message"] = reason.message + context.beside_words((float(here[0]), float(here[1])))
        return reason.model_copy(update=update)

    def drive(self, task: Task, footprint: Footprint | None) -> bool:
        """Drive to an approach pose beside ``footprint`` (found again after a failure); True once there."""
        context = self.context
        navigator, config = context.navigator, context.config
        status = navigator.status
        if task.approach is not None and status is NavStatus.REACHED:
            return True
        if (
            task.approach is not None
            and navigator.goal_blocked
            and footprint is not None
            and task.reselections < config.max_reselections
        ):
            # Laser marks (another robot, a load) now cover the chosen cell: pick another at once, which is
            # no navigation failure (counting it as one gave tasks up that a step aside would have done).
            task.reselections += 1
            navigator.cancel()
            task.approach = None
            self.approach(task, footprint)
            return False
        if task.approach is not None and status is NavStatus.FAILED and footprint is not None:
            here = navigator.pose_xy_yaw[:2]
            # a load to be taken up need not be kept clear of: a robot held where it stands by the very
            # body it is to pick up (it fell beside it) takes it from there
            blocks = context.site_map.blocks(footprint) and self.cycle.state is not _S.PICK_UP
            if within_reach(
                footprint, here, blocks_band=blocks, config=context.approach_config
            ) and self._leaves_from(footprint, here):
                return True  # not on the stand-point, but the reach rule holds here: close enough
        if task.approach is not None and status is NavStatus.FAILED:
            # The navigator ran its recovery chain: re-choose the approach pose (any side, not this one).
            task.tries += 1
            task.failed_xy_m.append(task.approach.xy_m)
            if task.tries >= config.max_tries:
                name = component_name(task)
                what = name if self.cycle.state is _S.PICK_UP else f"the target of {name}"
                failed = give_back.navigation_failed(context.robot_id, what, task.tries, navigator.failure)
                self.handover.give_back(task, failed)
                return False
            task.approach, task.retry_at_s = (
                None,
                context.sim_s + config.retry_delay_s * min(task.tries, 10),
            )
            navigator.cancel()
        if task.approach is None and context.sim_s >= task.retry_at_s and footprint is not None:
            self.approach(task, footprint)
        return False

    def approach(self, task: Task, footprint: Footprint) -> bool:
        """Choose an approach pose beside ``footprint`` and set off for it (True); none free: wait for
        traffic, or count a miss, and give the task back after the bound (False)."""
        context = self.context
        navigator, site_map, bounds = context.navigator, context.site_map, context.config
        # The navigator's own planning grid (laser marks inflated by its dynamic margin): an approach pose
        # free only in a less inflated grid is a goal A* can never reach, chosen again on every retry.
        navigator.see()
        grid = site_map.planning_grid(navigator.marks, navigator.config.dynamic_margin_m)
        xy = navigator.pose_xy_yaw[:2]
        blocks = site_map.blocks(footprint)
        config = context.approach_config
        # An enclosing element is set from outside the structure where it can; after a failed drive, any side.
        enclosing = sets_from_outside(task.component.ifc_class) and not task.failed_xy_m
        outside = site_map.layout.structure if enclosing else None
        placing = self.cycle.state not in (_S.DETECT_COMPONENT_POSITION, _S.PICK_UP)
        own = footprint if placing and blocks else None
        setting, theirs = theirs_setting(context, task.message.guid)
        way_out = self._way_out(grid, own, theirs)
        if theirs and not joined_near(grid, way_out, xy, site_map.config.inflation_m):
            # inside the room their parts close already: theirs wait for it to set its part and leave
            setting, way_out = [], self._way_out(grid, own)
        found = approach_pose(
            grid,
            footprint,
            xy,
            blocks_band=blocks,
            config=config,
            avoid_xy_m=task.failed_xy_m,
            outside_of=outside,
            way_out=way_out,
        )
        if found is None and task.failed_xy_m:  # every other side tried: the failed ones again
            found = approach_pose(grid, footprint, xy, blocks_band=blocks, config=config, way_out=way_out)
        if found is not None and way_out is not None and not _leaves(grid, way_out, found.xy_m):
            # every stand-point walls it in once the component stands: on the static map too, it is no
            # place to set it from (given back: a crane is asked first); else only traffic hides the way,
            # or the parts the others are setting now close it (waited for as traffic)
            if placing and blocks and self._walls_itself_in(footprint, xy):
                reason = give_back.walls_itself_in(context.robot_id, component_name(task), config.reach_m)
                self.handover.give_back(task, reason)
                return False
            found = None
        if found is None:
            task.retry_at_s = context.sim_s + bounds.retry_delay_s
            traffic = approach_pose(
                site_map.inflated_grid(), footprint, xy, blocks_band=blocks, config=config
            )
            if traffic is not None:  # free on the static map: only what the laser sees blocks it
                if task.traffic_since_s is None:
                    task.traffic_since_s = context.sim_s
                    _log.info(
                        "%s: every stand-point of %s is blocked by traffic%s: waiting",
                        context.robot_id,
                        component_name(task),
                        f", or shut in by what {', '.join(setting)} set now" if setting else "",
                    )
                waited_s = context.sim_s - task.traffic_since_s
                if waited_s < bounds.traffic_wait_s:
                    return False
            else:
                task.misses += 1
                if task.misses < bounds.max_approach_misses:
                    return False
            carrying = self.cycle.state not in (_S.DETECT_COMPONENT_POSITION, _S.PICK_UP)
            what = f"the target of {component_name(task)}" if carrying else component_name(task)
            reason = self._no_approach(grid, footprint, what)
            if traffic is not None:
                why = (
                    f"; for {waited_s:.0f} s, by what the laser saw and the site plan does not have (other "
                    "robots, their loads): on the site plan there is a way"
                )
                reason = reason.model_copy(update={"message": reason.message + why})
            self.handover.give_back(task, reason)
            return False
        task.approach, task.traffic_since_s = found, None
        navigator.set_goal(found.xy_m, found.yaw_rad, context.sim_s)
        return True


def _leaves(grid: OccupancyGrid, way_out: NDArray[np.bool_], xy_m: tuple[float, float]) -> bool:
    """Whether the stand-point ``xy_m`` lies in ``way_out`` (cells of ``grid`` that keep a way home)."""
    row, col = (int(v) for v in grid.world_to_cell(np.asarray(xy_m, float)))
    rows, cols = way_out.shape
    return 0 <= row < rows and 0 <= col < cols and bool(way_out[row, col])
