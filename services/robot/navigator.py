"""Drive to a goal like ROS move_base: localisation, A* global plan, DWA local planner (pure).

Why: the robot's navigation stack (paper §5.2) assembled from the pure cores of this package. Per control
step (:meth:`Navigator.step`), after :meth:`Navigator.observe_odom` / :meth:`Navigator.observe_scan` fed the
:class:`.localisation.Localiser`:

1. the scan becomes the **local obstacles** of the DWA and **laser marks** (hits the static map does not
   explain: other robots, surprises) added to the grid for planning (:mod:`.surroundings`);
2. **plan** with A* on the inflated grid (+ marks) when the goal is new, the map changed, a mark lies on the
   path within ``blocked_check_m`` ahead, or the robot strayed more than ``deviation_m`` from it (at most
   once per ``replan_interval_s``); the path is line-of-sight pruned. No path → the robot waits and
   retries (another robot may stand on the goal for a while); every ``no_path_recover_s`` of waiting runs
   the next recovery, and it fails after ``max_wait_s`` at the latest;
3. **follow** the path with the DWA towards a carrot (:func:`.motion.carrot`: far along the path, but only
   as far as the robot sees along a free line, so it never cuts a corner into an obstacle), under a speed
   cap that lets it brake onto the goal and slows it near marks. Facing away from the carrot it first
   turns on the spot; the last metre, when free, is a straight drive; at the goal it turns gently onto the
   goal's yaw;
4. **stuck** (moved less than ``stuck_move_m`` in ``stuck_window_s``): facing another robot, the traffic
   rules say who steps aside and who holds (:mod:`.traffic`); otherwise, and when the **progress watchdog**
   expires (neither the distance to the goal nor the path left shrank by ``progress_min_m`` within
   ``progress_window_s``), the next step of the **recovery chain** (:mod:`.recovery`: clear laser marks,
   rotate in place, back up, plan out of an inflated start cell). With the chain exhausted (or after
   ``timeout_s``) it reports FAILED with a :attr:`Navigator.failure` reason (``robot_trapped``,
   ``unreachable`` or ``no_progress``, with the numbers) and the executor re-chooses the approach pose, and
   after its own bound gives the task back.

Units: metres, radians, simulated seconds; world (map) frame.
"""

from __future__ import annotations

import logging
import math
from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bimbot.shared.geometry import wrap_angle
from bimbot.shared.messages import OdomMsg, PositionFixMsg, ScanMsg
from bimbot.shared.reasons import Reason

from .astar import plan_path, simplify_path
from .dwa import RobotState, dwa_step
from .fine_alignment import Alignment, align
from .localisation import Localiser
from .motion import Path, carrot, straight_line_clear, turn_command, unicycle
from .nav_types import DEFAULT_NAVIGATOR, Course, Goal, NavCommand, NavigatorConfig, NavStatus, new_goal
from .particle_filter import PositionFix
from .recovery import Recovery, diagnose, escape_path, held_where_it_stands, next_recovery, plan_start
from .site_map import SiteMap
from .surroundings import Surroundings
from .traffic import Traffic

_log = logging.getLogger(__name__)
MIN_STILL_FIXES = 2  # a placement's pose from the positioning sensor: the mean of this many fixes at least
# A laser alignment farther than this many standard deviations (of the still fixes' mean), plus the margin,
# from the positioning sensor's fixes is not trusted: the laser matched outlines the wrong way (hits on a
# few parallel faces leave the alignment free along them, its residual tiny) and the fixes stand.
# With a positioning sensor, a placement waits standing still for this many fixes (2 s at the 0.2 s control
# period), as a layout robot measures before it marks: two fixes of 3 mm left the heading ~3 mrad off, 4–5 mm
# at the reach (placements p95 9.8 mm against the 10 mm tolerance on the 988-component site). The wait ends
# after PLACE_FIXES_WAIT_STEPS periods standing still whatever the count (a sensor that went quiet).
PLACE_FIXES = 10
PLACE_FIXES_WAIT_STEPS = 25
FIX_AGREEMENT_SIGMAS = 3.0
FIX_AGREEMENT_MARGIN_M = 0.003
# a laser hit is never trusted closer than this in a fused position: the map's outlines are the BIM's, and
# what stands there stands a few millimetres off them
LASER_FLOOR_M = 0.005

REST_MPS = 0.002  # odometry speed below which the robot stands still (noise: ~2 % of the increment)
REST_RADPS = 0.005


class Navigator:
    """Localisation + global plan + local planner for one robot (see the module doc).

    Owns its localiser, its course (:class:`.nav_types.Course`: goal, status, a goal set aside), what its
    last scan shows (:class:`.surroundings.Surroundings`) and its traffic rules (:class:`.traffic.Traffic`,
    which share the course and the surroundings)."""

    def __init__(
        self,
        site_map: SiteMap,
        start_xy_yaw: ArrayLike,
        config: NavigatorConfig = DEFAULT_NAVIGATOR,
        rng: np.random.Generator | None = None,
        robot_id: str = "",
    ) -> None:
        self.site_map, self.config, self.robot_id = site_map, config, robot_id
        self.localiser = Localiser(site_map, start_xy_yaw, config.localiser, rng)
        self.course = Course()
        self.surroundings = Surroundings(site_map, config, start_xy_yaw)
        self.traffic = Traffic(config, robot_id, site_map, self.course, self.surroundings)
        self.v_mps = self.w_radps = 0.0
        self._acting = (0.0, 0.0)  # the command acting until the one being computed does (latency)
        self.still_steps = 0  # consecutive commands to stand still
        self.odom_speed = (0.0, 0.0)  # the last odometry's (v, w)
        self.replans = 0
        self.failure: Reason | None = None  # why the last goal FAILED
        self.recoveries: list[tuple[float, Recovery]] = []  # (sim s, recovery) run, for logs and tests

    @property
    def status(self) -> NavStatus:
        """The status of the caller's goal (stepping aside for another robot counts as driving)."""
        course = self.course
        return NavStatus.ACTIVE if course.resume is not None else course.status

    @property
    def goal(self) -> Goal | None:
        """The goal it drives to now (a spot beside the way while stepping aside)."""
        return self.course.goal

    @property
    def marks(self) -> NDArray[np.float64]:
        """The last scan's laser marks (:mod:`.surroundings`), once a goal or :meth:`see` needed them."""
        return self.surroundings.marks

    def observe_robot(self, robot_id: str, xy_m: ArrayLike, sim_s: float) -> None:
        """Another robot's pose estimate (its published state): who is who when robots block each other."""
        self.traffic.observe_robot(robot_id, xy_m, sim_s)

    @property
    def pose_xy_yaw(self) -> tuple[float, float, float]:
        """Where the robot will be when its next command acts: the estimate now, carried on by the command
        acting meanwhile over the command latency (physics' lock-step latency; 0: the estimate now)."""
        x, y, yaw = self._acting_pose()
        return (float(x), float(y), float(yaw))

    def _acting_pose(self) -> NDArray[np.float64]:
        latency_s = self.config.command_latency_s
        pose = self.localiser.pose
        if latency_s <= 0.0:
            return pose
        v, w = self._acting
        return unicycle(pose, v, w, latency_s)

    def observe_odom(self, message: OdomMsg) -> None:
        self.localiser.observe_odom(message.pose_xy_yaw)
        self.odom_speed = (message.v_mps, message.w_radps)

    def observe_fix(self, message: PositionFixMsg) -> None:
        """A positioning sensor's fix: fused with this period's scan (which comes next)."""
        self.localiser.observe_fix(
            PositionFix(message.position_xy_m, message.std_m, message.yaw_rad, message.yaw_std_rad)
        )

    def observe_scan(self, message: ScanMsg, *, defer_localisation: bool = False) -> None:
        """The scan for the localisation (now, or with ``defer_localisation`` at :meth:`localise`, after the
        step's command is out, see :mod:`.localisation`), the fine alignment, and the local obstacles and
        marks of the next :meth:`step` with a goal."""
        ranges = np.asarray(message.ranges_m, float)
        beams = np.arange(len(ranges), dtype=np.float64)
        angles = message.angle_min_rad + message.angle_increment_rad * beams
        self.localiser.observe_scan(ranges, angles, message.range_max_m, defer=defer_localisation)
        self.surroundings.take_scan(ranges, angles, message.range_max_m, self.localiser.pose)

    def see(self) -> None:
        """Take the latest scan's marks now, goal or not: the executor looks for a stand-point (no goal yet)
        with what the robot sees, not with the marks of the last step it drove."""
        self.surroundings.see()

    def align(self) -> Alignment:
        """Fine-align the pose estimate to the last scan (:mod:`.fine_alignment`; standing still, before a
        placement); a trusted alignment becomes the estimate."""
        self.localiser.update()  # a deferred scan first: the alignment starts from the filter's best
        hits = self.surroundings.scan_hits_robot_m
        result = align(self.localiser.pose, hits, self.site_map.laser_segments())
        still = self.localiser.still_fix_pose()  # the positioning sensor's fixes standing here, if any
        fixed = still is not None and still[1] >= MIN_STILL_FIXES
        if result.trusted and fixed and still is not None:
            gate_m = FIX_AGREEMENT_SIGMAS * self.localiser.still_fix_std_m() + FIX_AGREEMENT_MARGIN_M
            apart_m = float(np.hypot(*(result.pose_xy_yaw[:2] - still[0][:2])))
            if apart_m > gate_m:
                _log.info(
                    "%s: the laser alignment lies %.1f mm from the mean of %d fixes (more than %.1f mm): "
                    "not trusted",
                    self.robot_id,
                    1000.0 * apart_m,
                    still[1],
                    1000.0 * gate_m,
                )
                result = replace(result, pose_xy_yaw=self.localiser.pose, trusted=False, disagrees_m=apart_m)
        if result.trusted and fixed and still is not None:  # both agree: each weighed by its spread
            result = replace(result, pose_xy_yaw=self._fused(result, still[0]), fixes=still[1])
        if result.trusted:
            self.localiser.set_pose(result.pose_xy_yaw)
            return result
        if fixed and still is not None:  # nothing (trusted) to align on: the positioning sensor
            pose, count = still
            _log.info(
                "%s: positioned on the mean of %d fixes standing still (moved the estimate %.1f mm)",
                self.robot_id,
                count,
                1000.0 * float(np.hypot(*(pose[:2] - self.localiser.pose[:2]))),
            )
            self.localiser.set_pose(pose)
            return replace(result, fixes=count)
        return result

    def _fused(self, alignment: Alignment, fixes_pose: NDArray[np.float64]) -> NDArray[np.float64]:
        """The position of a laser alignment and of the still fixes' mean, each weighed by the inverse of
        its variance (the alignment's: its residual, never below :data:`LASER_FLOOR_M`, over √hits; the
        fixes': their mean's); the heading is the alignment's (a wide scan turns less than two prisms a
        metre apart). A fit of 11 mm rms on 32 hits weighs a fifth against ten 3 mm fixes."""
        hits = max(alignment.hits, 1)
        laser_var = max(alignment.rms_m, LASER_FLOOR_M) ** 2 / hits
        fixes_var = self.localiser.still_fix_std_m() ** 2
        laser_weight = fixes_var / (fixes_var + laser_var) if fixes_var + laser_var > 0 else 1.0
        pose = np.array(alignment.pose_xy_yaw, dtype=float)
        pose[:2] = laser_weight * pose[:2] + (1.0 - laser_weight) * np.asarray(fixes_pose[:2], float)
        return pose

    def localise(self) -> bool:
        """Run the localisation update on a deferred scan (True if the filter ran)."""
        return self.localiser.update()

    def set_goal(
        self,
        xy_m: ArrayLike,
        yaw_rad: float | None,
        sim_s: float,
        tolerance_m: float | None = None,
        *,
        quiet: bool = False,
    ) -> None:
        """Drive to ``xy_m`` (facing ``yaw_rad`` unless None). ``quiet``: the caller says why it failed
        (a retry of a drive that failed alike): its waits, recoveries and failure are logged at debug."""
        tolerance = tolerance_m if tolerance_m is not None else self.config.goal_tolerance_m
        course = self.course
        course.goal = new_goal(self.config, np.asarray(xy_m, float), yaw_rad, tolerance, sim_s)
        course.goal.quiet = quiet
        course.status, course.resume, self.failure = NavStatus.ACTIVE, None, None

    def waiting_s(self, sim_s: float) -> float:
        """How long the robot has been without a path to its goal (0 when it has one)."""
        goal = self.course.goal
        since = goal.no_path_since_s if goal is not None and self.course.resume is None else None
        return 0.0 if since is None else sim_s - since

    @property
    def goal_blocked(self) -> bool:
        """Whether the goal cell itself is occupied in the latest planning grid (choose another goal)."""
        return self.goal is not None and self.goal.blocked

    def cancel(self) -> None:
        course = self.course
        course.goal, course.status, course.resume = None, NavStatus.IDLE, None

    # --- the control step ----------------------------------------------------------------------------

    def step(self, sim_s: float) -> NavCommand:
        self._acting = (self.v_mps, self.w_radps)  # the last command: it acts until this one does
        course = self.course
        if course.goal is not None:
            self.surroundings.see()
        if course.resume is not None and self.traffic.stepped_aside(sim_s):
            return self._command(0.0, 0.0)
        goal = course.goal
        if goal is None or course.status in (NavStatus.REACHED, NavStatus.FAILED, NavStatus.IDLE):
            return self._command(0.0, 0.0)
        pose = self._acting_pose()
        watchdog = goal.watchdog
        assert watchdog is not None
        if sim_s < goal.hold_until_s:
            watchdog.reset(sim_s)
            return self._command(*turn_command(0.0, self.v_mps, 0.0, self.config.dwa))
        if sim_s - goal.started_s > self.config.timeout_s:
            return self._fail(f"did not reach its goal within {self.config.timeout_s:.0f} s")
        if sim_s < goal.backup_until_s:
            watchdog.reset(sim_s)
            return self._command(-self.config.backup_speed_mps, 0.0)
        if sim_s < goal.rotate_until_s:
            watchdog.reset(sim_s)
            return self._command(*turn_command(math.pi, self.v_mps, self.w_radps, self.config.dwa))
        to_goal = math.hypot(*(goal.xy - pose[:2]))
        if to_goal <= goal.tolerance_m or (goal.arrived and to_goal <= 2.0 * goal.tolerance_m):
            return self._turn_to_goal(goal, pose)
        new_path = None
        _, ahead = self._ahead(goal, pose)
        if self._needs_plan(goal, pose, sim_s, ahead):
            new_path = self._plan(goal, pose, sim_s)
            if new_path is None:
                watchdog.reset(sim_s)
                waited_s = sim_s - (goal.no_path_since_s if goal.no_path_since_s is not None else sim_s)
                if waited_s > self.config.max_wait_s:
                    return self._fail(f"found no path in {waited_s:.0f} s")
                if waited_s > (len(goal.tried) + 1) * self.config.no_path_recover_s:
                    return self._recover(goal, pose, sim_s, f"found no path in {waited_s:.0f} s")
                course.status = NavStatus.WAITING
                return self._command(0.0, 0.0)
            _, ahead = self._ahead(goal, pose)
        if goal.path is None or goal.grid is None:
            course.status = NavStatus.WAITING
            return self._command(0.0, 0.0)
        course.status = NavStatus.ACTIVE
        if self._stuck(goal, pose, sim_s):
            way = self.traffic.give_way(goal, pose, sim_s, self.v_mps)
            if way is not None:
                return self._command(*way)
            window = self.config.stuck_window_s
            return self._recover(
                goal, pose, sim_s, f"moved less than {self.config.stuck_move_m:.2f} m in {window:.0f} s"
            )
        path_left_m = float(goal.path.arc_m[-1] - goal.path.project(pose[:2])[0])
        if watchdog.expired(to_goal, path_left_m, sim_s):
            return self._recover(
                goal,
                pose,
                sim_s,
                f"gained less than {self.config.progress_min_m:.2f} m on its goal in "
                f"{self.config.progress_window_s:.0f} s",
            )
        sight = self.site_map.inflated_grid(self.config.sight_inflation_m)
        target, local_path = carrot(ahead, pose[:2], self.config.lookahead_m, sight)
        dwa_config = self.config.dwa
        obstacles = self.surroundings.obstacles(pose)
        cap = max(0.15, math.sqrt(1.4 * dwa_config.max_accel_mps2 * max(0.0, to_goal - goal.tolerance_m / 2)))
        heading_error = float(wrap_angle(math.atan2(target[1] - pose[1], target[0] - pose[0]) - pose[2]))
        if abs(heading_error) > self.config.rotate_in_place_rad:  # facing away: turn first (safe for a disc)
            return self._rotate(heading_error, new_path)
        if to_goal < self.config.final_approach_m and self._clear_line(pose, goal):
            return self._approach_goal(goal, pose, cap, new_path)
        # Slow down near what may move (other robots): full speed beyond ~2.5 m, 0.3 m/s at 1 m.
        nearest_mark_m = self.surroundings.nearest_mark_m
        cap = min(cap, 0.3 + 0.7 * min(1.0, max(0.0, (nearest_mark_m - 1.0) / 1.5)))
        if cap < dwa_config.max_speed_mps:
            dwa_config = replace(dwa_config, max_speed_mps=cap)
        if len(obstacles):
            # Already nearer than the DWA's clearance (localisation jumped, something moved in)? Then no
            # rollout would be admissible: shrink the clearance to what there is, so moving away is allowed.
            now_m = float(np.hypot(obstacles[:, 0] - pose[0], obstacles[:, 1] - pose[1]).min())
            limit = now_m - dwa_config.safety_margin_m - 0.01
            if limit < dwa_config.robot_radius_m:
                dwa_config = replace(dwa_config, robot_radius_m=max(0.05, limit))
        state = RobotState(pose[0], pose[1], pose[2], self.v_mps, self.w_radps)
        result = dwa_step(state, target, obstacles, dwa_config, path_xy_m=local_path)
        return self._command(result.v_mps, result.w_radps, new_path)

    def _rotate(self, heading_error: float, new_path: NDArray[np.float64] | None = None) -> NavCommand:
        return self._command(
            *turn_command(heading_error, self.v_mps, self.w_radps, self.config.dwa), new_path
        )

    def _clear_line(self, pose: NDArray[np.float64], goal: Goal) -> bool:
        """A straight drive to the goal stays in free cells and clear of every local obstacle point."""
        clearance = self.config.dwa.robot_radius_m + self.config.dwa.safety_margin_m
        return goal.grid is not None and straight_line_clear(
            goal.grid, pose[:2], goal.xy, self.surroundings.local_points, clearance
        )

    def _approach_goal(
        self, goal: Goal, pose: NDArray[np.float64], cap_mps: float, new_path: NDArray[np.float64] | None
    ) -> NavCommand:
        """The last metre in a straight free line: face the goal, then drive onto it and brake."""
        dwa = self.config.dwa
        error = float(wrap_angle(math.atan2(goal.xy[1] - pose[1], goal.xy[0] - pose[0]) - pose[2]))
        if abs(error) > 0.5:
            return self._rotate(error, new_path)
        dv, dw = dwa.max_accel_mps2 * dwa.control_period_s, dwa.max_yaw_accel_radps2 * dwa.control_period_s
        v = float(np.clip(min(cap_mps, dwa.max_speed_mps), self.v_mps - dv, self.v_mps + dv))
        w = float(np.clip(2.5 * error, -dwa.max_yaw_rate_radps, dwa.max_yaw_rate_radps))
        return self._command(max(0.0, v), float(np.clip(w, self.w_radps - dw, self.w_radps + dw)), new_path)

    # --- internals -------------------------------------------------------------------------------------

    def _command(self, v: float, w: float, new_path: NDArray[np.float64] | None = None) -> NavCommand:
        self.v_mps, self.w_radps = v, w
        self.still_steps = self.still_steps + 1 if v == 0.0 and w == 0.0 else 0
        return NavCommand(v, w, self.status, new_path)

    @property
    def at_rest(self) -> bool:
        """Standing still, and commanded to go on standing still until its next command acts (through the
        command latency): a heavy robot coasts a centimetre or two after its stop command, which a
        placement commanded meanwhile would carry into the component's pose."""
        latency_steps = round(self.config.command_latency_s / max(self.config.dwa.control_period_s, 1e-9))
        v_mps, w_radps = self.odom_speed
        return self.still_steps >= latency_steps + 1 and abs(v_mps) < REST_MPS and abs(w_radps) < REST_RADPS

    @property
    def ready_to_place(self) -> bool:
        """:attr:`at_rest`, and with a positioning sensor ``PLACE_FIXES`` fixes taken standing here (at most
        ``PLACE_FIXES_WAIT_STEPS`` periods waited for them); without one, as soon as it is at rest."""
        if not self.at_rest:
            return False
        still = self.localiser.still_fix_pose()
        return still is None or still[1] >= PLACE_FIXES or self.still_steps >= PLACE_FIXES_WAIT_STEPS

    def _fail(self, why: str) -> NavCommand:
        """FAILED, with :attr:`failure` naming why (see :func:`.recovery.diagnose`)."""
        goal = self.goal
        pose = self.localiser.pose
        goal_xy = goal.xy if goal is not None else pose[:2]
        grid = self.site_map.inflated_grid()
        body = self.site_map.inflated_grid(self.config.body_half_width_m)
        self.failure = diagnose(
            grid,
            pose[:2],
            goal_xy,
            robot_id=self.robot_id,
            why=why,
            trapped_area_m2=self.config.trapped_area_m2,
            tried=goal.tried if goal is not None else (),
            beside=self.site_map.components_near(pose[:2], self.config.beside_m),
            held=held_where_it_stands(grid, body, pose[:2], self.config.plan_out_max_m),
        )
        _log.log(
            logging.DEBUG if goal is not None and goal.quiet else logging.WARNING,
            "navigation to %s failed: %s",
            np.round(goal_xy, 2).tolist(),
            self.failure.line(),
        )
        self.course.status = NavStatus.FAILED
        return self._command(0.0, 0.0)

    def _turn_to_goal(self, goal: Goal, pose: NDArray[np.float64]) -> NavCommand:
        """At the goal: turn gently onto its yaw (a skid-steered base lags its commands; a stiff gain makes
        it oscillate around the heading), then report REACHED."""
        goal.arrived = True
        if goal.yaw is not None:
            error = float(wrap_angle(goal.yaw - pose[2]))
            if abs(error) > self.config.yaw_tolerance_rad:
                dwa = self.config.dwa
                step = dwa.max_yaw_accel_radps2 * dwa.control_period_s
                w = float(np.clip(1.0 * error, -0.8, 0.8))
                w = float(np.clip(w, self.w_radps - step, self.w_radps + step))
                if abs(w) < 0.15:
                    w = math.copysign(0.15, error)
                self.course.status = NavStatus.ACTIVE
                return self._command(0.0, w)
        self.course.status = NavStatus.REACHED
        return self._command(0.0, 0.0)

    def _ahead(self, goal: Goal, pose: NDArray[np.float64]) -> tuple[float, NDArray[np.float64]]:
        """Distance from the path, and path samples every 0.1 m ``blocked_check_m`` ahead of the robot."""
        if goal.path is None:
            return math.inf, np.empty((0, 2))
        arc, gap = goal.path.project(pose[:2])
        return gap, goal.path.samples(arc, self.config.blocked_check_m, 0.1)

    def _needs_plan(
        self, goal: Goal, pose: NDArray[np.float64], sim_s: float, ahead: NDArray[np.float64]
    ) -> bool:
        if sim_s - goal.planned_s < self.config.replan_interval_s:
            return False
        if goal.path is None or goal.map_version != self.site_map.version:
            return True
        if float(np.hypot(*(ahead[0] - pose[:2]))) > self.config.deviation_m:
            return True
        reach = self.site_map.config.inflation_m + self.config.dynamic_margin_m
        return self.surroundings.marks_near(ahead, reach)

    def _plan(self, goal: Goal, pose: NDArray[np.float64], sim_s: float) -> NDArray[np.float64] | None:
        goal.planned_s, goal.map_version = sim_s, self.site_map.version
        marks = self.marks if sim_s >= goal.ignore_marks_until_s else ()
        grid = self.site_map.planning_grid(marks, self.config.dynamic_margin_m)
        # Inside an inflated zone (parked beside a column, pushed into a corner): leave it first, from the
        # nearest free cell (searched farther once the plan-out recovery ran).
        snap_m = self.config.plan_out_max_m if goal.plan_out else self.config.start_snap_m
        body = self.site_map.inflated_grid(self.config.body_half_width_m)
        free_start = plan_start(grid, pose[:2], snap_m, body)
        lead_in = escape_path(grid, pose[:2], body) if free_start is None and goal.plan_out else None
        if lead_in:  # what was built beside it narrowed its space: out through cells its body fits
            free_start = lead_in[-1]
        start = np.asarray(free_start if free_start is not None else pose[:2], float)
        result = plan_path(grid, start, goal.xy, snap_goal_to_free=True, max_snap_m=0.3)
        goal.blocked = not result.found and not grid.is_free(*goal.xy)
        if not result.found:
            if goal.no_path_since_s is None:
                _log.log(
                    _said(goal),
                    "no path to %s yet (%s): waiting",
                    np.round(goal.xy, 2).tolist(),
                    result.reason,
                )
                goal.no_path_since_s = sim_s
            goal.path = None
            return None
        goal.no_path_since_s = None
        if result.goal_snapped:
            goal.xy = result.path_xy_m[-1].copy()
        points = simplify_path(grid, result.path_xy_m)
        if lead_in:
            points = np.vstack([np.asarray(lead_in[:-1], float), points])
        elif not np.allclose(start, pose[:2]):
            points = np.vstack([pose[:2], points])
        goal.path, goal.grid = Path(points), grid
        self.replans += 1
        return points

    def _stuck(self, goal: Goal, pose: NDArray[np.float64], sim_s: float) -> bool:
        trail = goal.trail
        if not trail or sim_s - trail[-1][0] >= 0.5:
            trail.append((sim_s, float(pose[0]), float(pose[1])))
        while sim_s - trail[0][0] > self.config.stuck_window_s:
            trail.popleft()
        first = trail[0]
        if sim_s - first[0] < self.config.stuck_window_s - 0.5:
            return False
        return all(math.hypot(x - first[1], y - first[2]) < self.config.stuck_move_m for _, x, y in trail)

    def _recover(self, goal: Goal, pose: NDArray[np.float64], sim_s: float, why: str) -> NavCommand:
        """The next step of the recovery chain (:mod:`.recovery`), or FAILED when it is exhausted."""
        kind, goal.level = next_recovery(goal.level, clear_behind=self.surroundings.clear_behind(pose))
        if kind is None:
            return self._fail(why)
        goal.tried += (kind,)
        self.recoveries.append((sim_s, kind))
        _log.log(
            _said(goal),
            "%s at %s %s: recovery %s",
            self.robot_id,
            np.round(pose, 2).tolist(),
            why,
            kind.value,
        )
        goal.trail.clear()
        assert goal.watchdog is not None
        goal.watchdog.reset(sim_s)
        goal.planned_s, goal.path = -math.inf, None  # replan after the recovery
        if kind is Recovery.CLEAR_MARKS:
            goal.ignore_marks_until_s = sim_s + self.config.clear_marks_s
        elif kind is Recovery.ROTATE:
            goal.rotate_until_s = sim_s + self.config.rotate_s
            return self._command(*turn_command(math.pi, self.v_mps, self.w_radps, self.config.dwa))
        elif kind is Recovery.BACK_UP:
            goal.backup_until_s = sim_s + self.config.backup_s
            return self._command(-self.config.backup_speed_mps, 0.0)
        else:
            goal.plan_out = True
        return self._command(0.0, 0.0)


def _said(goal: Goal) -> int:
    """The log level of what happens on the way to ``goal``: info, or debug for a quiet one."""
    return logging.DEBUG if goal.quiet else logging.INFO
