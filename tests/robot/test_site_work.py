"""The executor of a machine that builds in place: a pump's crew forms and pours, a block layer lays course by
course, both by the sim clock, through the construction protocol; the agents' state table answers events."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from twins import twin_message

from bimbot.services.robot.executor import executor_class
from bimbot.services.robot.protocol import PhysicsRequest, PhysicsResult
from bimbot.services.robot.site_work import SiteWorkExecutor, work_steps
from bimbot.services.robot.task_state import ExecutorConfig
from bimbot.shared.component_states import TwinQuestion
from bimbot.shared.construction_methods import CastWork, ConstructionMethod
from bimbot.shared.manifest import Component, Manifest, read_manifest
from bimbot.shared.messages import (
    BuildRequest,
    ClockMsg,
    ComponentEvent,
    ComponentEventMsg,
    ComponentState,
    ComponentStateMsg,
    PhysicsReply,
    PoseMsg,
    RobotState,
    RobotStateMsg,
    SiteInfoMsg,
    TaskMsg,
    TaskStatus,
)
from bimbot.shared.robot_description import Capability, LayingSpec, PilingSpec, RobotDescription
from bimbot.shared.site_layout import plan_site
from bimbot.shared.state_table import Verdict, next_state

PERIOD_S = 1.0


@pytest.fixture(scope="module")
def frame_manifest(bundled_build: Path) -> Manifest:
    return read_manifest(bundled_build)


PUMP = RobotDescription(
    name="pump",
    urdf="carrier.urdf",
    payload_kg=1.0,
    reach_m=60.0,
    max_place_height_m=30.0,
    length_m=1.4,
    width_m=0.9,
    max_speed_mps=0.0,
    max_turn_radps=0.0,
    capabilities=frozenset({Capability.STAND_FIXED, Capability.POUR}),
)
LAYER = PUMP.model_copy(
    update={
        "name": "layer",
        "capabilities": frozenset({Capability.STAND_FIXED, Capability.LAY}),
        "laying": LayingSpec(
            block_length_m=0.6, block_height_m=0.3, block_width_m=0.4, block_mass_kg=45.0, blocks_per_h=300.0
        ),
    }
)

RIG = PUMP.model_copy(
    update={
        "name": "rig",
        "capabilities": frozenset({Capability.STAND_FIXED, Capability.PILE}),
        "piling": PilingSpec(pitch_s=300.0, penetration_m_per_h=60.0),
    }
)


def _site(frame_manifest: Manifest, description: RobotDescription, method: ConstructionMethod) -> tuple:
    footing = next(c for c in frame_manifest.components if c.ifc_class == "IfcFooting")
    cast = CastWork(formwork_area_m2=4.0, volume_m3=1.0, formwork_s=600.0, pour_s=120.0, cure_s=3600.0)
    component = footing.model_copy(update={"method": method, "cast": cast})
    manifest = frame_manifest.model_copy(update={"components": [component]})
    layout = plan_site(manifest.components, fleet=[description])
    info = SiteInfoMsg(
        robot_ids=["r1"],
        robot_starts_xy_yaw=layout.robot_starts,
        robot_type_of={"r1": description.name},
        robot_types={description.name: description},
        step_s=PERIOD_S / 10,
        control_period_s=PERIOD_S,
        lock_step=True,
        layout=layout,
    )
    return manifest, info, component


class FakeAgentAndPhysics:
    """The component's agent (the shared state table) and physics' build request, answered at once."""

    def __init__(self, executor: SiteWorkExecutor, component: Component) -> None:
        self.executor, self.component = executor, component
        self.state = ComponentState.RELEASED
        self.events: list[tuple[float, ComponentEvent]] = []
        self.builds: list[tuple[float, float]] = []  # (sim s, height fraction)
        self.robot_states: list[RobotStateMsg] = []
        self.history: list[ComponentStateMsg] = []
        self.step = 0
        self.now_s = 0.0
        self.hold: ComponentEvent | None = None  # an event left unanswered until release_held
        self.held: tuple[float, ComponentEventMsg] | None = None

    def assign(self) -> None:
        """The planner's release (heard by the robot, as on the bus), then its task for r1."""
        self.state = ComponentState.PLANNED
        self._publish(ComponentState.RELEASED, ComponentEvent.RELEASE.value)
        target = self.component.target_pose_world
        self.executor.handle(
            TaskMsg(
                task_id="T1",
                guid=self.component.guid,
                component_key=self.component.key,
                status=TaskStatus.ASSIGNED,
                robot_id="r1",
                target_pose=PoseMsg(position_m=target.position_m, quat_xyzw=target.quat_xyzw),
                sim_time_s=0.0,
                wall_time_s=1.0,
                method=self.component.method,
            )
        )

    def run(self, seconds: float) -> None:
        for _ in range(round(seconds / PERIOD_S)):
            self.jump_to(self.now_s + PERIOD_S)

    def jump_to(self, now: float) -> None:
        """One clock step, to ``now`` (a period on, or a skip over a quiet site)."""
        self.step, self.now_s = self.step + 1, now
        clock = ClockMsg(sim_time_s=now, step=self.step, real_time_factor=0.0, lock_step=True)
        for message in self.executor.tick(clock, wall_s=1000.0 + now):
            self._take(message, now)

    def release_held(self) -> None:
        assert self.held is not None
        (_, message), self.held, self.hold = self.held, None, None
        self._take(message, self.now_s)

    def _take(self, message: object, now: float) -> None:
        if isinstance(message, RobotStateMsg):
            self.robot_states.append(message)
        elif isinstance(message, ComponentEventMsg) and message.event is self.hold:
            if self.held is None:
                self.held = (now, message)
        elif isinstance(message, ComponentEventMsg):
            after = next_state(self.state, message.event.value)
            if after is None:
                return
            self.events.append((now, message.event))
            self._publish(after, message.event.value)
            if message.event is ComponentEvent.PLACE:
                self._publish(ComponentState.CONSTRUCTED, Verdict.VERIFIED.value)
        elif isinstance(message, TwinQuestion):  # a terminal claim is asked of the twin: the truth
            self.executor.handle(
                twin_message(self.component, self.state, self.history, attempt=1, robot_id="r1")
            )
        elif isinstance(message, PhysicsRequest):
            assert isinstance(message.message, BuildRequest)
            self.builds.append((now, message.message.height_fraction))
            reply = PhysicsReply(ok=True, sim_time_s=now)
            self.executor.handle(PhysicsResult(message.request_id, reply))

    def _publish(self, state: ComponentState, event: str) -> None:
        previous, self.state = self.state, state
        record = ComponentStateMsg(
            guid=self.component.guid,
            state=state,
            previous=previous,
            event=event,
            sim_time_s=self.now_s,
            wall_time_s=1000.0,
        )
        self.history.append(record)
        self.executor.handle(record)


def test_a_pump_is_given_the_executor_of_work_in_place(frame_manifest: Manifest) -> None:
    _, info, _ = _site(frame_manifest, PUMP, ConstructionMethod.CAST_IN_PLACE)
    assert executor_class(info, "r1") is SiteWorkExecutor


def test_a_crew_forms_then_pours_for_the_times_of_its_cast_work_then_it_stands(
    frame_manifest: Manifest,
) -> None:
    manifest, info, component = _site(frame_manifest, PUMP, ConstructionMethod.CAST_IN_PLACE)
    executor = SiteWorkExecutor(manifest, info, ExecutorConfig(robot_id="r1"))
    site = FakeAgentAndPhysics(executor, component)
    site.assign()
    site.run(1000.0)
    events = dict((event, when) for when, event in site.events)
    assert list(events) == [ComponentEvent.FORM, ComponentEvent.POUR, ComponentEvent.PLACE]
    # formwork 600 s, then the pour 120 s, within a control period or two of each
    assert events[ComponentEvent.POUR] - events[ComponentEvent.FORM] == pytest.approx(600.0, abs=3 * PERIOD_S)
    assert site.builds and site.builds[0][1] == 1.0
    assert site.builds[0][0] - events[ComponentEvent.POUR] == pytest.approx(120.0, abs=3 * PERIOD_S)
    assert site.state is ComponentState.CONSTRUCTED
    assert executor.done == [(component.guid, ComponentState.CONSTRUCTED)]
    assert executor.state is RobotState.IDLE
    busy = [m.busy_until_s for m in site.robot_states if m.busy_until_s is not None]
    assert busy and max(busy) == pytest.approx(events[ComponentEvent.POUR] + 120.0, abs=PERIOD_S)


def test_a_block_layer_raises_the_wall_course_by_course_at_its_rate(frame_manifest: Manifest) -> None:
    manifest, info, component = _site(frame_manifest, LAYER, ConstructionMethod.LAID)
    steps = work_steps(component, LAYER)
    height = component.bbox_world.max_m[2] - component.bbox_world.min_m[2]
    assert len(steps) == math.ceil(height / 0.3 - 1e-6)
    executor = SiteWorkExecutor(manifest, info, ExecutorConfig(robot_id="r1"))
    site = FakeAgentAndPhysics(executor, component)
    site.assign()
    total_s = sum(step.duration_s for step in steps)
    site.run(total_s + 60.0)
    fractions = [fraction for _, fraction in site.builds]
    assert fractions == pytest.approx([(i + 1) / len(steps) for i in range(len(steps))])
    assert site.builds[-1][0] - site.events[0][0] == pytest.approx(total_s, abs=2 * len(steps) * PERIOD_S)
    assert [event for _, event in site.events] == [ComponentEvent.LAY, ComponentEvent.PLACE]
    assert site.state is ComponentState.CONSTRUCTED


def test_a_piling_rig_pitches_and_drives_a_pile_for_its_length_at_its_rate_then_it_stands(
    frame_manifest: Manifest,
) -> None:
    manifest, info, component = _site(frame_manifest, RIG, ConstructionMethod.DRIVEN)
    assert executor_class(info, "r1") is SiteWorkExecutor
    length_m = component.bbox_world.max_m[2] - component.bbox_world.min_m[2]
    (step,) = work_steps(component, RIG)
    assert (step.event, step.height_fraction) == (ComponentEvent.DRIVE, 1.0)
    assert step.duration_s == pytest.approx(300.0 + 3600.0 * length_m / 60.0)
    executor = SiteWorkExecutor(manifest, info, ExecutorConfig(robot_id="r1"))
    site = FakeAgentAndPhysics(executor, component)
    site.assign()
    site.run(step.duration_s + 60.0)
    assert [event for _, event in site.events] == [ComponentEvent.DRIVE, ComponentEvent.PLACE]
    assert site.builds[0][0] - site.events[0][0] == pytest.approx(step.duration_s, abs=3 * PERIOD_S)
    assert site.state is ComponentState.CONSTRUCTED
    assert work_steps(component, PUMP) == []  # a pump drives no pile


def test_a_task_beyond_the_boom_is_given_back_at_once_with_the_numbers(frame_manifest: Manifest) -> None:
    short = PUMP.model_copy(update={"reach_m": 1.0})
    manifest, info, component = _site(frame_manifest, short, ConstructionMethod.CAST_IN_PLACE)
    executor = SiteWorkExecutor(manifest, info, ExecutorConfig(robot_id="r1"))
    site = FakeAgentAndPhysics(executor, component)
    site.assign()
    site.run(5.0)
    assert executor.given_back and "whose boom reaches 1 m" in executor.given_back[0][1].message
    assert [event for _, event in site.events] == [ComponentEvent.FORM, ComponentEvent.ABANDON]
    assert site.state is ComponentState.RELEASED and executor.state is RobotState.IDLE and not site.builds


def test_from_its_assignment_to_its_build_the_crew_always_says_until_when_it_is_busy(
    frame_manifest: Manifest,
) -> None:
    """Before a step's timer starts (its event's answer awaited) the state already says the earliest the
    step can end: a plan-fidelity clock jumping over a quiet site to another machine's end leapt past this
    crew's work, and the planner's watchdog took its footing back (the Duplex: 183 components blocked)."""
    manifest, info, component = _site(frame_manifest, PUMP, ConstructionMethod.CAST_IN_PLACE)
    executor = SiteWorkExecutor(manifest, info, ExecutorConfig(robot_id="r1"))
    site = FakeAgentAndPhysics(executor, component)
    site.assign()
    site.run(1000.0)
    build_s = site.builds[0][0]
    working = [m for m in site.robot_states if m.task_id is not None and m.sim_time_s < build_s]
    assert working and all(m.busy_until_s is not None for m in working)
    pour_s = dict((event, when) for when, event in site.events)[ComponentEvent.POUR]
    assert all(m.busy_until_s <= pour_s + 1e-9 for m in working if m.sim_time_s < pour_s)  # never past it


def test_a_clock_that_jumps_to_the_promised_end_while_the_pour_is_unanswered_ends_the_pour_there(
    frame_manifest: Manifest,
) -> None:
    """The crew says it is busy until the pour's start plus its duration while the pour's event awaits the
    agent's answer; a quiet site's clock jumped there (the Revit house's upper slab: 8,553 s), and the pour's
    timer then started at the answer and ran its 8,553 s again. The pour ends where the state said."""
    manifest, info, component = _site(frame_manifest, PUMP, ConstructionMethod.CAST_IN_PLACE)
    executor = SiteWorkExecutor(manifest, info, ExecutorConfig(robot_id="r1"))
    site = FakeAgentAndPhysics(executor, component)
    site.hold = ComponentEvent.POUR
    site.assign()
    site.run(700.0)  # the formwork's 600 s: the pour's event is sent and held
    assert site.held is not None and not site.builds
    promised = executor.state_message(wall_s=2000.0).busy_until_s
    assert promised == pytest.approx(site.held[0] + 120.0, abs=PERIOD_S)
    site.jump_to(promised)  # nothing else moves: the clock skips to the crew's end
    site.release_held()
    site.run(300.0)
    assert site.builds and site.builds[0][0] <= promised + 2 * PERIOD_S


def test_a_crew_may_sleep_only_while_it_has_no_work_and_none_assigned(frame_manifest: Manifest) -> None:
    manifest, info, component = _site(frame_manifest, PUMP, ConstructionMethod.CAST_IN_PLACE)
    executor = SiteWorkExecutor(manifest, info, ExecutorConfig(robot_id="r1"))
    site = FakeAgentAndPhysics(executor, component)
    site.run(1.0)
    assert executor.can_sleep()  # idle, nothing assigned: nobody needs to wait for its answers
    site.assign()
    assert not executor.can_sleep()  # assigned: it starts at its next tick
    site.run(100.0)
    assert executor.job is not None and not executor.can_sleep()  # forming
    site.run(1000.0)
    assert site.state is ComponentState.CONSTRUCTED and executor.can_sleep()
