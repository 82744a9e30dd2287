"""The scene: component bodies from the manifest at their yard slots, with its mass and full inertia;
nothing in the yard overlaps or moves; the ground and the fence are where the layout puts them."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from bimbot.services.physics.client import BulletClient, p
from bimbot.services.physics.scene import (
    component_model,
    component_pose,
    compose,
    create_component_body,
    invert,
    make_dynamic,
    principal_axes,
)
from bimbot.services.physics.simulation import Simulation
from bimbot.shared.manifest import Component, Manifest
from bimbot.shared.site_plan import FENCE_HEIGHT_M


def _inertia_matrix(component: Component) -> np.ndarray:
    i = component.inertia_kg_m2
    return np.array([[i.ixx, i.ixy, i.ixz], [i.ixy, i.iyy, i.iyz], [i.ixz, i.iyz, i.izz]])


def test_component_model_takes_mass_com_inertia_and_meshes_from_the_manifest(
    bundled_build: Path, frame_manifest: Manifest
) -> None:
    for component in frame_manifest.components:
        model = component_model(component, bundled_build)
        assert model.guid == component.guid
        assert model.mass_kg == component.mass_kg
        assert model.com_local_m == pytest.approx(component.com_local_m, abs=1e-12)
        assert np.allclose(model.inertia_kg_m2, _inertia_matrix(component), rtol=1e-12, atol=1e-12)
        assert np.allclose(model.inertia_kg_m2, np.transpose(model.inertia_kg_m2))  # symmetric, products kept
        expected = [bundled_build / name for name in component.files.collision]
        assert list(model.collision_files) == expected
        assert all(path.is_file() for path in model.collision_files)
        assert model.visual_file is not None and model.visual_file.is_file()


def test_principal_axes_rebuild_the_full_tensor_products_included() -> None:
    turn = Rotation.from_euler("xyz", [0.3, -0.7, 1.1]).as_matrix()
    tensor = turn @ np.diag([2.0, 5.0, 9.0]) @ turn.T  # non-zero products of inertia
    diagonal, quat = principal_axes(tensor)
    axes = Rotation.from_quat(quat).as_matrix()
    assert np.linalg.det(axes) == pytest.approx(1.0)
    assert np.allclose(axes @ np.diag(diagonal) @ axes.T, tensor, atol=1e-12)


def test_bodies_start_at_their_yard_slots_reported_as_their_centre_of_mass(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    sim = make_sim(robots=1)
    for component in frame_manifest.components:
        slot = sim.layout.slots[component.guid]
        body = sim.handling.items[component.guid].body
        com_world, _ = p.getBasePositionAndOrientation(body.body_id, physicsClientId=sim.client_id)
        expected = Rotation.from_quat(slot.quat_xyzw).apply(component.com_local_m) + np.asarray(
            slot.position_m
        )
        assert np.allclose(com_world, expected, atol=1e-9), component.guid  # pybullet reports pose ∘ com
        frame = component_pose(sim.client_id, body)
        assert np.allclose(frame[0], slot.position_m, atol=1e-9)
        assert abs(abs(float(np.dot(frame[1], slot.quat_xyzw))) - 1.0) < 1e-9


def test_a_body_has_the_sdf_mass_and_principal_inertia_when_dynamic(
    bundled_build: Path, frame_manifest: Manifest
) -> None:
    beam = next(c for c in frame_manifest.components if c.ifc_class == "IfcBeam")
    model = component_model(beam, bundled_build)
    with BulletClient() as client:
        body = create_component_body(client.id, beam, model, ((0.0, 0.0, 2.0), (0.0, 0.0, 0.0, 1.0)))
        at_rest = p.getDynamicsInfo(body.body_id, -1, physicsClientId=client.id)
        assert at_rest[0] == 0.0  # static while it waits
        make_dynamic(client.id, body)
        info = p.getDynamicsInfo(body.body_id, -1, physicsClientId=client.id)
        # a rigid body's frame in pybullet is its centre-of-mass frame on its principal axes (pybullet
        # does not report the inertial frame of a rigid body: getDynamicsInfo's fields 3-4 are not it)
        com_position, inertial_quat = p.getBasePositionAndOrientation(body.body_id, physicsClientId=client.id)
    mass, diagonal = info[0], info[2]
    assert mass == pytest.approx(beam.mass_kg)
    assert np.subtract(com_position, (0.0, 0.0, 2.0)) == pytest.approx(beam.com_local_m, abs=1e-9)
    axes = Rotation.from_quat(inertial_quat).as_matrix()
    rebuilt = axes @ np.diag(diagonal) @ axes.T
    assert np.allclose(rebuilt, _inertia_matrix(beam), rtol=1e-6, atol=1e-9)
    assert sorted(diagonal) == pytest.approx(sorted(np.linalg.eigvalsh(_inertia_matrix(beam))), rel=1e-9)


def test_nothing_in_the_yard_overlaps_falls_or_moves_in_two_seconds(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    sim = make_sim(robots=1)
    cid = sim.client_id
    ids = [sim.handling.items[c.guid].body.body_id for c in frame_manifest.components]
    boxes = [p.getAABB(i, physicsClientId=cid) for i in ids]
    margin = 0.003  # Bullet's collision margin around convex hulls
    for a in range(len(boxes)):
        assert boxes[a][0][2] > -margin, "resting on the ground, not in it"
        for b in range(a + 1, len(boxes)):
            (low_a, high_a), (low_b, high_b) = boxes[a], boxes[b]
            overlap = all(low_a[k] + margin < high_b[k] and low_b[k] + margin < high_a[k] for k in range(3))
            assert not overlap, (frame_manifest.components[a].guid, frame_manifest.components[b].guid)
    before = [p.getBasePositionAndOrientation(i, physicsClientId=cid) for i in ids]
    for _ in range(20):
        sim.advance()
    after = [p.getBasePositionAndOrientation(i, physicsClientId=cid) for i in ids]
    assert after == before


def test_ground_and_fence_stop_a_falling_box_and_enclose_the_site(
    make_sim: Callable[..., Simulation],
) -> None:
    sim = make_sim(robots=0)
    cid = sim.client_id
    shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.2, 0.2, 0.2], physicsClientId=cid)
    box = p.createMultiBody(
        5.0, shape, basePosition=[0.0, sim.layout.fence.min_xy[1] + 1.0, 1.0], physicsClientId=cid
    )
    for _ in range(20):
        sim.advance()
    assert p.getBasePositionAndOrientation(box, physicsClientId=cid)[0][2] == pytest.approx(0.2, abs=0.01)
    fence = [p.getAABB(i, physicsClientId=cid) for i in sim.fence_ids]
    inner = sim.layout.fence
    assert (
        min(low[0] for low, _ in fence) < inner.min_xy[0]
        and max(high[0] for _, high in fence) > inner.max_xy[0]
    )
    assert (
        min(low[1] for low, _ in fence) < inner.min_xy[1]
        and max(high[1] for _, high in fence) > inner.max_xy[1]
    )
    assert all(high[2] == pytest.approx(FENCE_HEIGHT_M, abs=0.01) for _, high in fence)


def test_frame_arithmetic_is_double_precision() -> None:
    a = ((0.1, 12345.678, -3.0), (0.0, 0.0, np.sin(0.35), np.cos(0.35)))
    b = ((0.2, -0.3, 1e-7), (np.sin(0.1), 0.0, 0.0, np.cos(0.1)))
    back = compose(invert(a), compose(a, b))
    assert np.allclose(back[0], b[0], atol=1e-12)
    assert np.allclose(back[1], b[1], atol=1e-12)
