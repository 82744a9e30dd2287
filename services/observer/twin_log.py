"""Bus messages → rerun archetypes at entity paths: what the observer draws, without a bus or a recording.

:class:`TwinLog` turns each received message into :class:`LogItem` s (entity path, archetype, static or
on the ``sim_time`` timeline at the message's sim time); the adapter (:mod:`.app`) only logs them. Kept
cheap on purpose, since the observer runs beside the simulation:

* every component's mesh (the converter's ``visual.glb``) is logged **once**, static (one built in
  place: once, when physics first poses it; it is never in the yard), and its text log lines name its
  method and the robot's type; afterwards a
  component costs a transform per pose change and a colour per state change
  (``Asset3D.from_fields(albedo_factor=…)``, a partial update that leaves the mesh alone);
* a moving body (a carried component, a robot) gets at most one transform per ``pose_min_interval_s`` of
  sim time, and none when it has not moved; the skipped latest pose is kept and given by
  :meth:`TwinLog.flush`, so the last pose always reaches the recording;
* every ``scan_every``-th laser scan per robot is drawn (:meth:`TwinLog.scan_wanted` is asked before the
  payload is even decoded); trails grow by a point per ``trail_step_m`` in
  segments of ``trail_segment_points`` points (each segment its own entity, so a log never re-sends the
  whole trail).

Entity paths (GUIDs escaped for rerun, ``$`` → ``\\$``; the viewer shows the plain GUID)::

    world, world/site/*, world/targets  the static scene, drawn by :mod:`.blueprint`
    world/components/<guid>             mesh (static; cast or laid: with its first pose) + Transform3D per
                                        pose + colour per state + its method as values (:mod:`.work_log`)
    world/work/<guid>[/courses]         cast or laid: its box while formed, poured, laid (:mod:`.work_log`)
    world/robots/<id>                   Transform3D (ground truth, else the robot's own state pose)
    world/robots/<id>/body              box coloured by robot state (a robot without a model)
    world/robots/<id>/model/<link>      its type's URDF link meshes, moved by joints (:mod:`.fleet_log`)
    world/robots/<id>/marker            point coloured by robot state, labelled with what it is doing (a
                                        robot with a model: ``r2 (pump): pour``)
    world/robots/<id>/scan              laser points in the robot frame (every N-th scan)
    world/trails/<id>/<segment>         driven path, world frame
    world/plans/<id>                    global plan, world frame; world/plans/<id>/goal
    progress/percent_constructed        Scalars; progress/components/<state>: Scalars (count)
    log/{components,tasks,robots,site}  TextLog
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

import rerun as rr
from pydantic import BaseModel

from bimbot.shared.manifest import Component, Manifest
from bimbot.shared.messages import (
    ComponentPoseMsg,
    ComponentState,
    ComponentStateMsg,
    PlanMsg,
    ProgressMsg,
    RobotPoseMsg,
    RobotState,
    RobotStateMsg,
    ScanMsg,
    SensorsMsg,
    SiteInfoMsg,
    TaskMsg,
    TaskStatus,
)
from bimbot.shared.report.methods import method_word
from bimbot.shared.site_plan import SiteLayout
from bimbot.shared.state_colors import ROBOT_COLORS, STATE_COLORS

from .fleet_log import FleetLog
from .twin_items import (
    PLAN_Z_M,
    ROBOT_HALF_SIZE_M,
    SITE_LINE_Z_M,
    STATE_LOG_LEVELS,
    LogItem,
    component_color,
    component_path,
    mesh_archetype,
    plan_path,
    planar_transform,
    robot_path,
    trail_path,
    transform,
)
from .work_log import WorkLog, robot_label, yard_kept


@dataclass(frozen=True)
class TwinLogOptions:
    scan_every: int = 10  # draw every N-th scan of each robot
    pose_min_interval_s: float = 0.1  # sim seconds between two transforms of one moving body
    pose_min_move_m: float = 0.002  # smaller moves are not logged
    pose_min_turn_rad: float = 0.002
    trail_step_m: float = 0.25  # a trail point per this much driving
    trail_segment_points: int = 64
    laser_height_m: float = 0.3  # scan points drawn at this height above the robot frame


@dataclass
class _Motion:
    """Throttling state of one moving body."""

    last_logged_s: float = -math.inf
    last_position: tuple[float, ...] = ()
    last_angle: tuple[float, ...] = ()
    pending: tuple[float, LogItem, tuple[float, ...], tuple[float, ...]] | None = None

    def take_pending(self) -> tuple[float, LogItem] | None:
        """The held-back pose (now counted as logged), or None."""
        if self.pending is None:
            return None
        sim_time_s, item, position, angle = self.pending
        self.last_logged_s, self.last_position, self.last_angle = sim_time_s, position, angle
        self.pending = None
        return sim_time_s, item


@dataclass
class _Trail:
    segment: int = 0
    points: list[tuple[float, float, float]] = field(default_factory=list)


MeshLoader = Callable[[Component], tuple[bytes, str] | None]


class TwinLog:
    """Turns bus messages into log items; remembers only what throttling and de-duplication need."""

    def __init__(self, manifest: Manifest, options: TwinLogOptions | None = None) -> None:
        self.manifest = manifest
        self.options = options or TwinLogOptions()
        self._components = {c.guid: c for c in manifest.components}
        self._motion: dict[str, _Motion] = {}
        self._trails: dict[str, _Trail] = {}
        self._scan_counts: dict[str, int] = {}
        self._robot_states: dict[str, tuple[RobotState, str]] = {}  # robot → (state, activity) drawn
        self.robot_type_of: dict[str, str] = {}  # robot id → type, from physics' site info
        self.work = WorkLog(manifest.components, self.robot_type_of)  # cast and laid components
        self._ground_truth: set[str] = set()  # robots seen on robots/<id>/pose
        self._last_plan: dict[str, tuple[tuple[float, float], ...]] = {}
        self._last_counts: tuple[int, ...] = ()
        self.fleet = FleetLog(self.options.pose_min_interval_s)
        self._handlers: dict[type[BaseModel], Callable[[Any], list[LogItem]]] = {
            ComponentStateMsg: self.component_state,
            ComponentPoseMsg: self.component_pose,
            RobotStateMsg: self.robot_state,
            RobotPoseMsg: self.robot_pose,
            ScanMsg: self.scan,
            SensorsMsg: self.sensors,
            PlanMsg: self.plan,
            TaskMsg: self.task,
            ProgressMsg: self.progress,
        }

    def items(self, message: BaseModel) -> list[LogItem]:
        """The log items of any bus message (none for the kinds the twin does not draw)."""
        handler = self._handlers.get(type(message))
        return handler(message) if handler is not None else []

    # --- the start of a run ---

    def scene(self, load_mesh: MeshLoader) -> tuple[list[LogItem], list[LogItem]]:
        """``(static meshes, items at sim time 0)``: every mesh once; then each component's colour."""
        static: list[LogItem] = []
        initial: list[LogItem] = []
        for component in self.manifest.components:
            path = component_path(component.guid)
            mesh = load_mesh(component)
            if self.work.built_in_place(component.guid):  # drawn once built (:mod:`.work_log`)
                self.work.hold_mesh(component.guid, mesh)
            elif mesh is not None:
                static.append(LogItem(path, mesh_archetype(*mesh), static=True))
            initial.append(LogItem(path, component_color(ComponentState.PLANNED)))
        initial += self.work.initial()
        for component in self.manifest.in_place:  # in place from the start (convert --in-place): built
            path = component_path(component.guid)
            mesh = load_mesh(component)
            if mesh is not None:
                target = component.target_pose_world
                static.append(LogItem(path, mesh_archetype(*mesh), static=True))
                static.append(LogItem(path, transform(target.position_m, target.quat_xyzw), static=True))
                static.append(LogItem(path, component_color(ComponentState.CONSTRUCTED), static=True))
        return static, initial

    def yard_poses(self, layout: SiteLayout) -> list[LogItem]:
        """Every component at its yard slot, for sim time 0: the site physics planned (its site info)."""
        items = []
        for component in self.manifest.components:
            slot = layout.slots.get(component.guid)
            if slot is not None and yard_kept(component):  # cast or laid: never in the yard
                # temporal, not static: a static transform would hide every later pose
                items.append(
                    LogItem(component_path(component.guid), transform(slot.position_m, slot.quat_xyzw))
                )
        return items

    def robots(self, info: SiteInfoMsg, now_s: float) -> tuple[list[LogItem], list[LogItem], list[LogItem]]:
        """``(static meshes, link poses for sim time 0, items for now_s)``: every robot on site as its
        type's model; a box drawn before the site was known is cleared, its state goes on the model's
        marker, and joint values heard before pose its links."""
        self.robot_type_of.update(info.robot_type_of)
        static, initial = self.fleet.site_known(info)
        now: list[LogItem] = self.fleet.catch_up(now_s)
        for robot_id, (state, activity) in self._robot_states.items():
            if self.fleet.drawn(robot_id):
                now.append(LogItem(f"{robot_path(robot_id)}/body", rr.Clear(recursive=False)))
                now += self.fleet.robot_state(robot_id, state, activity)
        return static, initial, now

    # --- messages ---

    def component_state(self, msg: ComponentStateMsg) -> list[LogItem]:
        component = self._components.get(msg.guid)
        label = msg.guid
        if component is not None:
            label = f"{component.name or msg.guid} ({component.ifc_class}, {method_word(component.method)})"
        previous = msg.previous.value if msg.previous else "start"
        details = [f"[{msg.event}]"]
        if msg.robot_id:
            details.append(f"robot {robot_label(msg.robot_id, self.robot_type_of)}")
        if msg.attempt:
            details.append(f"attempt {msg.attempt}")
        if msg.position_error_m is not None:
            details.append(f"error {msg.position_error_m * 1000:.1f} mm")
        if msg.angle_error_rad is not None:
            details.append(f"{math.degrees(msg.angle_error_rad):.2f}°")
        if msg.cause:
            details.append(msg.cause)
        text = f"{label} {msg.guid}: {previous} → {msg.state.value} " + " ".join(details)
        return [
            LogItem(component_path(msg.guid), component_color(msg.state)),
            LogItem(
                "log/components",
                rr.TextLog(
                    text, level=STATE_LOG_LEVELS.get(msg.state, "INFO"), color=STATE_COLORS[msg.state]
                ),
            ),
            *self.work.component_state(msg),
        ]

    def component_pose(self, msg: ComponentPoseMsg) -> list[LogItem]:
        item = LogItem(component_path(msg.guid), transform(msg.pose.position_m, msg.pose.quat_xyzw))
        moving = msg.attached_to is not None and not msg.fixed
        return self.work.component_pose(msg) + self._throttled(
            f"component/{msg.guid}",
            msg.sim_time_s,
            msg.pose.position_m,
            msg.pose.quat_xyzw,
            item,
            moving=moving,
        )

    def robot_pose(self, msg: RobotPoseMsg) -> list[LogItem]:
        self._ground_truth.add(msg.robot_id)
        return self._robot_motion(msg.robot_id, msg.sim_time_s, msg.pose_xy_yaw) + self.fleet.robot_pose(msg)

    def robot_state(self, msg: RobotStateMsg) -> list[LogItem]:
        items: list[LogItem] = []
        if msg.robot_id not in self._ground_truth:
            items += self._robot_motion(msg.robot_id, msg.sim_time_s, msg.pose_xy_yaw)
        drawn = self._robot_states.get(msg.robot_id)
        if drawn == (msg.state, msg.activity):  # a repeat (robots say their state every period)
            return items
        self._robot_states[msg.robot_id] = (msg.state, msg.activity)
        items += self.work.robot_state(msg)  # a laid wall's courses
        color = ROBOT_COLORS[msg.state]
        items += self.fleet.robot_state(msg.robot_id, msg.state, msg.activity)
        if not self.fleet.drawn(msg.robot_id):
            label = msg.robot_id + (f": {msg.activity}" if msg.activity else "")
            box = rr.Boxes3D(
                half_sizes=[ROBOT_HALF_SIZE_M],
                centers=[(0.0, 0.0, ROBOT_HALF_SIZE_M[2])],
                colors=[color],
                labels=[label],
                fill_mode="solid",
            )
            items.append(LogItem(f"{robot_path(msg.robot_id)}/body", box))
        previous = drawn[0] if drawn is not None else None
        if previous == msg.state:  # the same state, another step of its work (a course, the pour)
            activity = f"robot {robot_label(msg.robot_id, self.robot_type_of)}: {msg.activity}"
            if msg.busy_until_s is not None:
                activity += f" until sim {msg.busy_until_s:.0f} s"
            items.append(LogItem("log/robots", rr.TextLog(activity, level="INFO", color=color)))
            return items
        items.append(
            LogItem(
                f"{robot_path(msg.robot_id)}/heading",
                rr.Arrows3D(
                    vectors=[(0.8, 0.0, 0.0)], origins=[(0.0, 0.0, 0.45)], colors=[color], radii=0.03
                ),
            )
        )
        task = f" task {msg.task_id} ({msg.guid})" if msg.task_id else ""
        doing = f": {msg.activity}" if msg.activity else ""
        text = (
            f"robot {robot_label(msg.robot_id, self.robot_type_of)}: "
            f"{previous.value if previous else 'start'} → {msg.state.value}{task}{doing}"
        )
        items.append(LogItem("log/robots", rr.TextLog(text, level="INFO", color=color)))
        if msg.state == RobotState.IDLE:
            items += self._flush_motion(f"robot/{msg.robot_id}")
        return items

    def scan_wanted(self, robot_id: str) -> bool:
        """Count a scan of ``robot_id``; True for every ``scan_every``-th (asked before decoding it)."""
        count = self._scan_counts.get(robot_id, 0)
        self._scan_counts[robot_id] = count + 1
        return count % max(1, self.options.scan_every) == 0

    def sensors(self, msg: SensorsMsg) -> list[LogItem]:
        """A robot's sensors of one period: its scan is drawn every ``scan_every``-th time."""
        if msg.scan is None or not self.scan_wanted(msg.robot_id):
            return []
        return self.scan(msg.scan)

    def scan(self, msg: ScanMsg) -> list[LogItem]:
        """The scan's hits as points in the robot frame (call for the scans :meth:`scan_wanted` picks)."""
        z = self.options.laser_height_m
        points = [
            (
                r * math.cos(msg.angle_min_rad + i * msg.angle_increment_rad),
                r * math.sin(msg.angle_min_rad + i * msg.angle_increment_rad),
                z,
            )
            for i, r in enumerate(msg.ranges_m)
            if math.isfinite(r) and 0.0 < r < msg.range_max_m
        ]
        return [
            LogItem(
                f"{robot_path(msg.robot_id)}/scan",
                rr.Points3D(points, colors=[(255, 64, 64, 255)], radii=0.03),
            )
        ]

    def plan(self, msg: PlanMsg) -> list[LogItem]:
        path = tuple((float(x), float(y)) for x, y in msg.path_xy_m)
        if self._last_plan.get(msg.robot_id) == path:
            return []
        self._last_plan[msg.robot_id] = path
        strip = [(x, y, PLAN_Z_M) for x, y in path]
        goal = (msg.goal_xy_m[0], msg.goal_xy_m[1], PLAN_Z_M)
        return [
            LogItem(
                plan_path(msg.robot_id), rr.LineStrips3D([strip], colors=[(0, 200, 255, 255)], radii=0.04)
            ),
            LogItem(
                f"{plan_path(msg.robot_id)}/goal",
                rr.Points3D([goal], colors=[(0, 200, 255, 255)], radii=0.15),
            ),
        ]

    def task(self, msg: TaskMsg) -> list[LogItem]:
        robot = f" → robot {msg.robot_id}" if msg.robot_id else ""
        attempt = f" (attempt {msg.attempt})" if msg.attempt else ""
        level = {TaskStatus.FAILED: "ERROR", TaskStatus.BLOCKED: "WARN"}.get(msg.status, "INFO")
        text = f"task {msg.task_id} {msg.status.value}: {msg.guid}{robot}{attempt}"
        return [LogItem("log/tasks", rr.TextLog(text, level=level))]

    def progress(self, msg: ProgressMsg) -> list[LogItem]:
        """Plot points when the counts change (the planner repeats unchanged progress every second)."""
        counts = tuple(msg.counts.get(state.value, 0) for state in STATE_COLORS)
        if counts == self._last_counts and not msg.done:
            return []
        self._last_counts = counts
        items = [LogItem("progress/percent_constructed", rr.Scalars(msg.percent_constructed))]
        items += [
            LogItem(f"progress/components/{state.value}", rr.Scalars(float(msg.counts.get(state.value, 0))))
            for state in STATE_COLORS
        ]
        return items

    def site_event(self, text: str, level: str = "INFO") -> list[LogItem]:
        return [LogItem("log/site", rr.TextLog(text, level=level))]

    def flush(self) -> list[tuple[float, LogItem]]:
        """Poses held back by throttling, with their sim times (call at the end of a run)."""
        taken = (motion.take_pending() for motion in self._motion.values())
        return [item for item in taken if item is not None] + self.fleet.flush()

    # --- helpers ---

    def _robot_motion(
        self, robot_id: str, sim_time_s: float, pose_xy_yaw: tuple[float, float, float]
    ) -> list[LogItem]:
        x, y, yaw = pose_xy_yaw
        item = LogItem(robot_path(robot_id), planar_transform(pose_xy_yaw))
        items = self._throttled(f"robot/{robot_id}", sim_time_s, (x, y), (yaw,), item, moving=True)
        trail = self._trails.setdefault(robot_id, _Trail())
        point = (x, y, SITE_LINE_Z_M)
        if trail.points and math.dist(trail.points[-1][:2], point[:2]) < self.options.trail_step_m:
            return items
        if len(trail.points) >= self.options.trail_segment_points:
            trail.segment += 1
            trail.points = trail.points[-1:]  # the new segment starts where the old one ends
        trail.points.append(point)
        if len(trail.points) >= 2:
            items.append(
                LogItem(
                    trail_path(robot_id, trail.segment),
                    rr.LineStrips3D([trail.points], colors=[(255, 255, 255, 180)], radii=0.02),
                )
            )
        return items

    def _throttled(
        self,
        name: str,
        sim_time_s: float,
        position: Iterable[float],
        angle: Iterable[float],
        item: LogItem,
        *,
        moving: bool,
    ) -> list[LogItem]:
        """``[item]`` unless the body has not moved, or moved again too soon (then it is kept pending)."""
        motion = self._motion.setdefault(name, _Motion())
        position, angle = tuple(position), tuple(angle)
        options = self.options
        if motion.last_position and (
            math.dist(position, motion.last_position) < options.pose_min_move_m
            and math.dist(angle, motion.last_angle) < options.pose_min_turn_rad
        ):
            return []
        if moving and sim_time_s - motion.last_logged_s < options.pose_min_interval_s:
            motion.pending = (sim_time_s, item, position, angle)
            return []
        motion.last_logged_s, motion.last_position, motion.last_angle = sim_time_s, position, angle
        motion.pending = None
        return [item]

    def _flush_motion(self, name: str) -> list[LogItem]:
        motion = self._motion.get(name)
        taken = motion.take_pending() if motion is not None else None
        return [taken[1]] if taken is not None else []
