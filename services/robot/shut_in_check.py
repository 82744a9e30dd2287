"""Which robots a placement would shut in, checked by the robot about to place it (pure).

Why: the planner holds a part back at its release while placing it would shut a robot into a room
(:mod:`bimbot.services.planner.shut_in`), but robots move after a release. On the Revit house with three
carriers, r2 drove into a room to set a partition panel; another panel that closed the same room had
been released while r2 was outside, and r2 stood walled in for the rest of the run (80 h of sim time). A
site sets no wall that closes a room with a machine in it. So the robot that is about to place a
component that blocks the robots' height band asks, with its own map, which of the other robots that
drive are joined to their depot now and would not be once the component stands (on the map inflated by
each one's own radius); it waits while there is one (:mod:`.executor`).

A robot stands on a free cell of its own inflated grid or, held close to a wall, in its inflation: it
counts as joined when a joined cell lies within its inflation radius (one cell more) of where it said it
stood (:func:`joined_near`). What lies across the component it sets is farther than that.

Two robots may set the two parts that close a room at the same moment, each checking the site as it
stands: on the Revit house with three carriers, r2 set a partition panel from inside while one gap was
open, and a stud r1 set at the same time closed that gap (r2 walled in for 24.5 min). So a check counts
the parts the other robots are setting at their targets now (their state messages, :func:`note_placing`)
as standing too, and holds a placement for a robot that its part and theirs shut in together and theirs
alone would not, or that its part alone shuts in (a mullion and its glazing panel close one gap each
alone: two checks that each left it to the other let both go). A part set down already stands on the map,
its robot's check done: it is not theirs to check any more. The robot inside is not held by its own
check: it sets its part and drives out, and the robot outside waits for that.

A part set down and not joined lies loose: it is judged, and joined at its target or taken up by its
retry and set there. The check sees past it, as set at its target (:meth:`.site_map.SiteMap.loose_targets`):
a part judged misplaced across a room's gap neither counts a robot inside as walled in already nor hides
that its retry will close that gap.

Cost: two labellings of the free grid for each size of robot on site (the depots lie in one depot area,
joined to each other, so one depot stands for all robots of a size), once a placement and then every
few seconds of sim time while one is held.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from bimbot.shared.footprint import posed_footprint
from bimbot.shared.manifest import Component
from bimbot.shared.messages import RobotState, RobotStateMsg, TaskKind
from bimbot.shared.occupancy_grid import OccupancyGrid

from .approach import reachable_region, way_out_after
from .robot_context import RobotContext
from .site_map import STATIC_DISTANCE_MAX_M, SiteMap
from .task_state import ExecutorConfig, Task, component_name

_log = logging.getLogger(__name__)

# a robot in these states on a build task is setting its part at its target (carried there, or worked in
# place): the part counts as standing for the others' checks
PLACING_STATES = frozenset({RobotState.ASSEMBLE, RobotState.WORK_IN_PLACE})


def note_placing(
    context: RobotContext, message: RobotStateMsg, component: Component | None, kind: TaskKind | None
) -> None:
    """Keep in ``context.others_placing`` what another robot says it is setting at its target now: the
    band outlines of ``component`` at its BIM target while ``message`` is in a :data:`PLACING_STATES` state of
    a build task (``kind``; a hand-off goes down at a staging spot, a clear-away at a yard slot), else
    nothing for that robot."""
    if message.state not in PLACING_STATES or component is None or kind is not TaskKind.BUILD:
        context.others_placing.pop(message.robot_id, None)
        return
    known = context.others_placing.get(message.robot_id)
    if known is not None and known[0] == component.guid:
        return
    band = context.site_map.config
    target = component.target_pose_world
    footprint = posed_footprint(component, target.position_m, target.quat_xyzw)
    outlines = footprint.outlines_meeting(band.band_min_z_m, band.band_max_z_m)
    context.others_placing[message.robot_id] = (component.guid, outlines)


def joined_near(
    grid: OccupancyGrid, joined: NDArray[np.bool_] | None, xy_m: Sequence[float], radius_m: float
) -> bool:
    """Whether a cell of ``joined`` (cells of ``grid`` that reach a depot; None: none) lies within
    ``radius_m`` of ``xy_m``."""
    if joined is None:
        return False
    cells = math.ceil(radius_m / grid.resolution_m) + 1
    row, col = (int(v) for v in grid.world_to_cell(np.asarray(xy_m, float)))
    rows, cols = joined.shape
    r0, r1 = max(0, row - cells), min(rows, row + cells + 1)
    c0, c1 = max(0, col - cells), min(cols, col + cells + 1)
    if r0 >= r1 or c0 >= c1:
        return False
    near = np.hypot(*np.ogrid[r0 - row : r1 - row, c0 - col : c1 - col]) <= cells
    return bool((joined[r0:r1, c0:c1] & near).any())


def ways_out(
    site_map: SiteMap,
    outlines_xy_m: Sequence[NDArray[np.float64]],
    drivers: Mapping[str, tuple[float, tuple[float, float]]],
    others_xy: Mapping[str, tuple[float, float]],
    placing: str | None = None,
) -> dict[str, tuple[bool, bool]]:
    """For each robot of ``drivers`` (id → its inflation radius and depot start) where ``others_xy`` says
    it stands: whether it reaches its depot on ``site_map`` now, and once a component of these band
    outlines (``placing``, its guid) stands. Parts lying loose (set down, not joined) are seen past, as set
    at their targets (:meth:`.site_map.SiteMap.loose_targets`)."""
    loose, loose_outlines = site_map.loose_targets(but=placing)
    status = {}
    regions: dict[float, tuple[OccupancyGrid, NDArray[np.bool_] | None, NDArray[np.bool_] | None]] = {}
    for robot_id in sorted(others_xy):
        if robot_id not in drivers:
            continue
        radius_m, depot_xy = drivers[robot_id]
        if radius_m >= STATIC_DISTANCE_MAX_M:
            continue  # wider than the map's distance field goes: not checked (none of bimbot's types)
        if radius_m not in regions:  # once per robot size: the depots lie in one yard, joined to each other
            if loose:
                grid = site_map.inflated_grid_without(loose, radius_m)
                before = way_out_after(grid, loose_outlines, depot_xy, radius_m)
            else:
                grid = site_map.inflated_grid(radius_m)
                before = reachable_region(grid, depot_xy)
            after = way_out_after(grid, [*outlines_xy_m, *loose_outlines], depot_xy, radius_m)
            regions[radius_m] = (grid, before, after)
        grid, before, after = regions[radius_m]
        xy = others_xy[robot_id]
        status[robot_id] = (joined_near(grid, before, xy, radius_m), joined_near(grid, after, xy, radius_m))
    return status


def shut_in_by(
    site_map: SiteMap,
    outlines_xy_m: Sequence[NDArray[np.float64]],
    drivers: Mapping[str, tuple[float, tuple[float, float]]],
    others_xy: Mapping[str, tuple[float, float]],
    placing: str | None = None,
) -> list[str]:
    """The robots that reach their depot now and would not once a component of these band outlines
    stands (:func:`ways_out`); sorted. One walled in already is not this placement's doing."""
    if not outlines_xy_m:
        return []
    status = ways_out(site_map, outlines_xy_m, drivers, others_xy, placing)
    return [robot_id for robot_id, (now, then) in status.items() if now and not then]


def walled_in_already(context: RobotContext, robot_ids: Sequence[str]) -> list[str]:
    """Of ``robot_ids``, those with no way to their depot now, the loose parts seen past (:func:`ways_out`
    with nothing added)."""
    asked = {robot_id: context.others_xy[robot_id] for robot_id in robot_ids if robot_id in context.others_xy}
    status = ways_out(context.site_map, [], context.drivers, asked)
    return [robot_id for robot_id, (now, _) in status.items() if not now]


def theirs_setting(context: RobotContext, guid: str) -> tuple[list[str], list[NDArray[np.float64]]]:
    """The other robots setting a part other than ``guid`` at its target now, and those parts' band
    outlines (``context.others_placing``). A part set down already (held while its connection is made, or
    being judged) stands on the map, its robot's check done: it is no longer theirs to check. On the Revit
    house with three carriers, r1's stud waited for r2 inside; once r2's panel and r4's door stood, both
    robots still holding them, "theirs alone" shut r2 in, r1 left it to their checks, set the stud, and
    r2 was walled in."""
    site_map = context.site_map
    setting = sorted(
        robot_id
        for robot_id, (other_guid, _) in context.others_placing.items()
        if other_guid != guid and robot_id != context.robot_id and not site_map.set_down(other_guid)
    )
    return setting, [outline for robot_id in setting for outline in context.others_placing[robot_id][1]]


def shut_by_both(
    context: RobotContext, guid: str, outlines_xy_m: list[NDArray[np.float64]]
) -> tuple[list[str], list[str]]:
    """The robots that the part ``guid`` of these band outlines shuts in, with the parts the other robots
    are setting now (``context.others_placing``) counted as standing, less those that theirs alone shut
    in and this part alone does not (their own checks' business); and the robots whose parts were counted
    (both sorted). A robot that this part alone shuts in is held for here whatever the others set: a
    mullion and the glazing panel it frames close the same gap, each alone, and two checks that each left
    it to the other let both go (the Revit house with three carriers: r2 walled in to the end of a run)."""
    setting, theirs = theirs_setting(context, guid)
    site_map, drivers, others_xy = context.site_map, context.drivers, context.others_xy
    shut = shut_in_by(site_map, outlines_xy_m + theirs, drivers, others_xy, placing=guid)
    if shut and theirs:
        alone = set(shut_in_by(site_map, theirs, drivers, others_xy, placing=guid))
        alone -= set(shut_in_by(site_map, outlines_xy_m, drivers, others_xy, placing=guid))
        shut = [robot_id for robot_id in shut if robot_id not in alone]
    return shut, setting


def held(context: RobotContext, task: Task, config: ExecutorConfig) -> bool:
    """Whether the robot holds the task's placement now: placing it would shut another robot in
    (:func:`shut_in_by`), counting the parts the other robots are setting now (:func:`shut_by_both`). It
    asks again in ``shut_in_recheck_s`` (``task.retry_at_s``), for
    ``shut_in_wait_s`` at most; then it places (the planner's bound: the robot inside may be held there by
    its own work), and says so."""
    band = context.site_map.config
    outlines = task.target.outlines_meeting(band.band_min_z_m, band.band_max_z_m) if task.target else []
    shut, setting = shut_by_both(context, task.message.guid, outlines) if outlines else ([], [])
    name, now = component_name(task), context.sim_s
    if not shut:
        if task.shut_in_since_s is not None:
            walled = walled_in_already(context, task.shut_in_robots)
            _log.info(
                "%s: %s goes at %.0f s of sim time: it shuts nobody in now%s",
                context.robot_id,
                name,
                now,
                f" ({', '.join(walled)} walled in already, not by it)" if walled else "",
            )
            task.shut_in_since_s, task.shut_in_robots = None, []
        return False
    task.shut_in_robots = shut
    if task.shut_in_since_s is None:
        task.shut_in_since_s = now
        _log.info(
            "%s: %s waits at %.0f s of sim time: placing it now would shut in %s (no way out to the depot%s)",
            context.robot_id,
            name,
            now,
            ", ".join(
                f"{robot_id} at ({context.others_xy[robot_id][0]:.1f}, {context.others_xy[robot_id][1]:.1f})"
                for robot_id in shut
            ),
            f"; counting what {', '.join(setting)} set now" if setting else "",
        )
    if now - task.shut_in_since_s >= config.shut_in_wait_s:
        _log.warning(
            "%s: %s placed after %.0f s: it still shuts in %s",
            context.robot_id,
            name,
            now - task.shut_in_since_s,
            ", ".join(shut),
        )
        return False
    task.retry_at_s = now + config.shut_in_recheck_s
    return True
