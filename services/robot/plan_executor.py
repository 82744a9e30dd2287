"""The plan fidelity's robot (``--fidelity plan``): the same task cycle, moved along its timed A* path.

Why: a scenario study needs many runs, and a ground robot's laser, particle filter and DWA are most of
what a run costs. Here :class:`PlanExecutor` keeps everything of :class:`.executor.Executor` (the task
cycle, approach poses, give-backs, reasons, events and requests) and swaps its navigator for a
:class:`PlanNavigator`: a goal is planned with the same A* on the same inflated grid, and the robot then
moves along that path by :func:`bimbot.shared.plan_motion.trajectory` (the type's speed and turn limits).
The path goes out on the robot's ``plan`` key; physics poses the robot's body by the same function and
knows when the drive ends, so its clock can jump there. The robot knows where it is (no localisation
error: a placement's error is the type's precision model, drawn by physics), so it places with no belief
of its own (``believed_xy_yaw`` None). Cranes, pumps and block layers keep their executors: they do not
drive.

The site changes while the robot drives (a part placed, one that slid or fell): like the full navigator,
which plans again when its map changes, :meth:`PlanNavigator.watch` checks the rest of the path against the
site map each time the map changed. A cell of it that was free when planned and is occupied now: the robot
stops where it is and plans again from there; when the goal itself is covered, it stops and says so
(``goal_blocked``), so that its owner chooses another stand-point instead of driving into what lies there.

A drive with nothing else going on is slept through (:meth:`PlanExecutor.sleeps_until_s`): its answer says
until when (``CmdVelMsg.wakes_at_s``), and physics neither sends it sensors nor waits for it until the
first step that reaches the drive's end, or a task message wakes every sleeper (:mod:`.stepped`). On the
988-component frame with ten carriers a robot answered every one of 33,000 steps; asleep through drives it
answers a third of them, and the run took 642 s of wall time instead of 767 s (``bench/build.py --large``).
The path is watched against the map at the next tick, not at every step of the drive. An idle robot sleeps
alike through its drive out of the structure and to its depot, and while it waits for its parking time.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bimbot.shared.messages import ClockMsg, OdomMsg, PlanMsg, RobotPoseMsg, SiteInfoMsg
from bimbot.shared.occupancy_grid import OccupancyGrid
from bimbot.shared.plan_motion import Trajectory, standing, trajectory
from bimbot.shared.reasons import Reason

from .astar import plan_path, simplify_path
from .executor import Executor, executor_class
from .fine_alignment import Alignment
from .handover import Handover
from .motion import Path
from .nav_types import DEFAULT_NAVIGATOR, Goal, NavCommand, NavigatorConfig, NavStatus
from .protocol import Outgoing, assignment_waiting
from .recovery import diagnose, escape_path, plan_start
from .site_map import SiteMap
from .site_work import SiteWorkExecutor
from .task_state import Task

_log = logging.getLogger(__name__)

_NO_MARKS = np.empty((0, 2))
# a drive this much longer or more is slept through (its robot answers no step until it ends): fewer is
# not worth the sleep's own steps
MIN_SLEEP_S = 1.0
WATCH_STEP_M = 0.1  # the rest of a path is checked at points this far apart (the site map's cells)


@dataclass(frozen=True)
class _Watched:
    """A planned path as the site map stood then: points along it, their arc lengths (m from the start of
    the motion) and which were free on the inflated grid; the map's version."""

    version: int
    points_xy_m: NDArray[np.float64]
    arc_m: NDArray[np.float64]
    free: NDArray[np.bool_]


class PlanNavigator:
    """What the executor asks of a navigator, answered by a timed path instead of a control loop."""

    def __init__(
        self,
        site_map: SiteMap,
        start_xy_yaw: ArrayLike,
        *,
        speed_mps: float,
        turn_radps: float,
        robot_id: str = "",
        config: NavigatorConfig = DEFAULT_NAVIGATOR,
    ) -> None:
        self.site_map, self.config, self.robot_id = site_map, config, robot_id
        self.speed_mps, self.turn_radps = speed_mps, turn_radps
        self.now_s = 0.0
        start = np.asarray(start_xy_yaw, float)
        self.motion: Trajectory = standing([float(value) for value in start[:3]], 0.0)
        self.goal: Goal | None = None
        self.failure: Reason | None = None
        self.marks = _NO_MARKS
        self.goal_blocked = False
        self.ready_to_place = True  # it stands exactly where its motion ended
        self._failed = False
        self.published: Trajectory | None = None  # a new motion for the plan key (taken by the executor)
        self.path_xy_m: list[tuple[float, float]] = []
        self._watched: _Watched | None = None  # the motion's path as the map stood when it was planned

    @property
    def pose_xy_yaw(self) -> tuple[float, float, float]:
        return self.motion.pose_at(self.now_s)

    @property
    def status(self) -> NavStatus:
        if self.goal is None:
            return NavStatus.IDLE
        if self._failed:
            return NavStatus.FAILED
        return NavStatus.REACHED if self.now_s >= self.motion.end_s else NavStatus.ACTIVE

    def set_goal(
        self,
        xy_m: ArrayLike,
        yaw_rad: float | None,
        sim_s: float,
        tolerance_m: float | None = None,
        *,
        quiet: bool = False,
    ) -> None:
        """Plan to ``xy_m`` now (A* on the inflated grid) and move along the path from ``sim_s``; no path:
        FAILED with the diagnosis of the static map. ``quiet``: as :meth:`.navigator.Navigator.set_goal`."""
        self.now_s = sim_s
        here = self.pose_xy_yaw
        goal_xy = np.asarray(xy_m, float)[:2]
        self.goal = Goal(goal_xy, yaw_rad, tolerance_m or self.config.goal_tolerance_m, sim_s, quiet=quiet)
        self.failure, self._failed, self.goal_blocked, self._watched = None, False, False, None
        grid = self.site_map.inflated_grid()
        body = self.site_map.inflated_grid(self.config.body_half_width_m)
        start = plan_start(grid, here[:2], self.config.plan_out_max_m, body)
        lead_in = escape_path(grid, here[:2], body) if start is None else None
        if lead_in:
            start = lead_in[-1]
        result = plan_path(grid, start if start is not None else here[:2], goal_xy, snap_goal_to_free=True)
        if not result.found:
            self.failure = diagnose(
                grid,
                here[:2],
                goal_xy,
                robot_id=self.robot_id,
                why=result.reason,
                trapped_area_m2=self.config.trapped_area_m2,
                tried=(),
                beside=self.site_map.components_near(here[:2], self.config.beside_m),
                held=start is None and not lead_in,
            )
            self._failed = True
            self._move([(here[0], here[1])], sim_s)
            return
        points = [(float(x), float(y)) for x, y in simplify_path(grid, result.path_xy_m)]
        if lead_in:  # out of the narrowed space first, through cells its body fits
            points = [*lead_in[:-1], *points]
        if math.hypot(points[0][0] - here[0], points[0][1] - here[1]) > 0.0:
            points.insert(0, (here[0], here[1]))
        self._move(points, sim_s)
        self._watched = _watched(grid, points, self.site_map.version)

    def watch(self, sim_s: float) -> None:
        """Check the rest of the motion against the site map when the map changed since it was planned (see
        the module doc): plan again from here, or stop with ``goal_blocked`` when the goal is covered."""
        self.now_s = sim_s
        watched, goal = self._watched, self.goal
        if watched is None or goal is None or self._failed or sim_s >= self.motion.end_s:
            return
        version = self.site_map.version
        if version == watched.version:
            return
        ahead = watched.arc_m >= self.motion.distance_at(sim_s)
        covered = ahead & watched.free
        if covered.any():
            covered[covered] = ~self.site_map.free_at(watched.points_xy_m[covered])
        if not covered.any():
            self._watched = _Watched(version, watched.points_xy_m, watched.arc_m, watched.free)
            return
        x, y, _ = self.pose_xy_yaw
        if covered[-1]:  # the goal itself: another stand-point, not the nearest free cell beside it
            self._move([(x, y)], sim_s)
            self.goal_blocked, self._failed, self._watched = True, True, None
            self.failure = diagnose(
                self.site_map.inflated_grid(),
                (x, y),
                goal.xy,
                robot_id=self.robot_id,
                why="found its goal covered by what came onto the site map while it drove there",
                trapped_area_m2=self.config.trapped_area_m2,
                tried=(),
                beside=self.site_map.components_near(goal.xy, self.config.beside_m),
            )
            _log.log(_level(goal), "%s: %s", self.robot_id, self.failure.message)
            return
        first = watched.points_xy_m[int(np.argmax(covered))]
        _log.log(
            _level(goal),
            "%s: its path is covered at (%.2f, %.2f) since it set off: plans again from (%.2f, %.2f)",
            self.robot_id,
            first[0],
            first[1],
            x,
            y,
        )
        self.set_goal(goal.xy, goal.yaw, sim_s, goal.tolerance_m, quiet=goal.quiet)

    def cancel(self) -> None:
        """Stop where it is now (a motion still running is cut short: physics hears it)."""
        if self.now_s < self.motion.end_s:
            x, y, _ = self.pose_xy_yaw
            self._move([(x, y)], self.now_s)
        self.goal, self.failure, self._failed = None, None, False
        self.goal_blocked, self._watched = False, None

    def _move(self, points: list[tuple[float, float]], sim_s: float) -> None:
        yaw = self.pose_xy_yaw[2]
        self.motion = trajectory(points, yaw, sim_s, speed_mps=self.speed_mps, turn_radps=self.turn_radps)
        self.published, self.path_xy_m = self.motion, points

    def step(self, sim_s: float) -> NavCommand:
        self.now_s = sim_s
        return NavCommand(0.0, 0.0, self.status)

    # --- what the full navigator does and a kinematic robot does not need -------------------------------

    def see(self) -> None:
        """No laser: nothing to see beyond the site map."""

    def localise(self) -> bool:
        return False

    def observe_odom(self, message: Any) -> None: ...

    def observe_scan(self, message: Any, *, defer_localisation: bool = False) -> None: ...

    def observe_fix(self, message: Any) -> None: ...

    def observe_robot(self, robot_id: str, xy_m: ArrayLike, sim_s: float) -> None: ...

    def align(self) -> Alignment:
        return Alignment(np.asarray(self.pose_xy_yaw, float), True, 0, 0.0, 0.0)


class PlanHandover(Handover):
    """Physics requests of a robot that knows its pose: no belief to place from, none to doubt."""

    def _believed_pose(self, task: Task) -> tuple[float, float, float] | None:
        """It knows its pose: the placement's error is the type's precision alone (physics draws it)."""
        return None

    def _check_localisation(self, task: Task, kind: str, measured_m: float) -> None:
        """No localisation to doubt: the robot stands where its motion put it."""


class PlanExecutor(Executor):
    """:class:`.executor.Executor` with a :class:`PlanNavigator` (see the module doc)."""

    def __init__(self, manifest: Any, info: SiteInfoMsg, config: Any, **kwargs: Any) -> None:
        super().__init__(manifest, info, config, **kwargs)
        start = self.navigator.pose_xy_yaw
        description = self.description
        self.context.navigator = PlanNavigator(  # type: ignore[assignment]
            self.site_map,
            start,
            speed_mps=description.max_speed_mps,
            turn_radps=description.max_turn_radps,
            robot_id=self.robot_id,
        )
        self._driven_m = 0.0  # metres of the motions before the current one

    def _handover(self) -> Handover:
        return PlanHandover(self.context, self.cycle)

    @property
    def plan_navigator(self) -> PlanNavigator:
        navigator = self.navigator
        assert isinstance(navigator, PlanNavigator)
        return navigator

    def handle(self, message: object) -> None:
        if isinstance(message, OdomMsg):
            return  # it knows where it is; its distance is its motions'
        super().handle(message)

    def tick(self, clock: ClockMsg, wall_s: float) -> list[Outgoing]:
        navigator = self.plan_navigator
        before = navigator.motion
        navigator.watch(clock.sim_time_s)
        out = super().tick(clock, wall_s)
        if navigator.motion is not before:
            self._driven_m += before.distance_at(navigator.motion.start_s)
        self.distance_m = self._driven_m + navigator.motion.distance_at(clock.sim_time_s)
        motion = navigator.published
        if motion is not None:
            navigator.published = None
            path = navigator.path_xy_m
            plan = PlanMsg(
                robot_id=self.robot_id, path_xy_m=path, goal_xy_m=path[-1], sim_time_s=motion.start_s
            )
            out.insert(len(out) - 1, plan)  # before the step's command
        return out

    def sleeps_until_s(self) -> float | None:
        """Until its drive ends, when all it does meanwhile is follow its motion (see the module doc):
        nothing to send or to hear back (no physics request out, every event confirmed, no question out),
        no wait on another robot, and the drive at least :data:`MIN_SLEEP_S` long yet. Its task's no-progress
        bound wakes it too. Idle, until its parking acts (:meth:`_idle_until_s`). None: it answers every
        step."""
        task, navigator = self.task, self.plan_navigator
        if self.component_states.asking or self.cycle.outbox:
            return None
        if task is None:
            return self._idle_until_s()
        if navigator.goal is None or navigator.status is not NavStatus.ACTIVE:
            return None
        if task.request is not None or task.events:
            return None
        if task.abandoning or task.dropping is not None or task.withdrawn or task.waiting_since_s is not None:
            return None
        return self._worth_sleeping(
            min(navigator.motion.end_s, self.cycle.state_since_s + self.config.task_timeout_s)
        )

    def _idle_until_s(self) -> float | None:
        """Idle and not yet parked: asleep through its drive out of the structure or to its depot, and
        while it stands waiting for its parking time (a task message wakes it, as any sleeper); never while
        an assignment waits for its component's release (a component state starts it, and wakes nobody)."""
        if self.parking is None or assignment_waiting(self.tasks, self.robot_id, self.performed):
            return None
        navigator = self.plan_navigator
        if navigator.goal is None:
            return self._worth_sleeping(self.parking.next_act_s())
        return self._worth_sleeping(navigator.motion.end_s if navigator.status is NavStatus.ACTIVE else None)

    def _worth_sleeping(self, end_s: float | None) -> float | None:
        """``end_s`` when it lies at least :data:`MIN_SLEEP_S` ahead, else None."""
        return end_s if end_s is not None and end_s - self.sim_s >= MIN_SLEEP_S else None

    def _ground_truth(self, message: RobotPoseMsg) -> None:
        """No localisation error to measure: physics poses it by the same motion (a pose message stamped
        before a jump of the clock is no error)."""


def _watched(grid: OccupancyGrid, points: list[tuple[float, float]], version: int) -> _Watched:
    """Points every :data:`WATCH_STEP_M` along a path and which of them are free on ``grid``."""
    path = Path(points)
    length = float(path.arc_m[-1])
    arc = np.append(np.arange(0.0, length, WATCH_STEP_M), length)
    xy = path.samples(0.0, length, WATCH_STEP_M)
    return _Watched(version, xy, arc, grid.is_free_xy(xy))


def _level(goal: Goal) -> int:
    """The log level of what happens on the way to ``goal``: info, or debug for a quiet one."""
    return logging.DEBUG if goal.quiet else logging.INFO


def plan_executor_class(info: SiteInfoMsg, robot_id: str) -> type[Executor] | type[SiteWorkExecutor]:
    """The plan fidelity's executor of a robot: :class:`PlanExecutor` for one that drives; a crane, pump or
    block layer keeps its own (it does not drive)."""
    chosen = executor_class(info, robot_id)
    return PlanExecutor if chosen is Executor else chosen
