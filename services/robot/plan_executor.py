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
"""

from __future__ import annotations

import logging
import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from bimbot.shared.messages import ClockMsg, OdomMsg, PlanMsg, RobotPoseMsg, SiteInfoMsg
from bimbot.shared.plan_motion import Trajectory, standing, trajectory
from bimbot.shared.reasons import Reason

from .astar import plan_path, simplify_path
from .executor import Executor, executor_class
from .fine_alignment import Alignment
from .handover import Handover
from .nav_types import DEFAULT_NAVIGATOR, Goal, NavCommand, NavigatorConfig, NavStatus
from .protocol import Outgoing
from .recovery import diagnose, escape_path, plan_start
from .site_map import SiteMap
from .site_work import SiteWorkExecutor
from .task_state import Task

_log = logging.getLogger(__name__)

_NO_MARKS = np.empty((0, 2))


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
        self.failure, self._failed = None, False
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

    def cancel(self) -> None:
        """Stop where it is now (a motion still running is cut short: physics hears it)."""
        if self.now_s < self.motion.end_s:
            x, y, _ = self.pose_xy_yaw
            self._move([(x, y)], self.now_s)
        self.goal, self.failure, self._failed = None, None, False

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
        navigator.now_s = clock.sim_time_s
        before = navigator.motion
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

    def _ground_truth(self, message: RobotPoseMsg) -> None:
        """No localisation error to measure: physics poses it by the same motion (a pose message stamped
        before a jump of the clock is no error)."""


def plan_executor_class(info: SiteInfoMsg, robot_id: str) -> type[Executor] | type[SiteWorkExecutor]:
    """The plan fidelity's executor of a robot: :class:`PlanExecutor` for one that drives; a crane, pump or
    block layer keeps its own (it does not drive)."""
    chosen = executor_class(info, robot_id)
    return PlanExecutor if chosen is Executor else chosen
