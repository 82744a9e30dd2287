"""Physics loads a build whose path holds non-ASCII characters, with the very same collision shapes.

pybullet's ``createCollisionShapeArray`` crashed the physics process (a segmentation fault) on such paths;
:mod:`bimbot.services.physics.mesh_paths` hands it ASCII links to the same files.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from bimbot.services.physics.client import BulletClient, p
from bimbot.services.physics.mesh_paths import AsciiLinks
from bimbot.services.physics.scene import IDENTITY, component_model, create_component_body
from bimbot.services.physics.simulation import SimConfig, Simulation
from bimbot.shared.manifest import Manifest, read_manifest

NON_ASCII = Path("Bâtiment 3") / "建物"


@pytest.fixture(scope="module")
def non_ascii_build(bundled_build: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    build = tmp_path_factory.mktemp("builds") / NON_ASCII
    shutil.copytree(bundled_build, build)
    return build


def test_an_ascii_path_is_passed_through_and_nothing_is_made(tmp_path: Path) -> None:
    links = AsciiLinks(tmp_path)
    assert links.path(Path("/tmp/build/models/a/meshes/collision_0.obj")) == (
        "/tmp/build/models/a/meshes/collision_0.obj"
    )
    assert links.root is None and list(tmp_path.iterdir()) == []


def test_a_non_ascii_path_reads_the_same_file_through_an_ascii_link(tmp_path: Path) -> None:
    folder = tmp_path / "Bâtiment 3" / "建物"
    folder.mkdir(parents=True)
    (folder / "collision_0.obj").write_text("v 0 0 0\n")
    (folder / "pièce.obj").write_text("v 1 1 1\n")
    temp = tmp_path / "temp"
    temp.mkdir()
    links = AsciiLinks(temp)
    first = links.path(folder / "collision_0.obj")
    named = links.path(folder / "pièce.obj")
    assert first.isascii() and named.isascii()
    assert Path(first).read_text() == "v 0 0 0\n" and Path(named).read_text() == "v 1 1 1\n"
    assert links.path(folder / "collision_0.obj") == first  # one link per folder, made once
    links.close()
    assert list(temp.iterdir()) == []
    assert (folder / "collision_0.obj").read_text() == "v 0 0 0\n"  # the build is untouched


def test_a_component_body_from_a_non_ascii_path_has_the_same_collision_shape(
    bundled_build: Path, non_ascii_build: Path
) -> None:
    manifest = read_manifest(bundled_build)
    for component in manifest.components[:6]:
        shapes = []
        for build in (bundled_build, non_ascii_build):
            with BulletClient() as client:
                model = component_model(component, build)
                body = create_component_body(client.id, component, model, IDENTITY)
                shapes.append(
                    (
                        p.getAABB(body.body_id, physicsClientId=client.id),
                        p.getDynamicsInfo(body.body_id, -1, physicsClientId=client.id)[:3],
                        _ray_fingerprint(client.id, body.body_id),
                    )
                )
        assert shapes[0] == shapes[1], component.guid
        assert any(fraction < 1.0 for fraction in shapes[0][2]), component.guid  # the rays hit the body


def _ray_fingerprint(client_id: int, body_id: int, n: int = 9) -> list[float]:
    """Where a grid of vertical rays over the body's box hits it: equal shapes, equal fractions (a rigid
    body's collision shapes cannot be listed by pybullet)."""
    low, high = p.getAABB(body_id, physicsClientId=client_id)
    starts, ends = [], []
    for i in range(n):
        for j in range(n):
            x = low[0] + (high[0] - low[0]) * (i + 0.5) / n
            y = low[1] + (high[1] - low[1]) * (j + 0.5) / n
            starts.append((x, y, high[2] + 1.0))
            ends.append((x, y, low[2] - 1.0))
    return [hit[2] for hit in p.rayTestBatch(starts, ends, physicsClientId=client_id)]


def test_the_whole_site_loads_from_a_non_ascii_build_folder(non_ascii_build: Path) -> None:
    manifest: Manifest = read_manifest(non_ascii_build)
    with Simulation(manifest, non_ascii_build, SimConfig(robots=1, odom_noise=0.0)) as sim:
        assert set(sim.handling.items) == {component.guid for component in manifest.components}
        sim.advance()
        assert sim.step == 1
