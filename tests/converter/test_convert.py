"""End-to-end conversion: the bundled frame and every public sample → SDF world, checked by the SDFormat
reference parser (one file per structure) and a value check of every file (tests/converter/sdf_checks.py),
PyBullet, and the world-coordinate tessellation of the source."""

from __future__ import annotations

import os
from pathlib import Path

import ifcopenshell
import ifcopenshell.geom
import ifcopenshell.util.shape
import numpy as np
import pybullet
import pytest
import trimesh
from lxml import etree
from sample_builds import converted_sample
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation
from sdf_checks import sdf_check_files, sdf_model_pose

from bimbot.demo import bundled_model_path
from bimbot.services.converter.convert import convert_model
from bimbot.shared.identifiers import folder_to_guid, key_to_guid
from bimbot.shared.ifc_input import open_model
from bimbot.shared.manifest import CollisionMethod, Manifest, MassSource, read_manifest
from bimbot.shared.sequence import read_sequence
from bimbot.shared.support_graph import support_predecessors, support_violations

SAMPLES_DIR = Path(__file__).resolve().parents[3] / "shared" / "samples" / "ifc"
SAMPLE_FILES = sorted(SAMPLES_DIR.glob("*.ifc")) if SAMPLES_DIR.is_dir() else []
POSE_TOLERANCE_M = 1e-6


def _convert(source: Path, out_dir: Path) -> Manifest:
    return convert_model(open_model(source), source, out_dir)


@pytest.fixture(scope="module")
def frame(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Manifest]:
    out = tmp_path_factory.mktemp("frame")
    return out, _convert(bundled_model_path(), out)


@pytest.fixture(scope="module", params=[path.name for path in SAMPLE_FILES] or ["(no samples)"])
def sample(
    request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
) -> tuple[Path, Manifest, Path]:
    """The sample's default conversion, shared with the other test files that read it (sample_builds)."""
    if not SAMPLE_FILES:
        pytest.skip(f"{SAMPLES_DIR} is absent")
    out, manifest = converted_sample(request.param, tmp_path_factory)
    return out, manifest, SAMPLES_DIR / request.param


# --- shared checks ---------------------------------------------------------------------------------------


def _check_every_sdf_file(out: Path, manifest: Manifest) -> None:
    """Every file's values, and the reference parser on one file of each structure (the world among them)."""
    files = [out / component.files.sdf_file for component in manifest.components] + [
        out / manifest.world_file
    ]
    checked = sdf_check_files(files, out / "models")
    assert {path: answer for path, answer in checked.items() if answer != "Valid."} == {}


def _world_vertices(model: ifcopenshell.file, guid: str) -> np.ndarray:
    settings = ifcopenshell.geom.settings()
    settings.set("use-world-coords", True)
    settings.set("weld-vertices", True)
    shape = ifcopenshell.geom.create_shape(settings, model.by_guid(guid))
    return np.asarray(ifcopenshell.util.shape.get_vertices(shape.geometry), dtype=float)


def _check_mesh_at_pose_matches_world_tessellation(
    out: Path, manifest: Manifest, model: ifcopenshell.file
) -> None:
    origin = np.array(manifest.local_origin_m)
    for component in manifest.components:
        if component.parent_guid:  # a panel: no IFC element of its own (tests/converter/test_panels.py)
            continue
        mesh = trimesh.load(out / component.files.visual_obj, force="mesh", process=False)
        pose = sdf_model_pose(out / component.files.sdf_file)
        placed = mesh.vertices @ pose[:3, :3].T + pose[:3, 3] + origin
        expected = _world_vertices(model, component.guid)
        distance_there, _ = cKDTree(placed).query(expected)
        distance_back, _ = cKDTree(expected).query(placed)
        assert max(distance_there.max(), distance_back.max()) < POSE_TOLERANCE_M, component.guid


def _check_pybullet_loads_each_body_at_its_bim_pose(out: Path, manifest: Manifest) -> None:
    client = pybullet.connect(pybullet.DIRECT)
    try:
        for component in manifest.components:
            (body,) = pybullet.loadSDF(str(out / component.files.sdf_file), physicsClientId=client)
            _assert_body_at_pose(client, body, component)
        bodies = pybullet.loadSDF(str(out / manifest.world_file), physicsClientId=client)
        by_name = {pybullet.getBodyInfo(b, physicsClientId=client)[1].decode(): b for b in bodies}
        assert set(by_name) == {"ground_plane"} | {c.guid for c in manifest.components}
        for component in manifest.components:
            _assert_body_at_pose(client, by_name[component.guid], component)
    finally:
        pybullet.disconnect(client)


def _assert_body_at_pose(client: int, body: int, component) -> None:
    """PyBullet reports the centre-of-mass frame: pose ∘ CoM offset."""
    position, orientation = pybullet.getBasePositionAndOrientation(body, physicsClientId=client)
    pose = component.target_pose_world
    rotation = Rotation.from_quat(pose.quat_xyzw)
    expected = np.array(pose.position_m) + rotation.apply(component.com_local_m)
    np.testing.assert_allclose(position, expected, atol=POSE_TOLERANCE_M, err_msg=component.guid)
    assert (Rotation.from_quat(orientation).inv() * rotation).magnitude() < 1e-6, component.guid


# --- the bundled light steel frame ---------------------------------------------------------------------


def test_frame_converts_all_28_components_with_nothing_skipped(frame: tuple[Path, Manifest]) -> None:
    out, manifest = frame
    classes = sorted(c.ifc_class for c in manifest.components)
    assert (
        classes.count("IfcFooting") == 9
        and classes.count("IfcColumn") == 9
        and classes.count("IfcBeam") == 10
    )
    assert manifest.skipped == []
    assert read_manifest(out) == manifest
    assert manifest.site == "greenhouse-site" and (out / "worlds" / "greenhouse-site.world").is_file()


def test_frame_sdf_files_pass_the_value_check_and_each_structure_the_reference_parser(
    frame: tuple[Path, Manifest],
) -> None:
    _check_every_sdf_file(*frame)


def test_frame_meshes_at_their_poses_coincide_with_the_world_tessellation(
    frame: tuple[Path, Manifest],
) -> None:
    out, manifest = frame
    _check_mesh_at_pose_matches_world_tessellation(
        out, manifest, ifcopenshell.open(str(bundled_model_path()))
    )


def test_frame_loads_in_pybullet_with_every_body_at_its_bim_pose(frame: tuple[Path, Manifest]) -> None:
    _check_pybullet_loads_each_body_at_its_bim_pose(*frame)


def test_frame_masses_come_from_each_source_of_the_chain(frame: tuple[Path, Manifest]) -> None:
    _, manifest = frame
    sources = {c.ifc_class: c.mass_source for c in manifest.components}
    assert sources == {
        "IfcBeam": MassSource.QUANTITY_WEIGHT,  # Qto_BeamBaseQuantities.NetWeight
        "IfcColumn": MassSource.MATERIAL_DENSITY_PROPERTY,  # steel with Pset_MaterialCommon.MassDensity
        "IfcFooting": MassSource.MATERIAL_DENSITY_TABLE,  # "C30/37 Concrete" without a density
    }
    footing = next(c for c in manifest.components if c.ifc_class == "IfcFooting")
    assert footing.mass_kg == pytest.approx(0.6 * 0.6 * 0.3 * 2400.0, rel=1e-6)
    column = next(c for c in manifest.components if c.ifc_class == "IfcColumn")
    assert column.mass_kg == pytest.approx((0.1**2 - 0.09**2) * 3.0 * 7850.0, rel=1e-3)


def test_frame_collision_is_one_hull_for_pads_and_exact_parts_for_sections(
    frame: tuple[Path, Manifest],
) -> None:
    _, manifest = frame
    parts = {(c.ifc_class, c.collision_method, c.collision_parts) for c in manifest.components}
    assert ("IfcBeam", CollisionMethod.PROFILE_DECOMPOSITION, 3) in parts  # I-section: three boxes
    assert ("IfcColumn", CollisionMethod.PROFILE_DECOMPOSITION, 4) in parts  # hollow section: four walls
    assert all(c.collision_parts == 1 for c in manifest.components if c.ifc_class == "IfcFooting")


def test_frame_identical_geometry_is_written_once_and_linked(frame: tuple[Path, Manifest]) -> None:
    out, manifest = frame
    columns = [c for c in manifest.components if c.ifc_class == "IfcColumn"]
    inodes = {os.stat(out / c.files.visual_dae).st_ino for c in columns}
    assert len(inodes) == 1


def test_frame_sequence_comes_from_the_ifc_schedule_and_respects_supports(
    frame: tuple[Path, Manifest],
) -> None:
    out, manifest = frame
    sequence = read_sequence(out / manifest.sequence_file)
    assert manifest.sequence_source == sequence.source == "ifc_schedule"
    assert sorted(sequence.guids()) == sorted(c.guid for c in manifest.components)
    assert support_violations(sequence.guids(), support_predecessors(manifest.components)) == []


def test_frame_semantics_in_manifest_config_and_split_ifc(frame: tuple[Path, Manifest]) -> None:
    out, manifest = frame
    for component in manifest.components:
        assert key_to_guid(component.key) == component.guid
        assert folder_to_guid(component.folder) == component.guid
        assert component.storey == "Level 0"
        assert component.material in ("S235 Steel", "C30/37 Concrete")
        config = etree.parse(str(out / component.files.config_file)).getroot()
        assert config.findtext("name") == component.guid
        assert component.guid in config.findtext("description")
        split = ifcopenshell.open(str(out / component.files.split_ifc))
        assert split.by_guid(component.guid).is_a() == component.ifc_class
    beam = next(c for c in manifest.components if c.ifc_class == "IfcBeam")
    assert {link.other_class for link in beam.connections} >= {"IfcColumn"}


# --- every public sample -------------------------------------------------------------------------------


def test_sample_sdf_files_pass_the_value_check_and_each_structure_the_reference_parser(
    sample: tuple[Path, Manifest, Path],
) -> None:
    out, manifest, _ = sample
    _check_every_sdf_file(out, manifest)


def test_sample_meshes_at_poses_coincide_with_world_tessellation(sample: tuple[Path, Manifest, Path]) -> None:
    out, manifest, source = sample
    _check_mesh_at_pose_matches_world_tessellation(out, manifest, ifcopenshell.open(str(source)))


def test_sample_loads_in_pybullet_with_bodies_at_bim_poses(sample: tuple[Path, Manifest, Path]) -> None:
    out, manifest, _ = sample
    _check_pybullet_loads_each_body_at_its_bim_pose(out, manifest)


def test_sample_lists_every_element_as_component_or_skipped(sample: tuple[Path, Manifest, Path]) -> None:
    _, manifest, source = sample
    model = ifcopenshell.open(str(source))
    built = [*manifest.components, *manifest.in_place]
    listed = {c.guid for c in built} | {s.guid for s in manifest.skipped}
    listed |= {entry.guid for entry in manifest.panelised} | {g.guid for c in built for g in c.guests}
    for element in model.by_type("IfcElement"):
        assert element.GlobalId in listed, (element.is_a(), element.GlobalId)
    assert all(component.mass_kg > 0 for component in manifest.components)
    assert all(skipped.reason for skipped in manifest.skipped)


def test_far_model_is_shifted_to_a_local_origin(tmp_path_factory: pytest.TempPathFactory) -> None:
    source = SAMPLES_DIR / "large_offset.ifc"
    if not source.is_file():
        pytest.skip(f"{source} is absent")
    _, manifest = converted_sample(source.name, tmp_path_factory)  # the sample tests' conversion
    assert any(abs(v) > 1000.0 for v in manifest.local_origin_m)
    for component in manifest.components:
        assert np.abs(component.target_pose_world.position_m).max() < 1000.0


def test_csg_only_element_is_skipped_with_the_reason(tmp_path_factory: pytest.TempPathFactory) -> None:
    source = SAMPLES_DIR / "geographic-referencing.ifc"
    if not source.is_file():
        pytest.skip(f"{source} is absent")
    _, manifest = converted_sample(source.name, tmp_path_factory)  # the sample tests' conversion
    (skipped,) = manifest.skipped
    assert skipped.guid == "0rBru4syGxGOZb$M8kVJuS"
    assert "could not build" in skipped.reason
