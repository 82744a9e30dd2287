"""A pure-Python stand-in for physics, for the robot's tests: unicycle robots on the site's grid.

:class:`SimPhysics` plays the physics contract without PyBullet or a bus: ideal unicycle motion from each
``cmd_vel``, noisy odometry (multiplicative speed noise and a yaw-rate bias, so dead reckoning drifts), a
2D laser ray-marched on the laser-visible grid with the other robots drawn in as discs, component poses
(all at start, carried ones every step, fixed ones when placed), and the attach (reach-checked against the
true pose) and place (reply after the assembly motion) requests. :class:`SiteSim` runs it in lock-step
with real component agents, the real planner core and one
:class:`~bimbot.services.robot.executor.Executor` per robot, passing messages between them one step late,
as a bus would.
"""

from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bimbot.services.component_agents.agent import ComponentAgent
from bimbot.services.planner.scheduler import PlannerCore
from bimbot.services.planner.sources import PlanSource, SourceKind, load_plan
from bimbot.services.robot.executor import Executor, ExecutorConfig
from bimbot.services.robot.particle_filter import simulate_scan, wrap_angle
from bimbot.services.robot.protocol import PhysicsRequest, PhysicsResult
from bimbot.services.robot.site_map import SiteMap
from bimbot.shared.component_states import TwinQuestion
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import (
    AttachRequest,
    ClockMsg,
    CmdVelMsg,
    ComponentEventMsg,
    ComponentPoseMsg,
    ComponentStateMsg,
    DropRequest,
    OdomMsg,
    PhysicsReply,
    PlaceRequest,
    PlanMsg,
    PoseMsg,
    RobotPoseMsg,
    RobotStateMsg,
    ScanMsg,
    SiteInfoMsg,
    TaskMsg,
)
from bimbot.shared.occupancy_grid import OccupancyGrid
from bimbot.shared.robot_description import DEFAULT_ROBOT
from bimbot.shared.site_layout import plan_site

BODY_RADIUS_M = 0.45  # what other robots' lasers see of a robot
N_BEAMS = 180
RANGE_MAX_M = 15.0


@dataclass
class SimRobot:
    pose: np.ndarray  # true x, y, yaw
    odom: np.ndarray
    v_mps: float = 0.0
    w_radps: float = 0.0


@dataclass
class _Pending:
    due_step: int
    robot_id: str
    result: PhysicsResult


class SimPhysics:
    """Physics stand-in (see the module doc); reach: true pose to the footprint's rectangle, as physics."""

    def __init__(
        self,
        manifest: Manifest,
        robot_ids: tuple[str, ...],
        *,
        seed: int = 0,
        control_period_s: float = 0.1,
        reach_m: float = 1.5,
        odom_noise: float = 0.02,
    ) -> None:
        self.manifest = manifest
        self.components = {c.guid: c for c in manifest.components}
        self.layout = plan_site(manifest.components, robots=len(robot_ids))
        self.truth = SiteMap(self.layout, manifest.components)  # the world as it is
        self.rng = np.random.default_rng(seed)
        self.dt = control_period_s
        self.reach_m = reach_m
        self.odom_noise = odom_noise
        self.robot_ids = robot_ids
        self.robots = {
            rid: SimRobot(np.array(start, float), np.array(start, float))
            for rid, start in zip(robot_ids, self.layout.robot_starts, strict=True)
        }
        self.poses: dict[str, ComponentPoseMsg] = {}
        for guid, slot in self.layout.slots.items():
            pose = PoseMsg(position_m=slot.position_m, quat_xyzw=slot.quat_xyzw)
            self.poses[guid] = ComponentPoseMsg(guid=guid, pose=pose, sim_time_s=0.0)
        self.carried: dict[str, str] = {}  # guid → robot
        self.dropped: list[ComponentPoseMsg] = []  # put down since the last step: published with it
        self.placing: dict[str, tuple[int, PlaceRequest]] = {}  # guid → (due step, request)
        self.pending: list[_Pending] = []
        self.step = 0
        self.angles = np.linspace(-math.pi, math.pi, N_BEAMS, endpoint=False)

    @property
    def sim_s(self) -> float:
        return self.step * self.dt

    def info(self) -> SiteInfoMsg:
        return SiteInfoMsg(
            robot_ids=list(self.robot_ids),
            robot_starts_xy_yaw=[tuple(map(float, s)) for s in self.layout.robot_starts],
            step_s=self.dt / 10,
            control_period_s=self.dt,
            lock_step=True,
            robot_type_of={robot_id: DEFAULT_ROBOT.name for robot_id in self.robot_ids},
            robot_types={DEFAULT_ROBOT.name: DEFAULT_ROBOT.model_copy(update={"reach_m": self.reach_m})},
            layout=self.layout,
        )

    def start_messages(self) -> list[object]:
        return list(self.poses.values())

    def request(self, request: PhysicsRequest, latency_steps: int = 1) -> None:
        message = request.message
        if isinstance(message, AttachRequest):
            reply = self._attach(message)
            self.pending.append(
                _Pending(
                    self.step + latency_steps, message.robot_id, PhysicsResult(request.request_id, reply)
                )
            )
        elif isinstance(message, DropRequest):
            reply = self._drop(message)
            self.pending.append(
                _Pending(
                    self.step + latency_steps, message.robot_id, PhysicsResult(request.request_id, reply)
                )
            )
        elif isinstance(message, PlaceRequest):
            due = self.step + max(1, round(message.duration_s / self.dt))
            self.placing[message.guid] = (due, message)
            self.pending.append(
                _Pending(due, message.robot_id, PhysicsResult(request.request_id, None, "placing"))
            )

    def advance(self, commands: dict[str, CmdVelMsg]) -> list[object]:
        """Integrate one control period; the messages physics would publish for the new step."""
        self.step += 1
        out: list[object] = [
            ClockMsg(sim_time_s=self.sim_s, step=self.step, real_time_factor=1.0, lock_step=True)
        ]
        for rid, robot in self.robots.items():
            cmd = commands.get(rid)
            v, w = (cmd.v_mps, cmd.w_radps) if cmd is not None else (0.0, 0.0)
            previous = robot.pose
            robot.pose = _integrate(robot.pose, v, w, self.dt)
            robot.odom, v_odom, w_odom = self._odometry(robot.odom, previous, robot.pose)
            robot.v_mps, robot.w_radps = v, w
            out.append(
                OdomMsg(
                    robot_id=rid,
                    pose_xy_yaw=tuple(map(float, robot.odom)),
                    v_mps=v_odom,
                    w_radps=w_odom,
                    sim_time_s=self.sim_s,
                )
            )
            out.append(
                RobotPoseMsg(robot_id=rid, pose_xy_yaw=tuple(map(float, robot.pose)), sim_time_s=self.sim_s)
            )
        out.extend(self.dropped)
        self.dropped = []
        for guid, rid in self.carried.items():
            if guid in self.placing:
                continue
            pose = self.robots[rid].pose
            msg = ComponentPoseMsg(
                guid=guid,
                pose=PoseMsg(
                    position_m=(float(pose[0]), float(pose[1]), 0.8), quat_xyzw=(0.0, 0.0, 0.0, 1.0)
                ),
                sim_time_s=self.sim_s,
                attached_to=rid,
            )
            self.poses[guid] = msg
            out.append(msg)
        for guid, (due, request) in list(self.placing.items()):
            if due > self.step:  # the assembly motion: on its way, 5 cm per step short of the target
                x, y, z = request.pose.position_m
                moving = PoseMsg(
                    position_m=(x + 0.05 * (due - self.step), y, z), quat_xyzw=request.pose.quat_xyzw
                )
                msg = ComponentPoseMsg(
                    guid=guid, pose=moving, sim_time_s=self.sim_s, attached_to=request.robot_id
                )
                self.poses[guid] = msg
                out.append(msg)
            else:
                del self.placing[guid]
                self.carried.pop(guid, None)
                # no dynamics here: a placed component is fixed for good at once (joined, in physics' words)
                msg = ComponentPoseMsg(
                    guid=guid, pose=request.pose, sim_time_s=self.sim_s, fixed=True, joined=True
                )
                self.poses[guid] = msg
                self.truth.observe_pose(msg)
                out.append(msg)
                for pending in self.pending:
                    if (
                        pending.result.error == "placing"
                        and pending.due_step == due
                        and pending.robot_id == request.robot_id
                    ):
                        pending.result = PhysicsResult(
                            pending.result.request_id,
                            PhysicsReply(ok=True, sim_time_s=self.sim_s, pose=request.pose),
                        )
        for rid in self.robots:
            out.append(self._scan(rid))
        return out

    def _odometry(
        self, odom: np.ndarray, previous: np.ndarray, current: np.ndarray
    ) -> tuple[np.ndarray, float, float]:
        """Physics' odometry model: each increment's distance scaled by N(1, noise), heading disturbed."""
        c, s = math.cos(previous[2]), math.sin(previous[2])
        dx, dy = current[0] - previous[0], current[1] - previous[1]
        forward, left = c * dx + s * dy, -s * dx + c * dy
        turn = float(wrap_angle(current[2] - previous[2]))
        distance = math.hypot(forward, left)
        scale = 1.0 + self.rng.normal(0.0, self.odom_noise)
        forward, left = forward * scale, left * scale
        turn += self.rng.normal(0.0, self.odom_noise * (abs(turn) + 0.2 * distance))
        co, so = math.cos(odom[2]), math.sin(odom[2])
        new = np.array(
            [
                odom[0] + co * forward - so * left,
                odom[1] + so * forward + co * left,
                float(wrap_angle(odom[2] + turn)),
            ]
        )
        return new, forward / self.dt, turn / self.dt

    def due_results(self) -> list[tuple[str, PhysicsResult]]:
        due = [p for p in self.pending if p.due_step <= self.step and p.result.error != "placing"]
        self.pending = [p for p in self.pending if p not in due]
        return [(p.robot_id, p.result) for p in due]

    def _attach(self, request: AttachRequest) -> PhysicsReply:
        footprint = self.truth.footprints.get(request.guid)
        robot = self.robots[request.robot_id]
        if footprint is None:
            return PhysicsReply(ok=False, reason="already carried", sim_time_s=self.sim_s)
        poly = footprint.polygon_xy_m  # physics: distance to the footprint's bounding rectangle
        gap = np.maximum(
            np.maximum(poly.min(axis=0) - robot.pose[:2], robot.pose[:2] - poly.max(axis=0)), 0.0
        )
        distance = float(np.hypot(*gap))
        if distance > self.reach_m:
            return PhysicsReply(ok=False, reason=f"out of reach ({distance:.2f} m)", sim_time_s=self.sim_s)
        self.carried[request.guid] = request.robot_id
        pose = self.poses[request.guid]
        self.truth.observe_pose(
            ComponentPoseMsg(
                guid=request.guid, pose=pose.pose, sim_time_s=self.sim_s, attached_to=request.robot_id
            )
        )
        return PhysicsReply(ok=True, sim_time_s=self.sim_s)

    def _drop(self, request: DropRequest) -> PhysicsReply:
        """The load put down 1.5 m to the robot's left, lying as in its yard slot."""
        if self.carried.get(request.guid) != request.robot_id or request.guid in self.placing:
            return PhysicsReply(
                ok=False, reason=f"robot {request.robot_id} does not carry it", sim_time_s=self.sim_s
            )
        del self.carried[request.guid]
        x, y, yaw = self.robots[request.robot_id].pose
        slot = self.layout.slots[request.guid]
        position = (float(x - 1.5 * math.sin(yaw)), float(y + 1.5 * math.cos(yaw)), slot.position_m[2])
        pose = PoseMsg(position_m=position, quat_xyzw=slot.quat_xyzw)
        message = ComponentPoseMsg(guid=request.guid, pose=pose, sim_time_s=self.sim_s)
        self.poses[request.guid] = message
        self.truth.observe_pose(message)
        self.dropped.append(message)
        return PhysicsReply(ok=True, sim_time_s=self.sim_s, pose=pose)

    def _scan(self, rid: str) -> ScanMsg:
        grid = self.truth.laser_grid()
        others = [r.pose[:2] for other, r in self.robots.items() if other != rid]
        if others:
            grid = _with_discs(grid, others, BODY_RADIUS_M)
        pose = self.robots[rid].pose
        ranges = simulate_scan(grid, pose, self.angles, RANGE_MAX_M, step_m=0.05)
        ranges = np.where(ranges < RANGE_MAX_M, ranges + self.rng.normal(0.0, 0.01, ranges.shape), ranges)
        return ScanMsg(
            robot_id=rid,
            angle_min_rad=float(self.angles[0]),
            angle_increment_rad=float(self.angles[1] - self.angles[0]),
            range_max_m=RANGE_MAX_M,
            ranges_m=[float(r) for r in ranges],
            sim_time_s=self.sim_s,
        )


def _integrate(pose: np.ndarray, v: float, w: float, dt: float) -> np.ndarray:
    yaw_mid = pose[2] + 0.5 * w * dt
    return np.array(
        [
            pose[0] + v * dt * math.cos(yaw_mid),
            pose[1] + v * dt * math.sin(yaw_mid),
            float(wrap_angle(pose[2] + w * dt)),
        ]
    )


def _with_discs(grid: OccupancyGrid, centres: list[np.ndarray], radius_m: float) -> OccupancyGrid:
    cells = grid.occupied.copy()
    for centre in centres:
        rc = grid.world_to_cell(centre)
        n = math.ceil(radius_m / grid.resolution_m)
        rr, cc = np.mgrid[rc[0] - n : rc[0] + n + 1, rc[1] - n : rc[1] + n + 1]
        xy = grid.cell_to_world(np.stack([rr.ravel(), cc.ravel()], 1))
        inside = np.hypot(*(xy - centre).T) <= radius_m
        keep = inside & grid.in_bounds(np.stack([rr.ravel(), cc.ravel()], 1))
        cells[rr.ravel()[keep], cc.ravel()[keep]] = True
    return grid.with_occupied(cells)


@dataclass
class SimRecord:
    events: list[ComponentEventMsg] = field(default_factory=list)
    states: list[ComponentStateMsg] = field(default_factory=list)
    robot_states: dict[str, list[RobotStateMsg]] = field(default_factory=lambda: defaultdict(list))
    plans: list[PlanMsg] = field(default_factory=list)
    cmd_steps: dict[str, list[int]] = field(default_factory=lambda: defaultdict(list))
    requests: list[PhysicsRequest] = field(default_factory=list)
    min_separation_m: float = math.inf
    true_paths: dict[str, list[tuple[float, float]]] = field(default_factory=lambda: defaultdict(list))


class SiteSim:
    """Physics stand-in + real agents + real planner core + executors, in lock-step (see the module doc)."""

    def __init__(
        self,
        manifest: Manifest,
        build_dir: Path,
        robot_ids: tuple[str, ...] = ("r1",),
        *,
        seed: int = 0,
        source: SourceKind = SourceKind.BUILD,
        **executor_options: object,
    ) -> None:
        self.physics = SimPhysics(manifest, robot_ids, seed=seed)
        self.agents = {c.guid: ComponentAgent(c) for c in manifest.components}
        plan = load_plan(manifest, build_dir, PlanSource(source))
        self.planner = PlannerCore(manifest, plan, resend_s=1.0)
        info = self.physics.info()
        self.executors = {
            rid: Executor(manifest, info, ExecutorConfig(robot_id=rid, seed=seed, **executor_options))
            for rid in robot_ids  # type: ignore[arg-type]
        }
        for rid in robot_ids:
            self.planner.robot_liveliness(rid, True)
        self.planner.finish_sync()
        self.record = SimRecord()
        self._inflight: list[object] = list(self.physics.start_messages())
        self._late: list[object] = []
        self._commands: dict[str, CmdVelMsg] = {}

    def wall_s(self) -> float:
        return self.physics.sim_s  # the sim runs as fast as it can: one wall second per sim second here

    def run(self, max_steps: int, until=None) -> int:
        """Advance up to ``max_steps`` control steps (or until ``until(self)``); the steps taken."""
        for n in range(max_steps):
            messages = self.physics.advance(self._commands)
            clock = messages[0]
            # Component poses take one step longer than the physics replies (another route over the bus):
            # an event must not be stamped so that a pose from the assembly motion passes for the placement.
            poses = [m for m in messages[1:] if isinstance(m, ComponentPoseMsg)]
            others = [m for m in messages[1:] if not isinstance(m, ComponentPoseMsg)]
            deliver, self._inflight = self._inflight + self._late + others, []
            self._late = poses
            for message in deliver:
                self._deliver(message)
            for rid, result in self.physics.due_results():
                self.executors[rid].handle(result)
            self._commands = {}
            now = self.wall_s()
            for rid, executor in self.executors.items():
                for out in executor.tick(clock, now):  # type: ignore[arg-type]
                    self._route(rid, out, self._commands)
            for out in self.planner.step(now):
                self._inflight.append(out)
            for agent in self.agents.values():
                self._inflight.extend(agent.try_verify(now))
            if until is not None and until(self):
                return n + 1
        return max_steps

    def _deliver(self, message: object) -> None:
        if isinstance(message, ComponentEventMsg):
            self._inflight.extend(self.agents[message.guid].apply_event(message, self.wall_s()))
            return
        if isinstance(message, ComponentPoseMsg):
            self._inflight.extend(self.agents[message.guid].observe_pose(message, self.wall_s()))
            self.planner.observe_component_pose(message)
        elif isinstance(message, ComponentStateMsg):
            self.record.states.append(message)
            self.planner.observe_component_state(message)
        elif isinstance(message, RobotStateMsg):
            self.planner.observe_robot_state(message)
        elif isinstance(message, RobotPoseMsg):
            self.record.true_paths[message.robot_id].append(message.pose_xy_yaw[:2])
        for executor in self.executors.values():
            executor.handle(message)
        if isinstance(message, TaskMsg | ComponentStateMsg | RobotStateMsg | PlanMsg):
            return

    def _route(self, rid: str, out: object, commands: dict[str, CmdVelMsg]) -> None:
        if isinstance(out, CmdVelMsg):
            commands[rid] = out
            self.record.cmd_steps[rid].append(out.step or -1)
        elif isinstance(out, PhysicsRequest):
            self.record.requests.append(out)
            self.physics.request(out)
        elif isinstance(out, RobotStateMsg):
            self.record.robot_states[rid].append(out)
            self._inflight.append(out)
        elif isinstance(out, PlanMsg):
            self.record.plans.append(out)
        elif isinstance(out, ComponentEventMsg):
            self.record.events.append(out)
            self._inflight.append(out)
        elif isinstance(out, TwinQuestion):  # the agent's twin queryable answers at once
            self._inflight.append(self.agents[out.guid].twin())
        else:
            self._inflight.append(out)

    def all_constructed(self) -> bool:
        return all(agent.state.value == "constructed" for agent in self.agents.values())
