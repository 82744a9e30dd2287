"""Benchmark of the planner's loop on a large site: the wall time of one loop turn while nothing changes.

The planner's loop (``services/planner/app.py``) turns once per batch of bus messages, and on a site with
ten robots most batches change nothing the planner reads (clock ticks, robot states of robots that are
busy). Its passes over every task (release the ready ones, the no-progress watchdog, the staging spots in
use, the progress counts) run again only when a component's state or a task's phase has changed
(``PlannerCore.revision``). This bench builds the planner core of a generated frame of about a thousand
components (18×18 columns: 988) with ten robots, all busy, and times loop turns in which only the sim
clock moves:

* quiet: as the planner runs them (the passes skipped while the revision stands);
* forced: the revision bumped before every turn, so every pass runs (what every turn cost before);

and prints both and their ratio, same run. Then the planner's start-up access check on the same site
(``shared/site_access.py``: every component placed in plan order on the robots' 0.1 m grid, what each
placement cuts off): its wall time per placement, with the free region kept current around each change,
against one whole distance transform and labelling of the grid (what every placement cost before).
Run: ``.venv/bin/python bench/planner.py [--turns N]``.
"""

from __future__ import annotations

import argparse
import logging
import statistics
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import ndimage

from bimbot.data.light_steel_frame import build_light_steel_frame
from bimbot.services.converter.convert import convert_model
from bimbot.services.planner.access_plan import FINE
from bimbot.services.planner.capability import SiteRobot
from bimbot.services.planner.scheduler import PlannerCore
from bimbot.services.planner.sources import Plan, PlanSource, SourceKind, load_plan
from bimbot.shared.ifc_input import open_model
from bimbot.shared.manifest import Manifest, read_manifest
from bimbot.shared.messages import RobotState, RobotStateMsg, TaskMsg, TaskStatus
from bimbot.shared.occupancy_grid import distance_field_m
from bimbot.shared.robot_description import DEFAULT_ROBOT
from bimbot.shared.site_access import SiteAccess, check_order
from bimbot.shared.site_layout import plan_site
from bimbot.shared.site_plan import SiteLayout

BAYS = (18, 18)  # 988 components, as bench/build.py --large
ROBOTS = 10
PERIOD_S = 0.1
ACCESS_STEPS = 200  # placements of the access check timed


@dataclass(frozen=True)
class Site:
    manifest: Manifest
    plan: Plan
    layout: SiteLayout


def large_site(folder: Path) -> Site:
    """The generated 988-component frame converted into ``folder``, its derived plan and its site."""
    source = folder / "large.ifc"
    build_light_steel_frame(*BAYS).write(str(source))
    convert_model(open_model(source), source, folder / "build")
    manifest = read_manifest(folder / "build")
    plan = load_plan(manifest, folder / "build", PlanSource(SourceKind.DERIVE))
    return Site(manifest, plan, plan_site(manifest.components, ROBOTS))


def access_check_ms(site: Site) -> tuple[float, float, int]:
    """(ms a placement of the access check over the first ``ACCESS_STEPS`` of the plan, ms of one whole
    transform and labelling of the same grid, its cells)."""
    plan = site.plan
    access = SiteAccess(site.manifest.components, site.layout, DEFAULT_ROBOT, FINE)
    access.region()
    started = time.perf_counter()
    check_order(access, list(plan.order)[:ACCESS_STEPS])
    per_placement = 1000.0 * (time.perf_counter() - started) / ACCESS_STEPS
    wholes = []
    for _ in range(5):
        started = time.perf_counter()
        free = ~(distance_field_m(access.occupancy()) <= access.inflation_m + 1e-9)
        ndimage.label(free, structure=np.ones((3, 3), bool))
        wholes.append(1000.0 * (time.perf_counter() - started))
    return per_placement, statistics.median(wholes), access.grid.shape[0] * access.grid.shape[1]


def planner_core(site: Site) -> PlannerCore:
    """The core of a 988-component site with ten robots, each given its first task and reporting busy."""
    robots = [
        SiteRobot(f"r{number + 1}", DEFAULT_ROBOT, start)
        for number, start in enumerate(site.layout.robot_starts)
    ]
    core = PlannerCore(site.manifest, site.plan, robots=robots, slots=dict(site.layout.slots))
    for robot in robots:
        core.robot_liveliness(robot.robot_id, True)
        core.observe_robot_state(_robot_state(robot, RobotState.IDLE, None))
    core.finish_sync()
    given = {  # releases the footings, gives every robot one
        message.robot_id: message.task_id
        for message in core.step(0.0)
        if isinstance(message, TaskMsg) and message.status is TaskStatus.ASSIGNED
    }
    for robot in robots:
        core.observe_robot_state(_robot_state(robot, RobotState.PICK_UP, given.get(robot.robot_id)))
    return core


def _robot_state(robot: SiteRobot, state: RobotState, task_id: str | None) -> RobotStateMsg:
    return RobotStateMsg(
        robot_id=robot.robot_id,
        state=state,
        task_id=task_id,
        pose_xy_yaw=robot.home_xy_yaw,
        sim_time_s=0.0,
        wall_time_s=0.0,
    )


def turns_ms(core: PlannerCore, turns: int, *, forced: bool) -> list[float]:
    """Wall ms of each loop turn: the clock moves a period, the core steps, progress when it changed."""
    seen = -1
    times = []
    for _ in range(turns):
        started = time.perf_counter()
        if forced:
            core.revision += 1
        core.observe_clock(core.sim_time_s + PERIOD_S)
        core.step(time.time())
        if core.revision != seen:
            seen = core.revision
            core.progress()
        times.append(1000.0 * (time.perf_counter() - started))
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--turns", type=int, default=500, help="loop turns timed each way")
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING)
    with tempfile.TemporaryDirectory(prefix="bimbot-bench-planner-") as tmp:
        site = large_site(Path(tmp))
    core = planner_core(site)
    placement_ms, whole_ms, cells = access_check_ms(site)
    tasks = len(core.in_flight())
    medians = {}
    for label, forced in (("quiet", False), ("forced", True), ("quiet", False), ("forced", True)):
        medians.setdefault(label, []).append(statistics.median(turns_ms(core, args.turns, forced=forced)))
    quiet, forced = min(medians["quiet"]), min(medians["forced"])
    print(f"planner loop turn, 988 components, {ROBOTS} robots busy, {tasks} tasks released or assigned:")
    print(f"  quiet (nothing changed): {quiet:.3f} ms; every pass forced: {forced:.3f} ms")
    print(f"  ratio quiet / forced: {quiet / forced:.3f}")
    print(f"access check at start-up, {cells:,} cells at 0.1 m, first {ACCESS_STEPS} placements of the plan:")
    print(f"  {placement_ms:.1f} ms a placement; one whole transform and labelling {whole_ms:.1f} ms")
    print(f"  ratio placement / whole transform: {placement_ms / whole_ms:.3f}")


if __name__ == "__main__":
    main()
