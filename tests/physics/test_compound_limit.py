"""pybullet keeps only the first 16 children of a compound collision shape and drops the rest silently.

Two places made larger compounds: the pit floors (one body for every foundation's floor: on a site with
more than 16 foundations the others had no floor, and 308 of the 988-component site's 324 footings fell
through the ground), and components with more than 16 convex parts (the converter allowed 32: the Revit
house's windows have 22, acad2010's stairs 32). Now floors go 16 to a body, the converter makes at most 16
parts, and physics gives a component from an older build with more parts its bounding box, saying so.
"""

from __future__ import annotations

import dataclasses
import logging
from pathlib import Path

import pytest
from frames import convert_small_frame

from bimbot.services.physics.client import BulletClient, p
from bimbot.services.physics.pits import FLOOR_THICKNESS_M, Pits
from bimbot.services.physics.scene import component_model, create_component_body
from bimbot.services.physics.simulation import SimConfig, Simulation
from bimbot.shared.manifest import MAX_COLLISION_PARTS, Manifest, read_manifest


@pytest.fixture(scope="module")
def many_footings(tmp_path_factory: pytest.TempPathFactory) -> tuple[Manifest, Path]:
    """A 5×5 frame: 25 footings, more than one compound can hold."""
    build = convert_small_frame(tmp_path_factory.mktemp("frame_5x5"), bays=(5, 5))
    manifest = read_manifest(build)
    assert sum(1 for c in manifest.components if c.ifc_class == "IfcFooting") > MAX_COLLISION_PARTS
    return manifest, build


def test_every_pit_has_its_floor_on_a_site_with_more_than_sixteen_foundations(
    many_footings: tuple[Manifest, Path],
) -> None:
    manifest, _ = many_footings
    with BulletClient() as client:
        pits = Pits(client.id, manifest.components, filled=lambda guid: False)
        assert len(pits.pits) == 25
        starts, ends = [], []
        for pit in pits.pits:
            (x0, y0), (x1, y1) = pit.footprint.min_xy, pit.footprint.max_xy
            centre = ((x0 + x1) / 2.0, (y0 + y1) / 2.0)
            starts.append((*centre, 1.0))
            ends.append((*centre, pit.floor_z_m - 1.0))
        hits = p.rayTestBatch(starts, ends, physicsClientId=client.id)
        for pit, hit in zip(pits.pits, hits, strict=True):
            assert hit[0] == pit.floor_body, f"no floor under the pit of {pit.owner}"
            assert hit[3][2] == pytest.approx(pit.floor_z_m, abs=1e-6), "the floor's top is the pit's bottom"
        assert len({pit.floor_body for pit in pits.pits}) == 2  # 25 floors, 16 to a body
        assert FLOOR_THICKNESS_M > 0.0


def test_every_footing_set_down_over_its_pit_rests_on_its_floor(
    many_footings: tuple[Manifest, Path],
) -> None:
    manifest, build = many_footings
    footings = [c for c in manifest.components if c.ifc_class == "IfcFooting"]
    with Simulation(manifest, build, SimConfig(robots=1, odom_noise=0.0)) as sim:
        for footing in footings:
            sim.handling.set_down(footing.guid, sim.sim_time_s)
        for _ in range(10):  # 2 s
            sim.advance()
        for footing in footings:
            body = sim.handling.items[footing.guid].body
            z = p.getBasePositionAndOrientation(body.body_id, physicsClientId=sim.client_id)[0][2]
            com_z = footing.target_pose_world.position_m[2] + footing.com_local_m[2]
            assert z == pytest.approx(com_z, abs=0.01), f"{footing.name} fell through its pit's floor"


def test_a_component_with_more_parts_than_pybullet_keeps_collides_as_its_bounding_box(
    many_footings: tuple[Manifest, Path], caplog: pytest.LogCaptureFixture
) -> None:
    manifest, build = many_footings
    beam = next(c for c in manifest.components if c.ifc_class == "IfcBeam")
    model = component_model(beam, build)
    too_many = dataclasses.replace(model, collision_files=model.collision_files * (MAX_COLLISION_PARTS + 1))
    frame = ((0.0, 0.0, 5.0), (0.0, 0.0, 0.0, 1.0))
    with BulletClient() as client, caplog.at_level(logging.WARNING):
        body = create_component_body(client.id, beam, too_many, frame)
        low, high = p.getAABB(body.body_id, physicsClientId=client.id)
    assert f"{beam.guid} has {len(too_many.collision_files)} collision parts" in caplog.text
    box_low, box_high = beam.bbox_local.min_m, beam.bbox_local.max_m
    for axis in range(3):  # the body is the bounding box (Bullet's AABB adds its margin around it)
        assert low[axis] == pytest.approx(frame[0][axis] + box_low[axis], abs=0.05)
        assert high[axis] == pytest.approx(frame[0][axis] + box_high[axis], abs=0.05)
