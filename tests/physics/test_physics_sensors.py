"""The laser: one scan per robot per period that sees the fence, yard items and other robots' loads at the
right ranges, never the ground, its own body or its own load."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest
from physics_builders import drive, idle, west_of

from bimbot.services.physics import sensors
from bimbot.services.physics.client import p
from bimbot.services.physics.scene import ALL_GROUPS, GROUND_GROUP
from bimbot.services.physics.sensors import NEAR_SEGMENT_M, LaserConfig
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


def _single_segment_ranges(sim: Simulation, robot_id: str) -> np.ndarray:
    """The scan as one ray per beam over the whole range (what the two segments must agree with)."""
    robot, laser = sim.robots[robot_id], sim._laser
    mount = laser.mount(robot.frame(sim.client_id), robot.base_height_m)
    origin = np.asarray(mount[0])
    rotation = np.asarray(p.getMatrixFromQuaternion(mount[1])).reshape(3, 3)
    directions = laser._directions @ rotation.T
    begin = sim._beam_starts[robot_id]
    limit = laser.config.range_max_m
    hits = p.rayTestBatch(
        (origin + directions * begin[:, None]).tolist(),
        (origin + directions * limit).tolist(),
        collisionFilterMask=ALL_GROUPS ^ GROUND_GROUP ^ robot.group,
        physicsClientId=sim.client_id,
    )
    fractions = np.array([hit[2] if hit[0] >= 0 else 1.0 for hit in hits])
    return np.round(begin + fractions * (limit - begin), 3)


def test_near_then_far_segments_give_the_single_ray_ranges(make_sim: Callable[..., Simulation]) -> None:
    sim = make_sim(robots=1)
    slots = [slot.footprint for slot in sim.layout.slots.values()]
    low = np.min([spot.min_xy for spot in slots], axis=0) - 2.0
    high = np.max([spot.max_xy for spot in slots], axis=0) + 2.0
    rng = np.random.default_rng(7)
    beams = differing = 0
    for _ in range(12):  # in and around the yard: items near and far, beams that go on past 4 m
        sim.teleport_robot("r1", (*rng.uniform(low, high), float(rng.uniform(-math.pi, math.pi))))
        robot = sim.robots["r1"]
        mount = sim._laser.mount(robot.frame(sim.client_id), robot.base_height_m)
        scan = np.array(sim._laser.scan(sim.client_id, mount, robot.group, sim._beam_starts["r1"]))
        reference = _single_segment_ranges(sim, "r1")
        beams += len(scan)
        differing += int(np.count_nonzero(np.abs(scan - reference) > 0.0015))
        assert np.abs(scan - reference).max() < 0.02  # Bullet's convex cast: rare mm outliers either way
        assert np.any((scan > NEAR_SEGMENT_M) & (scan < sim._laser.config.range_max_m))  # far hits too
    assert differing <= 0.01 * beams


def test_a_surface_at_the_end_of_the_near_segment_is_seen_where_it_is(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest, monkeypatch: pytest.MonkeyPatch
) -> None:
    # A footing lying in the yard 1.5 m ahead, with the near segment ending just short of its face, just
    # past it or inside it: the far segment starts before the near one ends (a ray starting inside the
    # footing would not see it, one starting within its hull margin would report its own start).
    sim = make_sim(robots=1, compiled_laser=False)  # Bullet's casts, in two segments
    footing = next(c for c in frame_manifest.components if c.ifc_class == "IfcFooting")
    spot = sim.layout.slots[footing.guid].footprint
    sim.teleport_robot("r1", ((spot.min_xy[0] + spot.max_xy[0]) / 2.0, spot.min_xy[1] - 1.5, math.pi / 2))
    ahead = _beam(_scan(sim, "r1"), 0.0)
    assert ahead == pytest.approx(1.5, abs=0.01)
    for near_end_m in (ahead - 0.0005, ahead + 0.0005, ahead + 0.1):
        monkeypatch.setattr(sensors, "NEAR_SEGMENT_M", near_end_m)
        assert _beam(_scan(sim, "r1"), 0.0) == pytest.approx(ahead, abs=0.003)  # Bullet's cast: ~mm
