"""A clear-away task (kind ``clear``): the robot picks a failed component up where it lies, carries it to its
yard slot and puts it down there, telling the failed component nothing (no event: it stays failed); its
state messages say how the task ended (``cleared``) until its next task, done or given back."""

from __future__ import annotations

import math

import pytest
from fake_site import FakeSite, make_site, site_info
from frames import convert_small_frame

from bimbot.services.robot.executor import ExecutorConfig
from bimbot.services.robot.plan_executor import PlanExecutor
from bimbot.shared.manifest import Manifest, read_manifest
from bimbot.shared.messages import (
    AttachRequest,
    ComponentPoseMsg,
    ComponentState,
    ComponentStateMsg,
    DropRequest,
    PoseMsg,
    RobotState,
    RobotStateMsg,
    TaskKind,
    TaskMsg,
)


@pytest.fixture(scope="module")
def frame(tmp_path_factory: pytest.TempPathFactory) -> Manifest:
    return read_manifest(convert_small_frame(tmp_path_factory.mktemp("frame")))


def _clear_site(frame: Manifest) -> tuple[FakeSite, TaskMsg, tuple[float, float]]:
    """r1 (plan fidelity) and a failed footing lying on the ground 3 m south of its target; its clear
    task, and the centre of its yard slot (where it goes)."""
    site, _released, build = make_site(frame)
    info = site_info(frame)
    layout = info.layout
    assert layout is not None
    site.executor = PlanExecutor(frame, info, ExecutorConfig(robot_id="r1"))
    guid = build.guid
    slot = layout.slots[guid].footprint
    slot_xy = ((slot.min_xy[0] + slot.max_xy[0]) / 2.0, (slot.min_xy[1] + slot.max_xy[1]) / 2.0)
    x, y, z = site.component(guid).target_pose_world.position_m
    fallen = PoseMsg(position_m=(x, y - 3.0, max(z, 0.3)), quat_xyzw=(0.0, 0.0, 0.0, 1.0))
    site.executor.handle(ComponentPoseMsg(guid=guid, pose=fallen, sim_time_s=0.0, fixed=True))
    site.states[guid] = ComponentState.FAILED
    failed = ComponentStateMsg(
        guid=guid, state=ComponentState.FAILED, event="failed_placement", sim_time_s=0.0, wall_time_s=0.0
    )
    site.history[guid] = [failed]
    site.executor.handle(failed)
    task = build.model_copy(update={"task_id": "T0001-c", "kind": TaskKind.CLEAR, "put_down_xy_m": slot_xy})
    return site, task, slot_xy


def _run(site: FakeSite, task: TaskMsg, max_steps: int = 3000) -> list[RobotStateMsg]:
    states: list[RobotStateMsg] = []
    route = site.route

    def routed(message: object) -> None:
        if isinstance(message, RobotStateMsg):
            states.append(message)
        route(message)

    site.route = routed  # type: ignore[method-assign]
    site.run(1)
    site.executor.handle(task)
    site.run(max_steps, until=lambda s: s.executor.cycle.cleared is not None and s.executor.task is None)
    return states


def test_a_clear_task_carries_the_failed_body_to_its_yard_slot_and_says_so(frame: Manifest) -> None:
    site, task, slot_xy = _clear_site(frame)
    states = _run(site, task)
    assert site.events == [], "the failed component hears of no clear-away"
    kinds = [type(request.message) for request in site.requests]
    assert kinds == [AttachRequest, DropRequest]
    drop = site.requests[-1].message
    assert isinstance(drop, DropRequest) and drop.near_xy_m == pytest.approx(slot_xy)
    assert math.dist(site.executor.navigator.pose_xy_yaw[:2], slot_xy) < 6.0, "it drove to the yard slot"
    assert site.executor.machine.state is RobotState.IDLE
    assert site.states[task.guid] is ComponentState.FAILED
    outcome = states[-1].cleared
    assert (
        outcome is not None and outcome.ok and outcome.task_id == task.task_id and outcome.guid == task.guid
    )
    seen = [s.state for s in states if s.task_id == task.task_id]
    assert [a for a, b in zip(seen, [None, *seen], strict=False) if a is not b] == [
        RobotState.DETECT_COMPONENT_POSITION,
        RobotState.PICK_UP,
        RobotState.IDENTIFY_TARGET_LOCATION,
    ]


def test_a_clear_task_given_back_says_why_on_the_robots_state_and_sends_no_abandon(frame: Manifest) -> None:
    site, task, _slot_xy = _clear_site(frame)
    site.refuse_attach = 100  # physics never lets it take the body up
    states = _run(site, task, max_steps=6000)
    assert site.events == [], "no pick, no abandon: the component stays failed"
    outcome = states[-1].cleared
    assert outcome is not None and not outcome.ok
    assert outcome.reason is not None and "attach" in outcome.reason.message
    assert site.executor.machine.state is RobotState.IDLE
