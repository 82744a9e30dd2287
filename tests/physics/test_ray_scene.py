"""The laser's compiled caster: exact ranges on known shapes, the same scans as Bullet's ray test in the
bundled frame's scene, Bullet's filtering, and Bullet's own casts wherever the caster cannot stand in."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest
from physics_builders import drive, idle

from bimbot.services.physics.client import BulletClient, p
from bimbot.services.physics.ray_kernel import KIND_CONVEX, KIND_CYLINDER, KIND_SPHERE, cast_fan
from bimbot.services.physics.ray_scene import RayScene, box_primitive, hull_primitive, register_hulls
from bimbot.services.physics.scene import (
    ALL_GROUPS,
    GROUND_GROUP,
    STATIC_GROUP,
    component_pose,
    make_dynamic,
    set_component_pose,
    set_filter,
)
from bimbot.services.physics.sensors import Laser, LaserConfig
from bimbot.services.physics.simulation import Simulation
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import AttachRequest, ScanMsg

FOUR_BEAMS = dict(angle_min=-math.pi, angle_increment=math.pi / 2, full_circle=True)  # -x, -y, +x, +y


Shape = tuple[int, tuple[float, float], np.ndarray, tuple[float, float, float]]


def _cast(shapes: list[Shape], rotations: np.ndarray | None = None, **kw: object) -> np.ndarray:
    """Cast four beams (-x, -y, +x, +y) from the origin at shapes given as (kind, dims, planes, position),
    each turned by ``rotations[i]`` (default: not turned)."""
    n = len(shapes)
    planes = [s[2] for s in shapes]
    first = np.concatenate([[0], np.cumsum([len(pl) for pl in planes])]).astype(np.int64)
    positions = np.array([s[3] for s in shapes], float).reshape(n, 3)
    args = {**FOUR_BEAMS, "starts": np.zeros(4), "range_max": 15.0, **kw}
    return cast_fan(
        np.zeros(3),
        np.eye(3),
        args["angle_min"],
        args["angle_increment"],
        args["full_circle"],
        args["starts"],
        args["range_max"],
        np.array([s[0] for s in shapes], np.int64),
        np.repeat(np.eye(3)[None], n, axis=0) if rotations is None else rotations,
        positions,
        np.array([s[1] for s in shapes], float).reshape(n, 2),
        first,
        np.vstack(planes) if n else np.zeros((0, 4)),
        np.full(n, 3.0),
        np.ones(n, bool),
    )


def _box(position: tuple[float, float, float], half: float = 0.5) -> Shape:
    return (KIND_CONVEX, (0.0, 0.0), box_primitive([half] * 3).planes, position)


def test_exact_ranges_on_a_box_a_cylinder_and_a_sphere() -> None:
    no_planes = np.zeros((0, 4))
    ranges = _cast(
        [
            _box((3.0, 0.0, 0.0)),  # +x: its near face at 2.5 m
            (KIND_CYLINDER, (0.5, 1.0), no_planes, (0.0, 4.0, 0.0)),  # +y: axis along z, mantle at 3.5 m
            (KIND_SPHERE, (0.25, 0.0), no_planes, (-2.0, 0.0, 0.0)),  # -x: 1.75 m
        ]
    )
    assert ranges.tolist() == pytest.approx([1.75, 15.0, 2.5, 3.5], abs=1e-12)


def test_the_closest_shape_wins_and_a_cylinder_is_entered_through_its_cap() -> None:
    assert _cast([_box((6.0, 0.0, 0.0)), _box((4.0, 0.0, 0.0))])[2] == pytest.approx(3.5)
    # a wheel lying with its axis along x (local z turned onto x), 3 m ahead: the +x beam meets its cap
    axis_along_x = np.array([[[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]]])
    wheel = (KIND_CYLINDER, (0.3, 0.1), np.zeros((0, 4)), (3.0, 0.0, 0.0))
    assert _cast([wheel], rotations=axis_along_x).tolist() == pytest.approx([15.0, 15.0, 2.9, 15.0])


def test_a_beam_starting_inside_or_on_a_shape_does_not_see_it() -> None:
    inside = _cast([_box((0.0, 0.0, 0.0), half=1.0)])
    assert inside.tolist() == [15.0] * 4  # as Bullet's ray test: no entry after the start
    on_surface = _cast([_box((2.0, 0.0, 0.0), half=1.0)], starts=np.full(4, 1.0))
    assert on_surface[2] == 15.0
    before = _cast([_box((2.0, 0.0, 0.0), half=1.0)], starts=np.full(4, 0.5))
    assert before[2] == pytest.approx(1.0)


def test_beams_either_side_of_the_fans_seam_see_a_shape_behind_the_robot() -> None:
    # beams at -pi and +pi - step: a box straddling -x must be found by the first beam, whose index wraps
    ranges = _cast([_box((-3.0, 0.0, 0.0))], angle_min=-math.pi, angle_increment=2 * math.pi / 8)
    assert len(ranges) == 4  # four beams over half the circle: -pi, -3pi/4, -pi/2, -pi/4
    assert ranges[0] == pytest.approx(2.5)


def test_a_flat_part_is_as_thick_as_bullets_margin() -> None:
    sheet = hull_primitive(np.array([[2.0, -1.0, -1.0], [2.0, 1.0, -1.0], [2.0, -1.0, 1.0], [2.0, 1.0, 1.0]]))
    assert sheet is not None
    shape = (KIND_CONVEX, (0.0, 0.0), sheet.planes, sheet.position)
    assert _cast([shape])[2] == pytest.approx(2.0 - 0.001)
    assert hull_primitive(np.array([[0.0, 0, 0], [1.0, 0, 0], [2.0, 0, 0]])) is None  # a line: no shape


def _scans(sim: Simulation, robot_id: str, scene: RayScene) -> tuple[np.ndarray, np.ndarray]:
    robot, laser = sim.robots[robot_id], sim._laser
    mount = laser.mount(robot.frame(sim.client_id), robot.base_height_m)
    starts = sim._beam_starts[robot_id]
    bullet = np.array(laser.scan(sim.client_id, mount, robot.group, starts))
    compiled = np.array(laser.scan(sim.client_id, mount, robot.group, starts, scene))
    return bullet, compiled


def test_the_caster_gives_bullets_ranges_in_the_bundled_scene(make_sim: Callable[..., Simulation]) -> None:
    sim = make_sim(robots=3)
    scene = RayScene(sim.client_id)
    fence = sim.layout.fence
    rng = np.random.default_rng(3)
    low, high = np.array(fence.min_xy) + 1.0, np.array(fence.max_xy) - 1.0
    differences: list[np.ndarray] = []
    for _ in range(30):  # every robot somewhere on site: the yard's items, the fence, each other's wheels
        for robot_id in sim.robots:
            sim.teleport_robot(robot_id, (*rng.uniform(low, high), float(rng.uniform(-math.pi, math.pi))))
        scene.refresh()
        assert scene.unsupported is None
        for robot_id in sim.robots:
            bullet, compiled = _scans(sim, robot_id, scene)
            assert np.any(bullet < 15.0)
            differences.append(np.abs(bullet - compiled))
    every = np.concatenate(differences)
    assert np.median(every) == 0.0  # to the millimetre the scans round to
    assert np.mean(every <= 0.002) > 0.995
    # Where they differ by more, a beam grazes an edge Bullet rounds by its 1 mm margin, or starts
    # within that margin of a surface (Bullet then reports a hit at the start): a handful of beams.
    assert np.mean(every > 0.005) < 0.002


def _nearest_ahead(ranges: list[float] | np.ndarray) -> float:
    """The nearest return within 15° of straight ahead (beam 0 points to -x: straight ahead is the middle)."""
    middle, window = len(ranges) // 2, round(len(ranges) * 15 / 360)
    return float(min(ranges[middle - window : middle + window + 1]))


def test_a_scan_in_a_build_is_the_compiled_one_and_sees_what_moved(
    make_sim: Callable[..., Simulation],
) -> None:
    sim = make_sim(robots=2)
    fence = sim.layout.fence
    x, y = fence.min_xy[0] + 3.0, fence.max_xy[1] - 3.0
    sim.teleport_robot("r1", (x, y, 0.0))
    sim.teleport_robot("r2", (x + 3.0, y, 0.0))  # 3 m ahead of r1: its rear wheels face r1's laser

    def ahead_of_r1() -> float:
        scans = [m.message for m in idle(sim, 0.2)[-1].messages if isinstance(m.message, ScanMsg)]
        return _nearest_ahead(next(s for s in scans if s.robot_id == "r1").ranges_m)

    ahead = ahead_of_r1()
    assert sim._ray_scene is not None and sim._ray_scene.unsupported is None
    bullet, compiled = _scans(sim, "r1", sim._ray_scene)
    assert ahead == _nearest_ahead(compiled)  # what the robot got is the compiled scan
    assert 2.0 < ahead < 3.0 and ahead == pytest.approx(_nearest_ahead(bullet), abs=0.005)
    sim.teleport_robot("r2", (x + 5.0, y, 0.0))  # r2 moves on: the next period's scan sees it there
    assert ahead_of_r1() == pytest.approx(ahead + 2.0, abs=0.02)


def _fan(scene: RayScene, mask: int, beams: int = 8) -> np.ndarray | None:
    """``beams`` beams over the full circle from the origin, 10 m long."""
    return scene.cast(
        np.zeros(3),
        np.eye(3),
        angle_min=-math.pi,
        angle_increment=2 * math.pi / beams,
        full_circle=True,
        starts=np.zeros(beams),
        range_max=10.0,
        mask=mask,
    )


def test_a_shape_the_caster_cannot_represent_leaves_the_scan_to_bullet() -> None:
    laser = Laser(LaserConfig(beams=8, range_max_m=10.0))
    with BulletClient() as client:
        cid = client.id
        box = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.5, 0.5, 0.5], physicsClientId=cid)
        body = p.createMultiBody(0.0, box, basePosition=[3.0, 0.0, 0.0], physicsClientId=cid)
        set_filter(cid, body, STATIC_GROUP, ALL_GROUPS)
        scene = RayScene(cid)
        scene.refresh()
        mount = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
        mask = ALL_GROUPS ^ GROUND_GROUP
        compiled = _fan(scene, mask)
        assert compiled is not None and compiled[4] == pytest.approx(2.5)
        unseen = _fan(scene, mask ^ STATIC_GROUP)  # filtered as Bullet filters: by the box's group
        assert unseen is not None and unseen[4] == 10.0
        capsule = p.createCollisionShape(p.GEOM_CAPSULE, radius=0.3, height=1.0, physicsClientId=cid)
        p.createMultiBody(0.0, capsule, basePosition=[0.0, 2.0, 0.0], physicsClientId=cid)
        scene.refresh()  # a body more: the scene is built again, and cannot hold a capsule
        assert scene.unsupported is not None and "geometry type" in scene.unsupported
        assert _fan(scene, mask) is None
        ranges = laser.scan(cid, mount, 0, np.zeros(8), scene)  # Bullet's cast: the capsule at 1.7 m
        assert ranges[4] == pytest.approx(2.5, abs=0.002) and ranges[6] == pytest.approx(1.7, abs=0.002)


def test_a_registered_compound_is_seen_part_by_part() -> None:
    with BulletClient() as client:
        cid = client.id
        shape = p.createCollisionShapeArray(
            [p.GEOM_BOX, p.GEOM_BOX],
            halfExtents=[[0.5, 0.5, 0.5], [0.5, 0.5, 0.5]],
            collisionFramePositions=[[2.0, 0.0, 0.0], [0.0, -4.0, 0.0]],
            physicsClientId=cid,
        )
        body = p.createMultiBody(0.0, shape, physicsClientId=cid)
        corners = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
        register_hulls(cid, body, [corners + np.array([2.0, 0.0, 0.0]), corners + np.array([0.0, -4.0, 0.0])])
        scene = RayScene(cid)
        scene.refresh()
        ranges = _fan(scene, ALL_GROUPS, beams=4)
        assert ranges is not None and ranges.tolist() == pytest.approx([10.0, 3.5, 1.5, 10.0])


def test_what_moves_is_seen_where_physics_has_it_period_by_period(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    """A carried load, a load put down, a component falling under Bullet's dynamics: after every period
    the watching robot's compiled scan is Bullet's (the caster poses only what may have moved)."""
    sim = make_sim(robots=2)
    sim.set_alive("r1", True)
    beam = next(c for c in frame_manifest.components if c.ifc_class == "IfcBeam")
    spot = sim.layout.slots[beam.guid].footprint
    x, y = spot.min_xy[0] - 0.8, (spot.min_xy[1] + spot.max_xy[1]) / 2.0
    sim.teleport_robot("r1", (x, y, math.pi / 2))
    assert sim.attach(AttachRequest(robot_id="r1", guid=beam.guid)).ok
    sim.teleport_robot("r2", (x - 3.0, y + 1.0, 0.0))  # watching r1 and its load from 3 m
    scene = sim._ray_scene
    assert scene is not None

    def watched(seconds: float) -> None:
        for _ in range(round(seconds / sim.config.control_period_s)):
            sim.advance()
            scene.refresh()
            bullet, compiled = _scans(sim, "r2", scene)
            difference = np.abs(bullet - compiled)
            # a stale pose would put the beams on a moving load centimetres off; beams at grazing
            # incidence turn Bullet's sub-millimetre margin into a few millimetres of range
            assert np.mean(difference <= 0.002) >= 0.97 and np.mean(difference <= 0.02) >= 0.99

    def nearest_ahead_left() -> float:  # r2's beams from straight ahead round to its left: r1 and its load
        return float(_scans(sim, "r2", scene)[1][len(sim._beam_starts["r2"]) // 2 :].min())

    watched(1.2)  # lifted onto r1
    lifted = nearest_ahead_left()
    drive(sim, "r1", 0.5, 0.0, 1.0)
    watched(0.6)  # carried north at 0.5 m/s, past r2's beams: 5 cm a period
    assert nearest_ahead_left() != lifted
    sim.set_alive("r1", False)  # lost: it puts its load down beside it (set, then static)
    watched(0.4)
    footing = next(c for c in frame_manifest.components if c.ifc_class == "IfcFooting")
    item = sim.handling.items[footing.guid]
    raised = ((item.pose[0][0], item.pose[0][1], item.pose[0][2] + 0.4), item.pose[1])
    set_component_pose(sim.client_id, item.body, raised)
    make_dynamic(sim.client_id, item.body)  # it falls back under Bullet's dynamics alone
    spot = sim.layout.slots[footing.guid].footprint
    sim.teleport_robot("r2", (spot.min_xy[0] - 3.0, (spot.min_xy[1] + spot.max_xy[1]) / 2.0, 0.0))
    watched(0.6)
    assert component_pose(sim.client_id, item.body)[0][2] < raised[0][2] - 0.3  # it did fall


def test_a_new_client_starts_with_nothing_recorded_of_an_earlier_one_of_its_id() -> None:
    """pybullet gives a new client the id of one disconnected before; one disconnected without close()
    (a test's raw client) had left its bodies' filter groups recorded, and the next simulation's caster
    mixed them with its own: 54 % of its beams within 2 mm of Bullet's instead of all but a handful."""
    from bimbot.services.physics import ray_scene

    raw = p.connect(p.DIRECT)
    ray_scene.note_group(raw, 5, -1, 1 << 4)  # as set_filter records a body of that client
    p.disconnect(raw)  # without forgetting it
    with BulletClient() as client:
        assert client.id == raw  # the id comes round again
        record = ray_scene._RECORDS.get(client.id)
        assert record is None or not record.groups
