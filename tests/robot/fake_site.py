"""A fake site for the executor's tests: one robot on an ideal base, fake physics (attach, place, drop) and
fake components that follow the agents' state table."""

from __future__ import annotations

import math
import time
from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np
from twins import twin_message

from bimbot.services.robot.executor import Executor, ExecutorConfig
from bimbot.services.robot.particle_filter import simulate_scan, wrap_angle
from bimbot.services.robot.protocol import PhysicsRequest, PhysicsResult
from bimbot.shared.component_states import TwinQuestion
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import (
    AttachRequest,
    ClockMsg,
    CmdVelMsg,
    ComponentEvent,
    ComponentEventMsg,
    ComponentPoseMsg,
    ComponentState,
    ComponentStateMsg,
    DropRequest,
    OdomMsg,
    PhysicsReply,
    PlaceRequest,
    PoseMsg,
    RobotState,
    RobotStateMsg,
    ScanMsg,
    SiteInfoMsg,
    TaskMsg,
    TaskStatus,
    TwinMsg,
)
from bimbot.shared.occupancy_grid import OccupancyGrid
from bimbot.shared.robot_description import DEFAULT_ROBOT
from bimbot.shared.site_layout import plan_site
from bimbot.shared.state_table import Verdict, next_state

ANGLES = np.linspace(-math.pi, math.pi, 120, endpoint=False)
DT = 0.1


@dataclass
class FakeSite:
    """One robot on an ideal base; fake physics (replies ``latency`` steps late) and fake components that
    follow the agents' state table and judge every placement by its distance to the target."""

    manifest: Manifest
    executor: Executor
    pose: np.ndarray
    latency: int = 3
    drop_first: set[ComponentEvent] = field(default_factory=set)  # the agent misses the first delivery
    lose_state: set[ComponentState] = field(default_factory=set)  # the first message of it is lost on the way
    refuse_attach: int = 0  # physics refuses this many attach requests
    refuse_distance_m: float | None = None  # the distance physics measured, on those refusals
    wait_place: int = 0  # physics says "not now: another robot stands there" to this many place requests
    wait_s: float = 5.0  # how long it says to wait
    frozen: bool = False  # the robot does not move whatever it is told (stuck wheels)
    step: int = 0
    states: dict[str, ComponentState] = field(default_factory=dict)
    events: list[ComponentEventMsg] = field(default_factory=list)
    applied: list[ComponentEvent] = field(default_factory=list)
    robot_states: list[RobotState] = field(default_factory=list)
    commands: list[CmdVelMsg] = field(default_factory=list)
    requests: list[PhysicsRequest] = field(default_factory=list)
    request_steps: list[int] = field(default_factory=list)  # the step each request came at
    due: list[tuple[int, object]] = field(default_factory=list)
    carried: str | None = None
    tick_s: list[float] = field(default_factory=list)
    history: dict[str, list[ComponentStateMsg]] = field(default_factory=dict)  # the twins' transitions
    twin_questions: list[str] = field(default_factory=list)  # GUIDs whose twin the robot asked
    traffic_xy_m: list[tuple[float, float]] = field(default_factory=list)  # other robots its laser sees
    traffic_radius_m: float = 0.4
    _traffic_grid: tuple[tuple[tuple[float, float], ...], OccupancyGrid] | None = field(
        default=None, repr=False
    )

    def send(self, message: object, delay: int = 1) -> None:
        self.due.append((self.step + delay, message))

    def set_state(self, guid: str, state: ComponentState, event: str) -> None:
        previous = self.states.get(guid, ComponentState.PLANNED)
        self.states[guid] = state
        now = self.step * DT
        message = ComponentStateMsg(
            guid=guid, state=state, previous=previous, event=event, sim_time_s=now, wall_time_s=0.0
        )
        self.history.setdefault(guid, []).append(message)
        if state in self.lose_state:  # the agent applied it (its twin says so), the message never came
            self.lose_state.discard(state)
            return
        self.send(message)

    def laser_grid(self) -> OccupancyGrid:
        """What the laser sees: the robot's own laser grid of the site and the traffic (discs)."""
        grid = self.executor.site_map.laser_grid()
        if not self.traffic_xy_m:
            return grid
        traffic = tuple(self.traffic_xy_m)
        if self._traffic_grid is not None and self._traffic_grid[0] == traffic:
            return self._traffic_grid[1]
        rows, cols = np.indices(grid.shape)
        centres = grid.cell_to_world(np.column_stack([rows.ravel(), cols.ravel()])).reshape(*grid.shape, 2)
        cells = grid.occupied.copy()
        for x, y in self.traffic_xy_m:
            cells |= np.hypot(centres[..., 0] - x, centres[..., 1] - y) <= self.traffic_radius_m
        self._traffic_grid = (traffic, grid.with_occupied(cells))
        return self._traffic_grid[1]

    def run(self, steps: int, until=None) -> None:
        for _ in range(steps):
            laser = self.laser_grid()
            self.step += 1
            now = self.step * DT
            ready = [m for t, m in self.due if t <= self.step]
            self.due = [(t, m) for t, m in self.due if t > self.step]
            for message in ready:
                self.executor.handle(message)
            pose = tuple(float(v) for v in self.pose)
            self.executor.handle(
                OdomMsg(robot_id="r1", pose_xy_yaw=pose, v_mps=0.0, w_radps=0.0, sim_time_s=now)
            )
            ranges = simulate_scan(laser, self.pose, ANGLES, 15.0, step_m=0.05)
            self.executor.handle(
                ScanMsg(
                    robot_id="r1",
                    angle_min_rad=float(ANGLES[0]),
                    angle_increment_rad=float(ANGLES[1] - ANGLES[0]),
                    range_max_m=15.0,
                    ranges_m=ranges.tolist(),
                    sim_time_s=now,
                )
            )
            started = time.perf_counter()
            out = self.executor.tick(
                ClockMsg(sim_time_s=now, step=self.step, real_time_factor=1.0, lock_step=True), now
            )
            self.tick_s.append(time.perf_counter() - started)
            for message in out:
                self.route(message)
            if until is not None and until(self):
                return

    def route(self, message: object) -> None:
        if isinstance(message, CmdVelMsg):
            self.commands.append(message)
            if self.frozen:
                return
            yaw_mid = self.pose[2] + 0.5 * message.w_radps * DT
            self.pose = self.pose + np.array(
                [
                    message.v_mps * DT * math.cos(yaw_mid),
                    message.v_mps * DT * math.sin(yaw_mid),
                    message.w_radps * DT,
                ]
            )
            self.pose[2] = float(wrap_angle(self.pose[2]))
        elif isinstance(message, RobotStateMsg):
            if not self.robot_states or self.robot_states[-1] is not message.state:
                self.robot_states.append(message.state)
        elif isinstance(message, ComponentEventMsg):
            self.events.append(message)
            self.component_event(message)
        elif isinstance(message, PhysicsRequest):
            self.requests.append(message)
            self.request_steps.append(self.step)
            self.physics(message)
        elif isinstance(message, TwinQuestion):
            self.twin_questions.append(message.guid)
            self.send(self.twin(message.guid))

    def twin(self, guid: str) -> TwinMsg:
        """The component's twin as its agent would answer it: its state and the transitions that led there."""
        state = self.states.get(guid, ComponentState.PLANNED)
        return twin_message(self.component(guid), state, self.history.get(guid, []), attempt=1, robot_id="r1")

    def component_event(self, message: ComponentEventMsg) -> None:
        if message.event in self.drop_first:
            self.drop_first.discard(message.event)
            return
        state = self.states.get(message.guid, ComponentState.RELEASED)
        dest = next_state(state, message.event.value)
        if dest is None:
            return
        self.applied.append(message.event)
        self.set_state(message.guid, dest, message.event.value)

    def physics(self, request: PhysicsRequest) -> None:
        message = request.message
        now = self.step * DT
        if isinstance(message, AttachRequest):
            if self.refuse_attach > 0:
                self.refuse_attach -= 1
                reply = PhysicsReply(
                    ok=False, reason="out of reach", sim_time_s=now, distance_m=self.refuse_distance_m
                )
            else:
                self.carried = message.guid
                carried = PoseMsg(position_m=(*self.pose[:2], 0.5), quat_xyzw=(0.0, 0.0, 0.0, 1.0))
                self.send(ComponentPoseMsg(guid=message.guid, pose=carried, sim_time_s=now, attached_to="r1"))
                reply = PhysicsReply(ok=True, sim_time_s=now)
            self.send(PhysicsResult(request.request_id, reply), self.latency)
        elif isinstance(message, DropRequest):
            assert self.carried == message.guid, "only a carried load is dropped"
            self.carried = None
            beside = PoseMsg(
                position_m=(self.pose[0], self.pose[1] + 1.2, 0.1), quat_xyzw=(0.0, 0.0, 0.0, 1.0)
            )
            self.send(ComponentPoseMsg(guid=message.guid, pose=beside, sim_time_s=now))
            self.send(
                PhysicsResult(request.request_id, PhysicsReply(ok=True, sim_time_s=now, pose=beside)), 2
            )
        elif isinstance(message, PlaceRequest) and self.wait_place > 0:
            self.wait_place -= 1
            reply = PhysicsReply(
                ok=False, reason="r2 stands where it goes", sim_time_s=now, wait_s=self.wait_s
            )
            self.send(PhysicsResult(request.request_id, reply), self.latency)
        elif isinstance(message, PlaceRequest):
            placed = ComponentPoseMsg(
                guid=message.guid, pose=message.pose, sim_time_s=now, fixed=True, joined=True
            )
            self.send(placed, 20)  # no dynamics here: fixed for good at once
            self.send(
                PhysicsResult(request.request_id, PhysicsReply(ok=True, sim_time_s=now, pose=message.pose)),
                20,
            )
            target = self.component(message.guid).target_pose_world.position_m
            error = math.dist(message.pose.position_m, target)
            self.pending_verdict = (message.guid, error)

    def component(self, guid: str):
        return next(c for c in self.manifest.components if c.guid == guid)

    def verify(self) -> None:
        """The agent's verdict once it is verifying (called by the tests' ``until``)."""
        guid, error = self.pending_verdict
        if self.states.get(guid) is ComponentState.VERIFYING:
            if error < 0.01:
                self.set_state(guid, ComponentState.CONSTRUCTED, Verdict.VERIFIED.value)
            else:
                self.set_state(guid, ComponentState.MISPLACED, Verdict.MISPLACED.value)


def site_info(manifest: Manifest) -> SiteInfoMsg:
    """What physics tells robot r1 (the default type) of a site planned for one robot, in lock-step."""
    layout = plan_site(manifest.components, robots=1)
    return SiteInfoMsg(
        robot_ids=["r1"],
        robot_starts_xy_yaw=list(layout.robot_starts),
        step_s=1 / 240,
        control_period_s=DT,
        lock_step=True,
        robot_type_of={"r1": DEFAULT_ROBOT.name},
        robot_types={DEFAULT_ROBOT.name: DEFAULT_ROBOT},
        layout=layout,
    )


def make_site(
    manifest: Manifest,
    name: str | None = None,
    start_xy_yaw: tuple[float, float, float] | None = None,
    **config: object,
) -> tuple[FakeSite, ComponentStateMsg, TaskMsg]:
    """A site with one task for r1: the component called ``name`` (default: the first footing); r1 stands
    at ``start_xy_yaw`` (default: its depot start)."""
    info = site_info(manifest)
    layout = info.layout
    assert layout is not None
    config_ = ExecutorConfig(robot_id="r1", **config)  # type: ignore[arg-type]
    executor = Executor(manifest, info, config_, start_xy_yaw=start_xy_yaw)
    site = FakeSite(manifest, executor, np.array(start_xy_yaw or layout.robot_starts[0], float))
    component = next(
        c for c in manifest.components if (c.name == name if name else c.ifc_class == "IfcFooting")
    )
    target = component.target_pose_world
    task = TaskMsg(
        task_id="T0001",
        guid=component.guid,
        component_key=component.key,
        status=TaskStatus.ASSIGNED,
        robot_id="r1",
        target_pose=PoseMsg(position_m=target.position_m, quat_xyzw=target.quat_xyzw),
        sim_time_s=0.0,
        wall_time_s=0.0,
    )
    released = ComponentStateMsg(
        guid=component.guid,
        state=ComponentState.RELEASED,
        previous=ComponentState.PLANNED,
        event="release",
        sim_time_s=0,
        wall_time_s=0,
    )
    site.states[component.guid] = ComponentState.RELEASED
    site.history[component.guid] = [released]
    return site, released, task


def run_task(site: FakeSite, released: ComponentStateMsg, task: TaskMsg, max_steps: int = 3000) -> None:
    site.run(1)  # the robot announces itself idle
    site.executor.handle(released)
    site.executor.handle(task)

    def finished(s: FakeSite) -> bool:
        if getattr(s, "pending_verdict", None) is not None:
            s.verify()
        return bool(s.executor.done) and s.executor.machine.state is RobotState.IDLE

    site.run(max_steps, until=finished)


def construct_named(site: FakeSite, manifest: Manifest, names: Iterable[str]) -> None:
    """The components called ``names`` are constructed (their agents announce it; the robot's question to
    their twins confirms it): the robot's map has them at their targets from now on."""
    wanted = set(names)
    for component in manifest.components:
        if component.name in wanted:
            site.states[component.guid] = ComponentState.CONSTRUCTED
            site.executor.handle(
                ComponentStateMsg(
                    guid=component.guid,
                    state=ComponentState.CONSTRUCTED,
                    event="resume",
                    sim_time_s=site.step * DT,
                    wall_time_s=0.0,
                )
            )
