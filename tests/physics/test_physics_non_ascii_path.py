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
                        p.getDynamicsInfo(body.body_id, -1, physicsClientId=client.id)[:5],
                        len(p.getCollisionShapeData(body.body_id, -1, physicsClientId=client.id)),
                    )
                )
        assert shapes[0] == shapes[1], component.guid


def test_the_whole_site_loads_from_a_non_ascii_build_folder(non_ascii_build: Path) -> None:
    manifest: Manifest = read_manifest(non_ascii_build)
    with Simulation(manifest, non_ascii_build, SimConfig(robots=1, odom_noise=0.0)) as sim:
        assert set(sim.handling.items) == {component.guid for component in manifest.components}
        sim.advance()
        assert sim.step == 1
