"""The navigator's configuration, status, command, goal and course (data, and how a goal is set).

Why apart from :mod:`.navigator`: plain data the navigator, its recovery chain (:mod:`.recovery`) and the
executor share, so the navigator module keeps to its behaviour. Units: metres, radians, sim seconds.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field, replace
from enum import StrEnum

import numpy as np
from numpy.typing import NDArray

from bimbot.shared.messages import SiteInfoMsg
from bimbot.shared.occupancy_grid import OccupancyGrid
from bimbot.shared.robot_description import RobotDescription

from .dwa import DwaConfig
from .localisation import LocaliserConfig
from .motion import Path
from .recovery import ProgressWatchdog, Recovery

# Coarser than the DWA defaults, for a ~0.3 ms step: 11 rollout points (≤ 1 cm lost between samples for a
# 0.5 m disc at 1 m/s) and ~40 candidate commands. Husky half-length 0.495 m; the grid keeps paths 0.75 m off.
DEFAULT_DWA = DwaConfig(
    robot_radius_m=0.5, sim_dt_s=0.2, speed_resolution_mps=0.05, yaw_rate_resolution_radps=0.1
)


@dataclass(frozen=True)
class NavigatorConfig:
    dwa: DwaConfig = DEFAULT_DWA
    localiser: LocaliserConfig = field(default_factory=LocaliserConfig)
    goal_tolerance_m: float = 0.25  # reach is generous (1.5 m to the footprint); localisation error ~0.1 m
    # sim seconds between sensing and the command acting (physics' lock-step latency, SiteInfoMsg): the
    # navigator plans from where the command acting meanwhile will have carried the robot
    command_latency_s: float = 0.0
    yaw_tolerance_rad: float = 0.15
    lookahead_m: float = 2.5  # ≥ max speed × DWA horizon, or the carrot caps the speed
    sight_inflation_m: float = 0.65  # carrot visibility: between the DWA's clearance and the planning grid's
    rotate_in_place_rad: float = 1.0  # heading error to the carrot beyond which the robot turns on the spot
    final_approach_m: float = 1.2  # this near, in a free straight line: drive straight onto the goal
    local_obstacle_radius_m: float = 4.0
    mark_beyond_m: float = 0.3  # a laser hit this far from the static map is a mark
    dynamic_margin_m: float = 0.3  # extra DWA clearance from marks (they may move towards the robot)
    blocked_check_m: float = 4.0
    deviation_m: float = 0.8
    replan_interval_s: float = 1.0
    stuck_window_s: float = 6.0
    stuck_move_m: float = 0.2
    backup_s: float = 1.5
    backup_speed_mps: float = 0.2
    # The recovery chain (recovery.RECOVERY_CHAIN) and the watchdogs, all in sim seconds:
    progress_window_s: float = 20.0  # no progress_min_m gained on the goal within this → next recovery
    progress_min_m: float = 0.3
    no_path_recover_s: float = 3.0  # this much more waiting for a path → next recovery
    clear_marks_s: float = 5.0  # plan without laser marks this long
    rotate_s: float = 4.2  # turn on the spot (about one turn at 1.5 rad/s)
    start_snap_m: float = 1.0  # plan from the nearest free cell this near when the robot's cell is not free
    plan_out_max_m: float = 4.0  # … and this near once the plan-out recovery ran
    body_half_width_m: float = 0.35  # a way out of an inflated start cell keeps this clear (Husky: 0.34 m)
    trapped_area_m2: float = 2.0  # reachable free space below this: the robot is trapped
    traffic_range_m: float = 1.6  # stuck with a mark this near that another robot explains: traffic rules
    max_give_ways: int = 6  # per goal, then the plain recoveries take over
    aside_s: float = 8.0  # longest drive to a step-aside spot
    hold_s: float = 4.0  # standing still while the other robot steps aside (and waiting at the spot)
    max_wait_s: float = 30.0  # waiting for a path, at most
    beside_m: float = 1.0  # a failure names the components this near the robot (what may hold it up)
    timeout_s: float = 600.0  # one goal, at most


DEFAULT_NAVIGATOR = NavigatorConfig()


def controller_limits(dwa: DwaConfig, robot: RobotDescription, info: SiteInfoMsg) -> DwaConfig:
    """The local planner's limits from what physics simulates (its site info), never a second default:
    the robot type's speed, turn rate and footprint, and the clock's control period."""
    return replace(
        dwa,
        control_period_s=info.control_period_s,
        max_speed_mps=robot.max_speed_mps,
        max_yaw_rate_radps=robot.max_turn_radps,
        robot_radius_m=0.5 * max(robot.length_m, robot.width_m),  # a disc over the body's length
    )


class NavStatus(StrEnum):
    IDLE = "idle"  # no goal
    ACTIVE = "active"  # driving (or turning onto the goal's yaw)
    WAITING = "waiting"  # no path for now: standing still, retrying
    REACHED = "reached"
    FAILED = "failed"


@dataclass(frozen=True)
class NavCommand:
    v_mps: float
    w_radps: float
    status: NavStatus
    new_path_xy_m: NDArray[np.float64] | None = None  # set when the path was (re)planned this step


@dataclass
class Goal:
    xy: NDArray[np.float64]
    yaw: float | None
    tolerance_m: float
    started_s: float
    path: Path | None = None
    grid: OccupancyGrid | None = None  # the (inflated, marked) grid the path was planned on
    planned_s: float = -math.inf
    map_version: int = -1
    no_path_since_s: float | None = None
    blocked: bool = False  # the last plan failed because the goal itself is occupied (by fresh laser marks)
    level: int = 0  # position in the recovery chain
    tried: tuple[Recovery, ...] = ()
    backup_until_s: float = -math.inf
    rotate_until_s: float = -math.inf
    ignore_marks_until_s: float = -math.inf
    plan_out: bool = False  # the plan-out recovery ran: start from a free cell up to plan_out_max_m away
    watchdog: ProgressWatchdog | None = None
    hold_until_s: float = -math.inf  # standing still while another robot steps aside
    give_ways: int = 0
    arrived: bool = False  # within tolerance once: only turning onto the yaw now (unless pushed far off)
    quiet: bool = False  # its owner says why it failed: waits, recoveries and the failure log at debug
    aside_until_s: float = math.inf  # a step-aside goal: when to go back to the real goal at the latest
    trail: deque = field(default_factory=deque)  # (sim_s, x, y), one sample per 0.5 s


def new_goal(
    config: NavigatorConfig,
    xy: NDArray[np.float64],
    yaw: float | None,
    tolerance_m: float,
    sim_s: float,
    **more: float,
) -> Goal:
    """A goal set at ``sim_s``, watched for progress (``more``: e.g. ``aside_until_s`` of a step aside)."""
    watchdog = ProgressWatchdog(config.progress_window_s, config.progress_min_m, sim_s)
    return Goal(xy, yaw, tolerance_m, sim_s, watchdog=watchdog, **more)  # type: ignore[arg-type]


@dataclass
class Course:
    """Where the navigator is going: its goal and the goal's status, and the real goal while it steps aside
    for another robot. Shared by the navigator and its traffic rules (:mod:`.traffic`), which set a step
    aside and come back from it."""

    goal: Goal | None = None
    status: NavStatus = NavStatus.IDLE
    resume: Goal | None = None  # the real goal while stepping aside
