"""The positioning sensor in physics: with ``total_station_std_m`` every ground robot's sensors message
carries a fix of its true pose each period, with the instrument's noise; without it, none."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest

from bimbot.services.physics.outbox import bundle
from bimbot.services.physics.simulation import SimConfig, Simulation
from bimbot.shared.messages import CmdVelMsg, PositionFixMsg, SensorsMsg


def _sensors(sim: Simulation) -> list[SensorsMsg]:
    return [item.message for item in bundle(sim.advance().messages) if isinstance(item.message, SensorsMsg)]


def test_every_ground_robot_gets_a_fix_of_its_true_pose_each_period(
    make_sim: Callable[..., Simulation],
) -> None:
    sim = make_sim(robots=2, total_station_std_m=0.003)
    for robot_id in sim.robot_ids:
        sim.command(CmdVelMsg(robot_id=robot_id, v_mps=0.5, w_radps=0.2, sim_time_s=sim.sim_time_s))
    offsets, turns = [], []
    for _ in range(40):
        sensors = _sensors(sim)
        assert sorted(s.robot_id for s in sensors) == sorted(sim.robot_ids)
        for message in sensors:
            fix = message.fix
            assert isinstance(fix, PositionFixMsg) and fix.std_m == 0.003
            x, y, yaw = sim.robot_pose(message.robot_id)
            offsets.append((fix.position_xy_m[0] - x, fix.position_xy_m[1] - y))
            turns.append(math.remainder(fix.yaw_rad - yaw, 2 * math.pi))
            assert fix.yaw_std_rad == pytest.approx(math.sqrt(2) * 0.003 / 0.99)  # two prisms a Husky apart
    spread = np.std(np.array(offsets), axis=0)
    assert np.all((spread > 0.002) & (spread < 0.004))  # the instrument's noise, no more, no less
    assert abs(np.mean(offsets)) < 0.001 and np.std(turns) < 0.008


def test_without_a_positioning_sensor_no_fix_is_sent(make_sim: Callable[..., Simulation]) -> None:
    sim = make_sim(robots=1)
    assert all(message.fix is None for message in _sensors(sim))


def test_a_total_station_needs_a_positive_standard_deviation() -> None:
    with pytest.raises(ValueError, match="standard deviation"):
        SimConfig(total_station_std_m=0.0).validate()
