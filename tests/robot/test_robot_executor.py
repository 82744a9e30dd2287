"""The executor through whole tasks with fake physics and fake component states: the protocol's event order,
the paper's state order, a command for every clock step, at-least-once events, refusals, withdrawals."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import pytest
from robot_sim import convert_small_frame

from bimbot.services.component_agents.state_table import next_state
from bimbot.services.robot.executor import Executor, ExecutorConfig
from bimbot.services.robot.particle_filter import simulate_scan, wrap_angle
from bimbot.services.robot.protocol import EventQueue, PhysicsRequest, PhysicsResult, injected
from bimbot.services.robot.task_machine import PAPER_ORDER
from bimbot.shared.manifest import Manifest, read_manifest
from bimbot.shared.messages import (
    AttachRequest,
    ClockMsg,
    CmdVelMsg,
    ComponentEvent,
    ComponentEventMsg,
    ComponentPoseMsg,
    ComponentState,
    ComponentStateMsg,
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
)
from bimbot.shared.robot_description import DEFAULT_ROBOT
from bimbot.shared.site_layout import plan_site

ANGLES = np.linspace(-math.pi, math.pi, 120, endpoint=False)
DT = 0.1


@pytest.fixture(scope="module")
def frame(tmp_path_factory: pytest.TempPathFactory) -> Manifest:
    return read_manifest(convert_small_frame(tmp_path_factory.mktemp("frame")))


@dataclass
class FakeSite:
    """One robot on an ideal base; fake physics (replies ``latency`` steps late) and fake components that
    follow the agents' state table and judge every placement by its distance to the target."""

    manifest: Manifest
    executor: Executor
    pose: np.ndarray
    latency: int = 3
    drop_first: set[ComponentEvent] = field(default_factory=set)  # the agent misses the first delivery
    refuse_attach: int = 0  # physics refuses this many attach requests
    step: int = 0
    states: dict[str, ComponentState] = field(default_factory=dict)
    events: list[ComponentEventMsg] = field(default_factory=list)
    applied: list[ComponentEvent] = field(default_factory=list)
    robot_states: list[RobotState] = field(default_factory=list)
    commands: list[CmdVelMsg] = field(default_factory=list)
    requests: list[PhysicsRequest] = field(default_factory=list)
    due: list[tuple[int, object]] = field(default_factory=list)
    carried: str | None = None
    tick_s: list[float] = field(default_factory=list)

    def send(self, message: object, delay: int = 1) -> None:
        self.due.append((self.step + delay, message))

    def set_state(self, guid: str, state: ComponentState, event: str) -> None:
        self.states[guid] = state
        self.send(
            ComponentStateMsg(guid=guid, state=state, event=event, sim_time_s=self.step * DT, wall_time_s=0.0)
        )

    def run(self, steps: int, until=None) -> None:
        laser = self.executor.site_map.laser_grid()
        for _ in range(steps):
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
            self.physics(message)

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
                reply = PhysicsReply(ok=False, reason="out of reach", sim_time_s=now)
            else:
                self.carried = message.guid
                carried = PoseMsg(position_m=(*self.pose[:2], 0.5), quat_xyzw=(0.0, 0.0, 0.0, 1.0))
                self.send(ComponentPoseMsg(guid=message.guid, pose=carried, sim_time_s=now, attached_to="r1"))
                reply = PhysicsReply(ok=True, sim_time_s=now)
            self.send(PhysicsResult(request.request_id, reply), self.latency)
        elif isinstance(message, PlaceRequest):
            self.send(ComponentPoseMsg(guid=message.guid, pose=message.pose, sim_time_s=now, fixed=True), 20)
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
            self.set_state(
                guid, ComponentState.CONSTRUCTED if error < 0.01 else ComponentState.MISPLACED, "verified"
            )


def make_site(frame: Manifest, **config: object) -> tuple[FakeSite, ComponentStateMsg, TaskMsg]:
    layout = plan_site(frame.components, robots=1)
    info = SiteInfoMsg(
        robot_ids=["r1"],
        robot_starts_xy_yaw=list(layout.robot_starts),
        step_s=1 / 240,
        control_period_s=DT,
        lock_step=True,
        robot_type_of={"r1": DEFAULT_ROBOT.name},
        robot_types={DEFAULT_ROBOT.name: DEFAULT_ROBOT},
    )
    executor = Executor(frame, info, ExecutorConfig(robot_id="r1", **config))  # type: ignore[arg-type]
    site = FakeSite(frame, executor, np.array(layout.robot_starts[0], float))
    footing = next(c for c in frame.components if c.ifc_class == "IfcFooting")
    target = footing.target_pose_world
    task = TaskMsg(
        task_id="T0001",
        guid=footing.guid,
        component_key=footing.key,
        status=TaskStatus.ASSIGNED,
        robot_id="r1",
        target_pose=PoseMsg(position_m=target.position_m, quat_xyzw=target.quat_xyzw),
        sim_time_s=0.0,
        wall_time_s=0.0,
    )
    released = ComponentStateMsg(
        guid=footing.guid, state=ComponentState.RELEASED, event="release", sim_time_s=0, wall_time_s=0
    )
    site.states[footing.guid] = ComponentState.RELEASED
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


def test_one_task_runs_the_protocol_in_order_and_answers_every_clock_step(frame: Manifest) -> None:
    site, released, task = make_site(frame)
    run_task(site, released, task)
    assert site.executor.done == [(task.guid, ComponentState.CONSTRUCTED)]
    assert site.applied == [
        ComponentEvent.PICK,
        ComponentEvent.ATTACH,
        ComponentEvent.ARRIVE,
        ComponentEvent.PLACE,
    ]
    assert tuple(site.robot_states) == PAPER_ORDER
    assert [c.step for c in site.commands] == list(range(1, site.step + 1)), "one cmd_vel per clock step"
    last = site.executor.tick(
        ClockMsg(sim_time_s=site.step * DT, step=site.step + 1, real_time_factor=1.0), 0.0
    )
    assert isinstance(last[-1], CmdVelMsg) and last[-1].step == site.step + 1, "the command comes last"
    assert all(c.v_mps == 0.0 and c.w_radps == 0.0 for c in site.commands[-5:])
    kinds = [r.kind for r in site.requests]
    assert kinds == ["attach", "place"]
    place = site.requests[-1].message
    assert isinstance(place, PlaceRequest)
    np.testing.assert_allclose(place.pose.position_m, task.target_pose.position_m)
    assert max(site.tick_s) < 0.5 and float(np.median(site.tick_s)) < 0.02, "a tick never waits on anything"


def test_events_are_repeated_with_the_same_id_until_the_component_applies_them(frame: Manifest) -> None:
    site, released, task = make_site(frame, resend_s=0.3)
    site.drop_first = {ComponentEvent.PICK, ComponentEvent.ARRIVE}
    run_task(site, released, task)
    picks = [e for e in site.events if e.event is ComponentEvent.PICK]
    assert len(picks) >= 2 and len({e.event_id for e in picks}) == 1
    assert site.applied == [
        ComponentEvent.PICK,
        ComponentEvent.ATTACH,
        ComponentEvent.ARRIVE,
        ComponentEvent.PLACE,
    ]


def test_a_refused_attach_sends_the_robot_to_another_approach_and_tries_again(frame: Manifest) -> None:
    site, released, task = make_site(frame)
    site.refuse_attach = 1
    run_task(site, released, task)
    assert [r.kind for r in site.requests] == ["attach", "attach", "place"]
    assert site.executor.done == [(task.guid, ComponentState.CONSTRUCTED)]


def test_too_many_refusals_give_the_task_up_with_abandon(frame: Manifest) -> None:
    site, released, task = make_site(frame, max_tries=2)
    site.refuse_attach = 10
    site.executor.handle(released)
    site.executor.handle(task)
    site.run(3000, until=lambda s: s.executor.machine.state is RobotState.IDLE and s.step > 5)
    assert site.applied == [ComponentEvent.PICK, ComponentEvent.ABANDON]
    assert site.states[task.guid] is ComponentState.RELEASED
    assert site.executor.task is None


def test_an_injected_error_offsets_only_the_first_attempt(frame: Manifest) -> None:
    site, released, task = make_site(frame, placement_error_m=0.05)
    run_task(site, released, task)
    assert site.executor.done == [(task.guid, ComponentState.MISPLACED)]
    place = site.requests[-1].message
    assert place.pose.position_m[0] == pytest.approx(task.target_pose.position_m[0] + 0.05)
    spec = {"error_m": 0.05, "fraction": 0.0, "seed": 0}
    assert not injected(task.guid, 1, guids=frozenset(), **spec)
    assert injected(task.guid, 0, guids=frozenset({task.guid}), **spec)
    assert not injected(task.guid, 0, guids=frozenset({"other"}), **spec)
    share = np.mean(
        [injected(f"g{i}", 0, error_m=0.05, guids=frozenset(), fraction=0.3, seed=1) for i in range(1000)]
    )
    assert 0.25 < share < 0.35


def test_a_task_given_to_another_robot_is_dropped(frame: Manifest) -> None:
    site, released, task = make_site(frame)
    site.executor.handle(released)
    site.executor.handle(task)
    site.run(30)
    assert site.executor.machine.state is RobotState.PICK_UP
    site.executor.handle(task.model_copy(update={"robot_id": "r2"}))
    site.run(2)
    assert site.executor.machine.state is RobotState.IDLE and site.executor.task is None


def test_an_assignment_waits_for_the_components_release(frame: Manifest) -> None:
    site, released, task = make_site(frame)
    planned = released.model_copy(update={"state": ComponentState.PLANNED})
    site.executor.handle(planned)
    site.executor.handle(task)
    site.run(5)
    assert site.executor.machine.state is RobotState.IDLE
    site.executor.handle(released)
    site.run(2)
    assert site.executor.machine.state is not RobotState.IDLE


def test_event_queue_sends_the_oldest_unconfirmed_event_only() -> None:
    queue = EventQueue(resend_s=1.0)
    make = lambda event: ComponentEventMsg(  # noqa: E731
        guid="g", event=event, source="r1", event_id=event.value, sim_time_s=0, wall_time_s=0
    )
    queue.push(make(ComponentEvent.PICK))
    queue.push(make(ComponentEvent.ATTACH))
    assert queue.due(0.0).event is ComponentEvent.PICK
    assert queue.due(0.5) is None and queue.due(1.0).event is ComponentEvent.PICK
    queue.confirm(ComponentState.PICKING)
    assert queue.due(1.1).event is ComponentEvent.ATTACH, "the next goes out at once"
    queue.confirm(ComponentState.CONSTRUCTED)
    assert not queue and queue.queued == {ComponentEvent.PICK, ComponentEvent.ATTACH}


def test_a_task_given_back_and_assigned_again_is_taken_again(frame: Manifest) -> None:
    site, released, task = make_site(frame, max_tries=2)
    site.refuse_attach = 2
    site.executor.handle(released)
    site.executor.handle(task)
    site.run(3000, until=lambda s: ComponentEvent.ABANDON in s.applied and s.executor.task is None)
    assert site.states[task.guid] is ComponentState.RELEASED
    site.executor.handle(task)  # a late repeat of the old assignment: not a new one
    site.run(3)
    assert site.executor.task is None
    site.executor.handle(task.model_copy(update={"wall_time_s": 5.0}))  # the planner assigns it again
    site.run(3)
    assert site.executor.task is not None and site.executor.machine.state is RobotState.PICK_UP
