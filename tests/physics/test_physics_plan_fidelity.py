"""The plan fidelity's physics (DIRECT pybullet, the bundled frame): a robot's path moves its body by the
timed motion, no scan goes out, and once nothing was heard for a few periods the clock jumps so that a
period ends where the drive does — not before news held it. What is heard is taken by the advance after
the step it is stamped with, whenever it came, and the clock never jumps past what a robot says at the
step an event of its fell on, nor past where a skip landed."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from bimbot.services.physics.plan_fidelity import (
    EVENT_WAIT_PERIODS,
    QUIET_PERIODS,
    PlanSimulation,
    simulation_class,
)
from bimbot.services.physics.simulation import SimConfig, Simulation
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import (
    ComponentEvent,
    ComponentEventMsg,
    ComponentState,
    ComponentStateMsg,
    PlanMsg,
    RobotState,
    RobotStateMsg,
    ScanMsg,
    SensorsMsg,
    SkipRequest,
    StepDoneMsg,
)

GUID = "0Component000000000000a"


@pytest.fixture
def sim(bundled_build: Path, frame_manifest: Manifest) -> Iterator[PlanSimulation]:
    config = SimConfig(robots=1, control_period_s=0.2, step_s=1 / 120)
    with PlanSimulation(frame_manifest, bundled_build, config) as simulation:
        yield simulation


def _drive(sim: PlanSimulation, x_m: float) -> PlanMsg:
    x, y, _ = sim.robots["r1"].pose_xy_yaw(sim.client_id)
    path = [(x, y), (x + x_m, y)]
    return PlanMsg(robot_id="r1", path_xy_m=path, goal_xy_m=path[-1], sim_time_s=sim.sim_time_s)


def test_the_fidelity_names_its_simulation() -> None:
    assert simulation_class("plan") is PlanSimulation
    assert simulation_class("physics") is Simulation
    with pytest.raises(ValueError, match="fidelity"):
        simulation_class("exact")


def test_a_path_moves_the_robot_and_the_clock_jumps_to_its_end(sim: PlanSimulation) -> None:
    speed = sim.robots["r1"].description.max_speed_mps
    start_x = sim.robots["r1"].pose_xy_yaw(sim.client_id)[0]
    sim.hear(_drive(sim, 10.0 * speed))  # ten seconds of driving along +x (it faces +x: no turn)
    sim.advance()  # stamped at step 0: taken before advancing from step 1
    assert sim.robots["r1"].pose_xy_yaw(sim.client_id)[0] == pytest.approx(start_x, abs=1e-6)
    result = sim.advance()
    assert not any(isinstance(item.message, ScanMsg | SensorsMsg) for item in result.messages)
    x, _, _ = sim.robots["r1"].pose_xy_yaw(sim.client_id)
    assert x - start_x == pytest.approx(speed * sim.sim_time_s, abs=1e-3)  # where the motion has it
    times = [sim.sim_time_s]
    while sim.sim_time_s < 10.0 - 1e-9:
        sim.advance()
        times.append(sim.sim_time_s)
    assert times[1:4] == pytest.approx([0.6, 0.8, 1.0])  # news (a path) holds the clock for a few periods
    assert sim.jumps == 1 and times[-1] == pytest.approx(10.0)  # then one jump: the period ends at arrival
    x, _, _ = sim.robots["r1"].pose_xy_yaw(sim.client_id)
    assert x - start_x == pytest.approx(10.0 * speed, abs=1e-3)
    assert sim.quiet() is None and sim.next_event_s() is None


def test_a_robot_on_its_way_is_no_quiet_site(sim: PlanSimulation) -> None:
    sim.hear(_drive(sim, 5.0))
    sim.advance()
    sim.advance()
    assert sim.quiet() == "r1 is driving"


def _event(event_id: str) -> ComponentEventMsg:
    return ComponentEventMsg(
        guid=GUID,
        event=ComponentEvent.ARRIVE,
        source="r1",
        event_id=event_id,
        sim_time_s=0.0,
        wall_time_s=0.0,
    )


def test_a_component_event_its_agent_has_not_answered_holds_the_clock(sim: PlanSimulation) -> None:
    """A robot waits for its agent's answer to an event (a crane's arrive, before it lifts). Agents answer
    in wall time, so until a state of that component comes the clock goes period by period, not to the
    next known event (a drive's end far ahead); a late repeat of an answered event holds nothing, and one
    never answered holds the clock ``EVENT_WAIT_PERIODS`` periods at most."""
    sim.hear(_drive(sim, 100.0))  # a known event far ahead: a drive's end
    sim.hear(_event("e1"))
    for _ in range(3 * QUIET_PERIODS):
        sim.advance()
    assert sim.jumps == 0 and sim.sim_time_s == pytest.approx(3 * QUIET_PERIODS * 0.2)  # period by period
    state = ComponentStateMsg(
        guid=GUID, state=ComponentState.ASSEMBLING, event="arrive", sim_time_s=0.0, wall_time_s=0.0
    )
    sim.hear(state)  # answered
    sim.hear(_event("e1"))  # a late repeat
    for _ in range(QUIET_PERIODS + 1):
        sim.advance()
    assert sim.jumps == 1  # the answer is news for a few periods, then the clock jumps to the drive's end
    sim.hear(_drive(sim, 100.0))
    sim.hear(_event("e2"))  # never answered
    periods = 0
    while sim.jumps == 1 and periods < 2 * EVENT_WAIT_PERIODS:
        sim.advance()
        periods += 1
    assert sim.jumps == 2, sim.stepped_for
    assert EVENT_WAIT_PERIODS <= periods <= EVENT_WAIT_PERIODS + 1


def _busy(robot_id: str, until_s: float, stamp_s: float) -> RobotStateMsg:
    return RobotStateMsg(
        robot_id=robot_id,
        state=RobotState.WORK_IN_PLACE,
        pose_xy_yaw=(0.0, 0.0, 0.0),
        sim_time_s=stamp_s,
        wall_time_s=0.0,
        busy_until_s=until_s,
    )


def _times_with_a_reply_heard(sim: PlanSimulation, *, early: bool) -> list[float]:
    """r1 works until 5 s, r9 until 100 s; at the step the clock reaches 5 s r1 says it works on until
    50 s, heard before physics advances from that step (``early``) or after it: the step's sim times."""
    sim.hear(_busy("r1", 5.0, 0.0))
    sim.hear(_busy("r9", 100.0, 0.0))
    times: list[float] = []
    while sim.sim_time_s < 5.0 - 1e-9:
        sim.advance()
        times.append(sim.sim_time_s)
    reply = _busy("r1", 50.0, sim.sim_time_s)  # stamped with the step r1 answers
    if early:
        sim.hear(reply)
    sim.advance()
    times.append(sim.sim_time_s)
    if not early:
        sim.hear(reply)
    while sim.sim_time_s < 100.0 - 1e-9:
        sim.advance()
        times.append(sim.sim_time_s)
    return times


def test_a_reply_heard_at_its_own_step_or_after_it_gives_the_same_clock(
    sim: PlanSimulation, bundled_build: Path, frame_manifest: Manifest
) -> None:
    """In lock-step, what a robot says at step k may come before physics advances from k or after it (it
    need only come before k + 1): the clock must not depend on which. Its work ends where the clock jumped
    to: it says so at that step, so the clock goes on period by period there, then to r1's new end (50 s),
    not past it to r9's (100 s)."""
    config = SimConfig(robots=1, control_period_s=0.2, step_s=1 / 120)
    with PlanSimulation(frame_manifest, bundled_build, config) as other:
        late = _times_with_a_reply_heard(other, early=False)
    early = _times_with_a_reply_heard(sim, early=True)
    assert early == late
    assert any(time == pytest.approx(50.0) for time in early)  # a period ended where r1's new work did
    landed = next(index for index, time in enumerate(early) if time >= 5.0 - 1e-9)
    assert early[landed + 1] == pytest.approx(early[landed] + 0.2)  # no jump from where r1 answers


def test_the_clock_does_not_jump_from_where_a_skip_landed(sim: PlanSimulation) -> None:
    """The planner skips to a time physics knows no event at (a curing's end: the planner releases what
    waited for it there); what it says at the first step there is heard one step later, so the clock goes
    period by period until then, however quiet the site is, and only then to the next known event."""
    sim.hear(_busy("r8", 10.0, 0.0))
    sim.hear(_busy("r9", 1000.0, 0.0))
    while sim.sim_time_s < 10.0 - 1e-9:  # nothing else heard: the clock jumps to r8's end
        sim.advance()
    sim.advance()  # from where r8's work ended: period by period (what r8 says there comes next)
    assert sim.sim_time_s == pytest.approx(10.2)
    reply = sim.skip(SkipRequest(to_sim_s=300.0, why="curing", step=sim.step))
    assert reply.ok and sim.sim_time_s == pytest.approx(300.0)
    times = []
    for _ in range(3):
        sim.advance()
        times.append(sim.sim_time_s)
    assert times == pytest.approx([300.2, 300.4, 1000.0])


def _answer(step: int, stamp_s: float, next_event_s: float | None, *, done: bool = False) -> StepDoneMsg:
    return StepDoneMsg(
        participant="planner", step=step, sim_time_s=stamp_s, next_event_s=next_event_s, done=done
    )


def test_the_clock_stops_where_the_planner_said_it_acts_next_not_at_a_robot_s_later_end(
    sim: PlanSimulation,
) -> None:
    """r9 works until 1000 s; the planner holds a task until a curing ends at 300 s, which it says in its
    answer to each step: the clock jumps so that a period ends there (the planner releases the task at that
    step), not on to 1000 s. An answer said again for an older step changes nothing, and a done planner
    holds the clock nowhere."""
    sim.hear(_busy("r9", 1000.0, 0.0))
    sim.hear(_answer(0, 0.0, 300.0))
    before = (0, 0.0)
    while sim.sim_time_s < 300.0 - 1e-9:
        before = (sim.step, sim.sim_time_s)
        sim.advance()
    assert sim.sim_time_s == pytest.approx(300.0) and sim.jumps == 1
    assert sim.next_event_s() == pytest.approx(1000.0)  # 300 s has passed: it holds nothing ahead
    sim.hear(_answer(sim.step, sim.sim_time_s, 600.0))  # at 300 s: the next curing ends at 600 s
    sim.hear(_busy("r8", 700.0, sim.sim_time_s))  # news: r8 works until 700 s
    sim.advance()
    sim.advance()  # both taken: the news holds the clock a few periods
    sim.hear(_answer(*before, 450.0))  # the answer to the step before the jump, said again (a repeat)
    times = []
    while sim.sim_time_s < 600.0 - 1e-9:
        sim.advance()
        times.append(sim.sim_time_s)
    assert sim.sim_time_s == pytest.approx(600.0)
    assert not any(450.0 - 1e-6 <= time < 450.2 for time in times)
    sim.hear(_answer(sim.step, sim.sim_time_s, 900.0, done=True))
    while sim.sim_time_s < 1000.0 - 1e-9:
        sim.advance()
        times.append(sim.sim_time_s)
    assert sim.sim_time_s == pytest.approx(1000.0)
    assert not any(900.0 - 1e-6 <= time < 900.2 for time in times)


def test_the_build_is_over_once_the_planner_is_done_and_nothing_is_ahead(sim: PlanSimulation) -> None:
    """A site that waits for nothing is no finished build while the planner works (it may still release a
    task) nor when an agents shard stops answering; once the planner said it is done, the build is over at
    the first step where nothing is heard, settling or ahead: after a robot's timed work, not before."""
    for _ in range(2 * QUIET_PERIODS):
        sim.advance()
    assert sim.stepped_for.get("no event", 0) > 0 and sim.over_at is None
    sim.hear(StepDoneMsg(participant="agents-1of1", step=sim.step, sim_time_s=sim.sim_time_s, done=True))
    for _ in range(2 * QUIET_PERIODS):
        sim.advance()
    assert sim.over_at is None
    work_end_s = sim.sim_time_s + 20.0
    sim.hear(_busy("r9", work_end_s, sim.sim_time_s))
    sim.hear(_answer(sim.step, sim.sim_time_s, None, done=True))
    while sim.over_at is None and sim.step < 200:
        sim.advance()
    assert sim.over_at == sim.step - 1 and sim.sim_time_s > work_end_s
