"""Visual mesh formats (``bimbot convert --formats``): what is written, what is not, and that the readers
(physics, the rerun observer, Gazebo through model.sdf) still find what they use."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import ifcopenshell
import pybullet
import pytest
from cli_runs import Ended, bimbot_in_process, bimbot_process
from lxml import etree
from sdf_checks import sdf_check_all

from bimbot.demo import bundled_model_path
from bimbot.services.converter.convert import ConvertOptions, convert_model
from bimbot.services.converter.mesh_files import VISUAL_FORMATS, parse_formats
from bimbot.services.observer.app import load_mesh
from bimbot.services.physics.client import BulletClient
from bimbot.services.physics.scene import IDENTITY, component_model, create_component_body
from bimbot.shared.ifc_input import open_model
from bimbot.shared.manifest import Manifest

VISUAL_NAMES = {"dae": "visual.dae", "obj": "visual.obj", "glb": "visual.glb"}


def _convert(out: Path, formats: tuple[str, ...]) -> Manifest:
    source = bundled_model_path()
    return convert_model(open_model(source), source, out, ConvertOptions(formats=formats))


Converted = Callable[[tuple[str, ...]], tuple[Path, Manifest]]


@pytest.fixture(scope="module")
def converted(tmp_path_factory: pytest.TempPathFactory) -> Converted:
    """The bundled frame converted with the visual formats asked for, once per module for each choice of
    formats (several tests read the same one): its folder, read-only, and its manifest."""
    done: dict[tuple[str, ...], tuple[Path, Manifest]] = {}

    def convert(formats: tuple[str, ...]) -> tuple[Path, Manifest]:
        if formats not in done:
            out = tmp_path_factory.mktemp("frame-" + ("-".join(formats) or "none"))
            done[formats] = (out, _convert(out, formats))
        return done[formats]

    return convert


def _mesh_files(out: Path, manifest: Manifest) -> set[str]:
    """Names of the files in every component's meshes/ folder."""
    return {path.name for c in manifest.components for path in (out / c.files.model_dir / "meshes").iterdir()}


def _sdf_visual_uris(path: Path) -> list[str]:
    return [uri.text or "" for uri in etree.parse(str(path)).iterfind(".//visual/geometry/mesh/uri")]


def _physics_builds_every_body(out: Path, manifest: Manifest, *, visual: bool = False) -> None:
    """Physics' own loader (``visual``: as with ``--gui``) makes a body of every component."""
    with BulletClient() as bullet:  # closed, it forgets what the laser's caster recorded of its bodies
        client = bullet.id
        for component in manifest.components:
            model = component_model(component, out)
            body = create_component_body(client, component, model, IDENTITY, visual=visual)
            assert body.body_id >= 0
            drawn = {
                Path(shape[4].decode()).name
                for shape in pybullet.getVisualShapeData(body.body_id, physicsClientId=client)
            }
            # with visual.obj (and --gui) pybullet draws it, else it draws the collision parts
            expected = "visual.obj" if visual and model.visual_file is not None else "collision_0.obj"
            assert expected in drawn, (component.guid, drawn)


def test_default_formats_are_every_visual_format_a_reader_uses() -> None:
    assert ConvertOptions().formats == VISUAL_FORMATS == ("dae", "obj", "glb")


@pytest.mark.parametrize(
    ("text", "expected"), [("glb", ("glb",)), ("GLB, .dae", ("dae", "glb")), ("obj,obj", ("obj",)), ("", ())]
)
def test_formats_are_parsed_in_their_preference_order(text: str, expected: tuple[str, ...]) -> None:
    assert parse_formats(text) == expected


def test_unknown_format_is_refused_with_the_choices() -> None:
    with pytest.raises(ValueError, match=r"unknown visual format.*stl.*dae, obj, glb"):
        parse_formats("glb,stl")


@pytest.mark.parametrize("formats", [("glb",), ("obj",), ("dae", "glb")])
def test_only_the_formats_asked_for_are_written(formats: tuple[str, ...], converted: Converted) -> None:
    tmp_path, manifest = converted(formats)
    written = _mesh_files(tmp_path, manifest)
    expected_visuals = {VISUAL_NAMES[name] for name in formats}
    assert {name for name in written if name.startswith("visual.")} == expected_visuals
    assert any(name.startswith("collision_") for name in written)
    for component in manifest.components:
        paths = {"dae": component.files.visual_dae, "obj": component.files.visual_obj}
        paths["glb"] = component.files.visual_glb
        for name, path in paths.items():
            assert (path != "") == (name in formats), (name, path)
            assert path == "" or (tmp_path / path).is_file()
        assert all((tmp_path / path).is_file() for path in component.files.collision)


def test_without_dae_model_sdf_names_the_first_format_written_and_stays_valid(converted: Converted) -> None:
    tmp_path, manifest = converted(("obj", "glb"))
    files = [tmp_path / component.files.sdf_file for component in manifest.components[:3]]
    for sdf in files:
        assert [uri.rsplit("/", 1)[-1] for uri in _sdf_visual_uris(sdf)] == ["visual.obj"]
    checked = sdf_check_all([*files, tmp_path / manifest.world_file], tmp_path / "models")
    assert set(checked.values()) == {"Valid."}


def test_collision_only_writes_no_visual_and_keeps_every_sdf_valid(converted: Converted) -> None:
    tmp_path, manifest = converted(())
    assert not any(name.startswith("visual.") for name in _mesh_files(tmp_path, manifest))
    sdf = tmp_path / manifest.components[0].files.sdf_file
    assert _sdf_visual_uris(sdf) == []
    assert etree.parse(str(sdf)).find(".//collision") is not None
    checked = sdf_check_all([sdf, tmp_path / manifest.world_file], tmp_path / "models")
    assert set(checked.values()) == {"Valid."}
    assert load_mesh(tmp_path, manifest.components[0]) is None  # the observer draws nothing, says so
    _physics_builds_every_body(tmp_path, manifest)  # physics needs only the collision meshes


def test_observer_reads_the_glb_and_physics_its_collision_parts(converted: Converted) -> None:
    tmp_path, manifest = converted(("glb",))
    for component in manifest.components:
        loaded = load_mesh(tmp_path, component)
        assert loaded is not None and loaded[1] == "model/gltf-binary" and loaded[0][:4] == b"glTF"
        assert component_model(component, tmp_path).visual_file is None  # no visual.obj for --gui
    _physics_builds_every_body(tmp_path, manifest, visual=True)  # --gui without visual.obj: no visual


def test_observer_falls_back_to_the_obj_and_physics_gui_finds_it(converted: Converted) -> None:
    tmp_path, manifest = converted(("obj",))
    component = manifest.components[0]
    loaded = load_mesh(tmp_path, component)
    assert loaded is not None and loaded[1] == "model/obj" and loaded[0].startswith(b"#")
    visual = component_model(component, tmp_path).visual_file
    assert visual is not None and visual.is_file()
    _physics_builds_every_body(tmp_path, manifest, visual=True)


def test_shared_geometry_links_only_the_formats_written(converted: Converted) -> None:
    tmp_path, manifest = converted(("glb",))
    glbs = [tmp_path / c.files.visual_glb for c in manifest.components]
    inodes = {path.stat().st_ino for path in glbs}
    assert len(inodes) < len(glbs)  # the frame's 28 elements share 3 geometries
    assert not any(
        (tmp_path / c.files.model_dir / "meshes" / "visual.dae").exists() for c in manifest.components
    )


def test_cli_formats_option_writes_the_formats_and_refuses_unknown_ones(
    tmp_path: Path, capfd: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    """The conversions in this process (``main``), the refusal a real command: one line, exit 2."""
    source = tmp_path / "frame.ifc"
    ifcopenshell.open(str(bundled_model_path())).write(str(source))

    def bimbot(*args: str) -> Ended:
        return bimbot_in_process("convert", str(source), "--no-progress", *args, capfd=capfd, caplog=caplog)

    done = bimbot("-o", str(tmp_path / "out"), "--formats", "glb")
    assert done.returncode == 0, done.stderr
    manifest = Manifest.model_validate_json((tmp_path / "out" / "manifest.json").read_text())
    assert {name for name in _mesh_files(tmp_path / "out", manifest) if name.startswith("visual.")} == {
        "visual.glb"
    }
    none = bimbot("-o", str(tmp_path / "none"), "--formats", "none")
    assert none.returncode == 0, none.stderr
    refused = bimbot_process("convert", str(source), "-o", str(tmp_path / "bad"), "--formats", "glb,stl")
    assert refused.returncode == 2 and "--formats" in refused.stderr and "stl" in refused.stderr
    assert len(refused.stderr.strip().splitlines()) == 1
    assert "Traceback" not in refused.stderr and not (tmp_path / "bad" / "manifest.json").exists()


def test_no_split_ifc_writes_no_standalone_ifc_and_the_run_still_has_what_it_reads(
    tmp_path: Path, converted: Converted, capfd: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    source = tmp_path / "frame.ifc"
    ifcopenshell.open(str(bundled_model_path())).write(str(source))
    command = ["convert", str(source), "--no-progress", "--no-split-ifc", "-o", str(tmp_path / "out")]
    done = bimbot_in_process(*command, capfd=capfd, caplog=caplog)
    assert done.returncode == 0, done.stderr
    out = tmp_path / "out"
    manifest = Manifest.model_validate_json((out / "manifest.json").read_text())
    assert manifest.components and all(c.files.split_ifc == "" for c in manifest.components)
    assert not list((out / "models").rglob("*.ifc"))
    assert all((out / c.files.sdf_file).is_file() for c in manifest.components)
    _physics_builds_every_body(out, manifest)
    default, with_split = converted(VISUAL_FORMATS)  # the default still writes one per component
    assert all((default / c.files.split_ifc).is_file() for c in with_split.components)
