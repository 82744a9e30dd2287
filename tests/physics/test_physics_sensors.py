"""The laser: one scan per robot per period that sees the fence, yard items and other robots' loads at the
right ranges, never the ground, its own body or its own load."""

from __future__ import annotations

import math
from collections.abc import Callable

import pytest
from physics_builders import drive, idle, west_of

from bimbot.services.physics.sensors import LaserConfig
from bimbot.services.physics.simulation import Simulation
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import AttachRequest, ScanMsg


def _scan(sim: Simulation, robot_id: str) -> ScanMsg:
    messages = idle(sim, 0.1)[-1].messages
    return next(
        m.message for m in messages if isinstance(m.message, ScanMsg) and m.message.robot_id == robot_id
    )


def _beam(scan: ScanMsg, angle_rad: float) -> float:
    index = round((angle_rad - scan.angle_min_rad) / scan.angle_increment_rad) % len(scan.ranges_m)
    return scan.ranges_m[index]


def test_scan_shape_follows_the_config(make_sim: Callable[..., Simulation]) -> None:
    sim = make_sim(robots=1, laser=LaserConfig(beams=271, fov_rad=math.radians(270), range_max_m=10.0))
    scan = _scan(sim, "r1")
    assert len(scan.ranges_m) == 271 and scan.range_max_m == 10.0
    assert scan.angle_min_rad == pytest.approx(-math.radians(135))
    assert scan.angle_min_rad + 270 * scan.angle_increment_rad == pytest.approx(math.radians(135))
    assert all(0.0 < r <= 10.0 for r in scan.ranges_m)


def test_the_laser_sees_the_fence_at_the_right_range(make_sim: Callable[..., Simulation]) -> None:
    sim = make_sim(robots=1)
    fence = sim.layout.fence
    sim.teleport_robot("r1", (fence.min_xy[0] + 2.5, fence.max_xy[1] - 2.0, 0.0))
    scan = _scan(sim, "r1")
    assert _beam(scan, math.pi / 2) == pytest.approx(2.0, abs=0.01)  # north fence, to the left
    assert _beam(scan, math.pi) == pytest.approx(2.5, abs=0.01)  # west fence, behind
    assert min(scan.ranges_m) > 0.3  # never its own body, never the ground


def test_the_laser_sees_a_yard_item_at_the_right_range(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    sim = make_sim(robots=1)
    footings = [c for c in frame_manifest.components if c.ifc_class == "IfcFooting"]  # solid, 0.3 m high
    southmost = min(footings, key=lambda c: sim.layout.slots[c.guid].footprint.min_xy[1])
    spot = sim.layout.slots[southmost.guid].footprint
    centre_x = (spot.min_xy[0] + spot.max_xy[0]) / 2.0
    sim.teleport_robot("r1", (centre_x, spot.min_xy[1] - 1.5, math.pi / 2))  # in the aisle, facing it
    assert _beam(_scan(sim, "r1"), 0.0) == pytest.approx(1.5, abs=0.01)


def test_a_robot_does_not_see_its_own_load_but_others_do(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    # The laser sits forward, inside the hollow column the robot carries, at the column's height: every
    # forward beam would hit the column's walls within 0.1 m if the robot's own load were not left out.
    laser = LaserConfig(height_m=0.47, mount_x_m=1.2)
    sim = make_sim(robots=2, laser=laser)
    column = next(c for c in frame_manifest.components if c.ifc_class == "IfcColumn")  # a 3 m hollow section
    sim.teleport_robot("r1", west_of(sim.layout.slots[column.guid].footprint, 0.8))
    assert sim.attach(AttachRequest(robot_id="r1", guid=column.guid)).ok
    drive(sim, "r1", 0.0, 0.0, 1.5)  # lifted onto the robot, lying along its x axis
    x = sim.layout.building.min_xy[0] + 3.0
    sim.teleport_robot("r1", (x, sim.layout.building.max_xy[1] + 1.0, 0.0))
    sim.teleport_robot("r2", (x, sim.layout.building.max_xy[1] - 2.0 - 1.2, math.pi / 2))  # laser 3 m from r1
    forward = [_beam(_scan(sim, "r1"), math.radians(a)) for a in range(-60, 61, 5)]
    assert min(forward) > 1.0
    robot = sim.robots["r1"]
    mount = sim._laser.mount(robot.frame(sim.client_id), robot.base_height_m)
    unfiltered = sim._laser.scan(sim.client_id, mount, own_group=0)  # the same scan, nothing left out
    assert min(unfiltered[120:241]) < 0.2  # so the load is there to be seen
    other = _scan(sim, "r2")  # 3 m to the side of r1's column, facing it
    assert _beam(other, 0.0) == pytest.approx(3.0 - 0.05, abs=0.01)  # the column is 0.1 m wide
