"""The plan fidelity's physics (DIRECT pybullet, the bundled frame): a robot's path moves its body by the
timed motion, no scan goes out, and once nothing was heard for a few periods the clock jumps so that a
period ends where the drive does — not before news held it."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from bimbot.services.physics.plan_fidelity import PlanSimulation, simulation_class
from bimbot.services.physics.simulation import SimConfig, Simulation
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import PlanMsg, ScanMsg, SensorsMsg


@pytest.fixture
def sim(bundled_build: Path, frame_manifest: Manifest) -> Iterator[PlanSimulation]:
    config = SimConfig(robots=1, control_period_s=0.2, step_s=1 / 120)
    with PlanSimulation(frame_manifest, bundled_build, config) as simulation:
        yield simulation


def _drive(sim: PlanSimulation, x_m: float) -> PlanMsg:
    x, y, _ = sim.robots["r1"].pose_xy_yaw(sim.client_id)
    return PlanMsg(robot_id="r1", path_xy_m=[(x, y), (x + x_m, y)], goal_xy_m=(x + x_m, y), sim_time_s=0.0)


def test_the_fidelity_names_its_simulation() -> None:
    assert simulation_class("plan") is PlanSimulation
    assert simulation_class("physics") is Simulation
    with pytest.raises(ValueError, match="fidelity"):
        simulation_class("exact")


def test_a_path_moves_the_robot_and_the_clock_jumps_to_its_end(sim: PlanSimulation) -> None:
    speed = sim.robots["r1"].description.max_speed_mps
    start_x = sim.robots["r1"].pose_xy_yaw(sim.client_id)[0]
    sim.hear(_drive(sim, 10.0 * speed))  # ten seconds of driving along +x (it faces +x: no turn)
    result = sim.advance()
    assert not any(isinstance(item.message, ScanMsg | SensorsMsg) for item in result.messages)
    x, _, _ = sim.robots["r1"].pose_xy_yaw(sim.client_id)
    assert x - start_x == pytest.approx(speed * sim.sim_time_s, abs=1e-3)  # where the motion has it
    times = [sim.sim_time_s]
    while sim.sim_time_s < 10.0 - 1e-9:
        sim.advance()
        times.append(sim.sim_time_s)
    assert times[1:4] == pytest.approx([0.4, 0.6, 0.8])  # news (a path) holds the clock for a few periods
    assert sim.jumps == 1 and times[-1] == pytest.approx(10.0)  # then one jump: the period ends at arrival
    x, _, _ = sim.robots["r1"].pose_xy_yaw(sim.client_id)
    assert x - start_x == pytest.approx(10.0 * speed, abs=1e-3)
    assert sim.quiet() is None and sim.next_event_s() is None


def test_a_robot_on_its_way_is_no_quiet_site(sim: PlanSimulation) -> None:
    sim.hear(_drive(sim, 5.0))
    sim.advance()
    assert sim.quiet() == "r1 is driving"
