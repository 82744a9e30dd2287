"""The plan fidelity's executor on the fake site: the same task cycle and protocol, its drives a timed A*
path published on its plan key (no velocity commands), arriving when the motion says, placing with no
belief of its own (physics draws the type's precision)."""

from __future__ import annotations

import math

import pytest
from fake_site import DT, make_site, run_task, site_info
from frames import convert_small_frame

from bimbot.services.robot.executor import ExecutorConfig
from bimbot.services.robot.plan_executor import PlanExecutor, plan_executor_class
from bimbot.services.robot.task_machine import PAPER_ORDER
from bimbot.shared.manifest import Manifest, read_manifest
from bimbot.shared.messages import ComponentEvent, ComponentState, PlaceRequest, PlanMsg
from bimbot.shared.robot_description import DEFAULT_ROBOT


@pytest.fixture(scope="module")
def frame(tmp_path_factory: pytest.TempPathFactory) -> Manifest:
    return read_manifest(convert_small_frame(tmp_path_factory.mktemp("frame")))


def test_a_task_runs_the_protocol_along_timed_paths(frame: Manifest) -> None:
    site, released, task = make_site(frame)
    info = site_info(frame)
    layout = info.layout
    assert layout is not None
    assert plan_executor_class(info, "r1") is PlanExecutor
    site.executor = PlanExecutor(frame, info, ExecutorConfig(robot_id="r1"))
    plans: list[PlanMsg] = []
    route = site.route
    site.route = lambda message: plans.append(message) if isinstance(message, PlanMsg) else route(message)  # type: ignore[method-assign]
    run_task(site, released, task)
    assert site.executor.done == [(task.guid, ComponentState.CONSTRUCTED)]
    assert site.applied == [
        ComponentEvent.PICK,
        ComponentEvent.ATTACH,
        ComponentEvent.ARRIVE,
        ComponentEvent.PLACE,
    ]
    assert tuple(site.robot_states) == PAPER_ORDER
    assert all(c.v_mps == 0.0 and c.w_radps == 0.0 for c in site.commands)  # it moves by its paths
    start = layout.robot_starts[0]
    assert plans and plans[0].path_xy_m[0] == pytest.approx(start[:2])
    driven_m = sum(
        math.dist(a, b)
        for plan in plans[:2]
        for a, b in zip(plan.path_xy_m, plan.path_xy_m[1:], strict=False)
    )
    assert site.step * DT >= driven_m / DEFAULT_ROBOT.max_speed_mps  # the drives took their time
    assert site.executor.distance_m == pytest.approx(driven_m, rel=0.05)
    place = site.requests[-1].message
    assert isinstance(place, PlaceRequest) and place.believed_xy_yaw is None


def test_a_kinematic_robot_may_sleep_through_its_drives_and_its_idle_wait_and_not_while_it_talks(
    frame: Manifest,
) -> None:
    """``sleeps_until_s`` (the lock-step loop lets it sleep until then): the end of a drive with its load or
    to it, of its drive out of the structure after the task, or its parking time; never with a request out
    or an event unconfirmed, and never past the end of what it waits for."""
    site, released, task = make_site(frame)
    info = site_info(frame)
    layout = info.layout
    assert layout is not None
    executor = PlanExecutor(frame, info, ExecutorConfig(robot_id="r1"))
    site.executor = executor
    said: list[tuple[float, float | None, bool, bool]] = []  # (sim s, until, with a task, talking)
    tick = executor.tick

    def ticked(clock, wall_s):  # type: ignore[no-untyped-def]
        out = tick(clock, wall_s)
        current = executor.task
        talking = current is not None and (current.request is not None or bool(current.events))
        said.append((clock.sim_time_s, executor.sleeps_until_s(), current is not None, talking))
        return out

    executor.tick = ticked  # type: ignore[method-assign]
    run_task(site, released, task)
    site.run(int(3 * executor.config.park_after_s / DT))
    with_task = [entry for entry in said if entry[2]]
    idle = [entry for entry in said if not entry[2]]
    assert any(until is not None for _, until, _, _ in with_task)  # its drives with and to its load
    assert any(until is not None for _, until, _, _ in idle[2:])  # out of the structure, or parking
    assert all(until is None for _, until, _, talking in said if talking)
    assert all(until is None or until > now for now, until, _, _ in said)
    assert executor.can_sleep()  # parked at its depot at last: asleep until a task message
