"""Tests of bimbot.services.converter.split_ifc: one element → one standalone IFC file."""

from __future__ import annotations

import functools
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import ifcopenshell
import ifcopenshell.api.aggregate
import ifcopenshell.api.classification
import ifcopenshell.api.feature
import ifcopenshell.api.geometry
import ifcopenshell.api.pset
import ifcopenshell.api.root
import ifcopenshell.api.spatial
import ifcopenshell.api.style
import ifcopenshell.geom
import ifcopenshell.util.classification
import ifcopenshell.util.element
import ifcopenshell.util.placement
import ifcopenshell.util.shape
import ifcopenshell.util.unit
import numpy as np
import pytest
from ifc_builders import (
    SmallModel,
    add_assembly,
    add_beam,
    add_material,
    add_opening,
    add_pset,
    add_qto,
    add_type,
    add_wall,
    new_model,
    translation,
)

from bimbot.services.converter.split_ifc import split_element

Entity = ifcopenshell.entity_instance

SAMPLES_DIR = (
    Path(__file__).resolve().parents[3] / "shared" / "samples" / "ifc"
)  # the public samples beside the checkout (tests/conftest.py), needed here at collection time
#: Files with more building elements than this are tested on a class-diverse selection of this many.
MAX_ELEMENTS_PER_FILE = 20
VOLUME_RTOL = 1e-3


# --- helpers -------------------------------------------------------------------------------------------


def building_elements(model: ifcopenshell.file) -> list[Entity]:
    """IfcElement instances that are not openings or other subtraction features."""
    return [e for e in model.by_type("IfcElement") if not e.is_a("IfcFeatureElementSubtraction")]


def has_body(element: Entity) -> bool:
    shape = element.Representation
    return shape is not None and any(rep.RepresentationIdentifier == "Body" for rep in shape.Representations)


def selected_elements(model: ifcopenshell.file) -> list[Entity]:
    """All elements with a Body of a small file; of a larger one, one per class first, then in file order."""
    candidates = [e for e in building_elements(model) if has_body(e)]
    if len(candidates) <= MAX_ELEMENTS_PER_FILE:
        return candidates
    first_of_class = list({e.is_a(): e for e in reversed(candidates)}.values())
    rest = [e for e in candidates if e not in first_of_class]
    return (first_of_class + rest)[:MAX_ELEMENTS_PER_FILE]


@functools.cache
def open_sample(name: str) -> ifcopenshell.file:
    return ifcopenshell.open(str(SAMPLES_DIR / name))


def sample_params() -> list[Any]:
    if not SAMPLES_DIR.is_dir():
        return [pytest.param("", "", marks=pytest.mark.skip(reason=f"{SAMPLES_DIR} is absent"))]
    return [
        pytest.param(path.name, element.GlobalId, id=f"{path.stem}-{element.is_a()}-{element.GlobalId}")
        for path in sorted(SAMPLES_DIR.glob("*.ifc"))
        for element in selected_elements(open_sample(path.name))
    ]


def split_and_reopen(model: ifcopenshell.file, element: Entity, tmp_path: Path) -> ifcopenshell.file:
    path = tmp_path / f"{element.GlobalId}.ifc"
    split_element(model, element).write(str(path))
    return ifcopenshell.open(str(path))


def without_ids(value: Any) -> Any:
    if isinstance(value, dict):
        return {key: without_ids(item) for key, item in value.items() if key != "id"}
    return value


def material_names(element: Entity) -> tuple[str | None, list[str]]:
    material = ifcopenshell.util.element.get_material(element)
    names = sorted(m.Name or "" for m in ifcopenshell.util.element.get_materials(element))
    return (material.is_a() if material is not None else None), names


def spatial_guids(element: Entity) -> list[str]:
    """GlobalIds of the element's (possibly indirect) container and its parents up to the project."""
    guids = []
    node = ifcopenshell.util.element.get_container(element)
    while node is not None:
        guids.append(node.GlobalId)
        node = ifcopenshell.util.element.get_aggregate(node)
    return guids


def world_shape(element: Entity) -> Any:
    settings = ifcopenshell.geom.settings()
    settings.set("use-world-coords", True)
    return ifcopenshell.geom.create_shape(settings, element)


def volume_m3(shape: Any) -> float:
    vertices = ifcopenshell.util.shape.get_vertices(shape.geometry)
    faces = ifcopenshell.util.shape.get_faces(shape.geometry)
    a, b, c = vertices[faces[:, 0]], vertices[faces[:, 1]], vertices[faces[:, 2]]
    return abs(float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum()) / 6.0)


def two_walls(schema: str) -> tuple[SmallModel, Entity, Entity]:
    """Two walls sharing one property set, one material and one type."""
    small = new_model(schema)
    wall_1 = add_wall(small, "Wall 1")
    wall_2 = add_wall(small, "Wall 2", matrix_m=translation(0.0, 5.0))
    add_pset(small, [wall_1, wall_2], "Pset_WallCommon", {"IsExternal": True, "FireRating": "F90"})
    add_qto(small, wall_1, "Qto_WallBaseQuantities", {"Length": 4.0, "Height": 3.0})
    add_material(small, [wall_1, wall_2], "Concrete")
    add_type(small, [wall_1, wall_2], "IfcWallType", "Concrete wall 200")
    return small, wall_1, wall_2


# --- ifcopenshell behaviour relied on --------------------------------------------------------------------


def test_add_copies_a_source_instance_once_per_target_file() -> None:
    _small, wall, _ = two_walls("IFC4")
    target = ifcopenshell.file(schema="IFC4")
    first = target.add(wall)
    count = len(list(target))
    again = target.add(wall)
    placement = target.add(wall.ObjectPlacement)
    assert again == first
    assert placement == first.ObjectPlacement
    assert len(list(target)) == count
    other = ifcopenshell.file(schema="IFC4")
    other.add(wall)
    assert len(list(other)) == count  # a second target file gets its own full copy


# --- every sample ----------------------------------------------------------------------------------------

SplitSample = Callable[[str, str], tuple[Entity, ifcopenshell.file]]


@pytest.fixture(scope="module")
def split_sample(tmp_path_factory: pytest.TempPathFactory) -> SplitSample:
    """Split a sample element once per module: (source element, split file written and reopened)."""
    cache: dict[tuple[str, str], ifcopenshell.file] = {}  # also keeps the files alive for their instances

    def split(sample: str, guid: str) -> tuple[Entity, ifcopenshell.file]:
        element = open_sample(sample).by_guid(guid)
        if (sample, guid) not in cache:
            folder = tmp_path_factory.mktemp(Path(sample).stem)
            cache[sample, guid] = split_and_reopen(open_sample(sample), element, folder)
        return element, cache[sample, guid]

    return split


@pytest.mark.parametrize(("sample", "guid"), sample_params())
def test_split_sample_keeps_schema_units_and_exactly_that_one_element(
    sample: str, guid: str, split_sample: SplitSample
) -> None:
    element, split = split_sample(sample, guid)
    model = open_sample(sample)
    assert split.schema_identifier == model.schema_identifier
    scale = ifcopenshell.util.unit.calculate_unit_scale
    assert scale(split) == scale(model)
    (copy,) = building_elements(split)
    assert (copy.GlobalId, copy.is_a(), copy.Name) == (element.GlobalId, element.is_a(), element.Name)
    guids = [root.GlobalId for root in split.by_type("IfcRoot")]
    assert len(guids) == len(set(guids)), "an object or relationship was copied twice"
    assert [p.GlobalId for p in split.by_type("IfcProject")] == [
        p.GlobalId for p in model.by_type("IfcProject")
    ]


@pytest.mark.parametrize(("sample", "guid"), sample_params())
def test_split_sample_keeps_the_absolute_placement(sample: str, guid: str, split_sample: SplitSample) -> None:
    element, split = split_sample(sample, guid)
    np.testing.assert_allclose(
        ifcopenshell.util.placement.get_local_placement(split.by_guid(guid).ObjectPlacement),
        ifcopenshell.util.placement.get_local_placement(element.ObjectPlacement),
        atol=1e-9,
    )


@pytest.mark.parametrize(("sample", "guid"), sample_params())
def test_split_sample_keeps_psets_quantities_type_material_and_openings(
    sample: str, guid: str, split_sample: SplitSample
) -> None:
    element, split = split_sample(sample, guid)
    copy = split.by_guid(guid)
    get_psets = ifcopenshell.util.element.get_psets
    assert without_ids(get_psets(copy)) == without_ids(get_psets(element))
    assert material_names(copy) == material_names(element)
    source_type = ifcopenshell.util.element.get_type(element)
    copy_type = ifcopenshell.util.element.get_type(copy)
    assert (copy_type and copy_type.GlobalId) == (source_type and source_type.GlobalId)
    openings = sorted(rel.RelatedOpeningElement.GlobalId for rel in element.HasOpenings or ())
    assert sorted(rel.RelatedOpeningElement.GlobalId for rel in copy.HasOpenings or ()) == openings


@pytest.mark.parametrize(("sample", "guid"), sample_params())
def test_split_sample_is_contained_in_the_source_spatial_chain_under_the_project(
    sample: str, guid: str, split_sample: SplitSample
) -> None:
    element, split = split_sample(sample, guid)
    copy = split.by_guid(guid)
    assert spatial_guids(copy) == spatial_guids(element)
    if not spatial_guids(element):
        pytest.skip(f"{element.is_a()} {guid} is in no spatial structure in the source either")
    assert ifcopenshell.util.element.get_container(copy, should_get_direct=True) is not None
    assert split.by_guid(spatial_guids(copy)[-1]).is_a("IfcProject")


@pytest.mark.parametrize(("sample", "guid"), sample_params())
def test_split_sample_element_has_the_source_volume(
    sample: str, guid: str, split_sample: SplitSample
) -> None:
    element, split = split_sample(sample, guid)  # split stays referenced: its instances need it alive
    try:
        source_shape = world_shape(element)
    except RuntimeError as error:
        pytest.skip(f"source geometry of {element.is_a()} cannot be meshed, the converter skips it: {error}")
    copy_shape = world_shape(split.by_guid(guid))
    assert volume_m3(copy_shape) == pytest.approx(volume_m3(source_shape), rel=VOLUME_RTOL, abs=1e-12)
    np.testing.assert_allclose(
        ifcopenshell.util.shape.get_vertices(copy_shape.geometry).min(axis=0),
        ifcopenshell.util.shape.get_vertices(source_shape.geometry).min(axis=0),
        atol=1e-6,
    )


def test_split_keeps_the_georeferencing_of_the_project(tmp_path: Path) -> None:
    if not (SAMPLES_DIR / "geographic-referencing.ifc").is_file():
        pytest.skip(f"{SAMPLES_DIR} is absent")
    model = open_sample("geographic-referencing.ifc")
    (source,) = model.by_type("IfcMapConversion")
    split = split_and_reopen(model, building_elements(model)[0], tmp_path)
    (copy,) = split.by_type("IfcMapConversion")
    assert (copy.Eastings, copy.Northings, copy.OrthogonalHeight) == (
        source.Eastings,
        source.Northings,
        source.OrthogonalHeight,
    )
    assert copy.TargetCRS.Name == source.TargetCRS.Name
    assert copy.SourceCRS in split.by_type("IfcProject")[0].RepresentationContexts


# --- generated models ------------------------------------------------------------------------------------


@pytest.mark.parametrize("schema", ["IFC2X3", "IFC4", "IFC4X3"])
def test_split_of_one_wall_holds_no_trace_of_the_other_wall(schema: str, tmp_path: Path) -> None:
    small, wall_1, wall_2 = two_walls(schema)
    split = split_and_reopen(small.file, wall_1, tmp_path)

    assert wall_2.GlobalId not in (tmp_path / f"{wall_1.GlobalId}.ifc").read_text()
    assert [wall.GlobalId for wall in split.by_type("IfcWall")] == [wall_1.GlobalId]
    shared = [
        *wall_1.IsDefinedBy,
        *(getattr(wall_1, "IsTypedBy", None) or ()),
        *wall_1.HasAssociations,
        *wall_1.ContainedInStructure,
    ]
    assert len({rel.is_a() for rel in shared}) >= 4
    for rel in shared:
        copy = split.by_guid(rel.GlobalId)
        assert copy.is_a() == rel.is_a()
        related = (
            copy.RelatedElements if copy.is_a("IfcRelContainedInSpatialStructure") else copy.RelatedObjects
        )
        assert [obj.GlobalId for obj in related] == [wall_1.GlobalId]


def test_split_is_deterministic_and_independent_of_other_splits() -> None:
    small, wall_1, wall_2 = two_walls("IFC4")
    first = split_element(small.file, wall_1)
    second = split_element(small.file, wall_2)
    first_again = split_element(small.file, wall_1)
    assert [w.GlobalId for w in first.by_type("IfcWall")] == [wall_1.GlobalId]
    assert [w.GlobalId for w in second.by_type("IfcWall")] == [wall_2.GlobalId]
    assert first_again.to_string() == first.to_string()


def test_split_keeps_psets_quantities_material_and_type_of_a_generated_wall(tmp_path: Path) -> None:
    small, wall_1, _ = two_walls("IFC4")
    split = split_and_reopen(small.file, wall_1, tmp_path)
    copy = split.by_guid(wall_1.GlobalId)
    psets = without_ids(ifcopenshell.util.element.get_psets(copy))
    assert psets["Pset_WallCommon"] == {"IsExternal": True, "FireRating": "F90"}
    assert psets["Qto_WallBaseQuantities"] == {"Length": 4.0, "Height": 3.0}
    assert ifcopenshell.util.element.get_material(copy).Name == "Concrete"
    assert ifcopenshell.util.element.get_type(copy).Name == "Concrete wall 200"


def test_split_element_with_opening_keeps_the_voided_volume(tmp_path: Path) -> None:
    small = new_model("IFC4")
    wall = add_wall(small, length_m=4.0, height_m=3.0, thickness_m=0.2)
    opening = add_opening(small, wall, width_m=1.0, height_m=1.0, matrix_m=translation(1.0, -0.2, 1.0))
    window = ifcopenshell.api.root.create_entity(small.file, ifc_class="IfcWindow", name="Window")
    ifcopenshell.api.spatial.assign_container(small.file, products=[window], relating_structure=small.storey)
    ifcopenshell.api.feature.add_filling(small.file, opening=opening, element=window)
    split = split_and_reopen(small.file, wall, tmp_path)

    assert volume_m3(world_shape(split.by_guid(wall.GlobalId))) == pytest.approx(
        4.0 * 3.0 * 0.2 - 0.2, rel=1e-6
    )
    assert [o.GlobalId for o in split.by_type("IfcOpeningElement")] == [opening.GlobalId]
    assert split.by_guid(wall.HasOpenings[0].GlobalId).RelatedOpeningElement.GlobalId == opening.GlobalId
    assert split.by_type("IfcWindow") == () and split.by_type("IfcRelFillsElement") == ()


def test_split_part_of_assembly_is_contained_in_the_assembly_container_without_the_assembly(
    tmp_path: Path,
) -> None:
    small = new_model("IFC4")
    beam = add_beam(small, contained=False, matrix_m=translation(2.0, 1.0, 3.0))
    add_assembly(small, [beam])
    split = split_and_reopen(small.file, beam, tmp_path)

    assert split.by_type("IfcElementAssembly") == ()
    copy = split.by_guid(beam.GlobalId)
    assert (
        ifcopenshell.util.element.get_container(copy, should_get_direct=True).GlobalId
        == small.storey.GlobalId
    )
    np.testing.assert_allclose(
        ifcopenshell.util.placement.get_local_placement(copy.ObjectPlacement),
        ifcopenshell.util.placement.get_local_placement(beam.ObjectPlacement),
    )
    again = split_element(small.file, beam)
    assert (
        copy.ContainedInStructure[0].GlobalId
        == again.by_type("IfcRelContainedInSpatialStructure")[0].GlobalId
    )


def test_split_element_in_a_space_keeps_the_space_in_its_chain(tmp_path: Path) -> None:
    small = new_model("IFC4")
    space = ifcopenshell.api.root.create_entity(small.file, ifc_class="IfcSpace", name="Room")
    ifcopenshell.api.aggregate.assign_object(small.file, products=[space], relating_object=small.storey)
    wall = add_wall(small, contained=False)
    ifcopenshell.api.spatial.assign_container(small.file, products=[wall], relating_structure=space)
    split = split_and_reopen(small.file, wall, tmp_path)
    copy = split.by_guid(wall.GlobalId)
    assert spatial_guids(copy) == [
        space.GlobalId,
        small.storey.GlobalId,
        small.building.GlobalId,
        small.site.GlobalId,
        small.project.GlobalId,
    ]


def test_split_spatial_containers_keep_their_placement_but_not_their_shape(tmp_path: Path) -> None:
    small = new_model("IFC4")
    terrain = ifcopenshell.api.geometry.add_slab_representation(small.file, context=small.body, depth=1.0)
    ifcopenshell.api.geometry.assign_representation(small.file, product=small.site, representation=terrain)
    ifcopenshell.api.geometry.edit_object_placement(small.file, product=small.site, matrix=translation(10.0))
    wall = add_wall(small, matrix_m=translation(12.0))
    split = split_and_reopen(small.file, wall, tmp_path)
    site = split.by_guid(small.site.GlobalId)
    assert site.Representation is None and site.ObjectPlacement is not None
    np.testing.assert_allclose(
        ifcopenshell.util.placement.get_local_placement(split.by_guid(wall.GlobalId).ObjectPlacement)[:3, 3],
        [12000.0, 0.0, 0.0],
    )


def test_split_keeps_material_psets_styles_and_classification(tmp_path: Path) -> None:
    small = new_model("IFC4")
    wall = add_wall(small)
    material = add_material(small, [wall], "Concrete")
    material_pset = ifcopenshell.api.pset.add_pset(small.file, product=material, name="Pset_MaterialCommon")
    ifcopenshell.api.pset.edit_pset(small.file, pset=material_pset, properties={"MassDensity": 2400.0})
    style = ifcopenshell.api.style.add_style(small.file, name="Grey")
    ifcopenshell.api.style.add_surface_style(
        small.file,
        style=style,
        attributes={"SurfaceColour": {"Name": None, "Red": 0.5, "Green": 0.5, "Blue": 0.5}},
    )
    (body,) = wall.Representation.Representations
    ifcopenshell.api.style.assign_representation_styles(small.file, shape_representation=body, styles=[style])
    classification = ifcopenshell.api.classification.add_classification(small.file, classification="Uniclass")
    ifcopenshell.api.classification.add_reference(
        small.file, products=[wall], identification="EF_25_10", name="Walls", classification=classification
    )
    split = split_and_reopen(small.file, wall, tmp_path)

    copy_material = ifcopenshell.util.element.get_material(split.by_guid(wall.GlobalId))
    assert without_ids(ifcopenshell.util.element.get_psets(copy_material)) == {
        "Pset_MaterialCommon": {"MassDensity": 2400.0}
    }
    assert [s.Name for s in split.by_type("IfcSurfaceStyle")] == ["Grey"]
    assert len(split.by_type("IfcStyledItem")) == 1
    references = ifcopenshell.util.classification.get_references(split.by_guid(wall.GlobalId))
    assert [r.Identification for r in references] == ["EF_25_10"]


def test_split_ifc4x3_model_keeps_schema_identifier_and_volume(tmp_path: Path) -> None:
    small = new_model("IFC4X3")
    beam = add_beam(small, length_m=6.0, width_m=0.3, depth_m=0.5, matrix_m=translation(1.0, 2.0, 3.0))
    add_pset(small, [beam], "Pset_BeamCommon", {"Span": 6.0})
    split = split_and_reopen(small.file, beam, tmp_path)

    assert split.schema_identifier == small.file.schema_identifier == "IFC4X3_ADD2"
    copy = split.by_guid(beam.GlobalId)
    assert volume_m3(world_shape(copy)) == pytest.approx(6.0 * 0.3 * 0.5, rel=1e-6)
    assert without_ids(ifcopenshell.util.element.get_psets(copy)) == {"Pset_BeamCommon": {"Span": 6.0}}


def test_split_header_keeps_authorship_and_names_the_source() -> None:
    if not (SAMPLES_DIR / "acad2010_objects.ifc").is_file():
        pytest.skip(f"{SAMPLES_DIR} is absent")
    model = open_sample("acad2010_objects.ifc")
    element = building_elements(model)[0]
    split = split_element(model, element)  # keep the file referenced while its header is read
    header = split.header
    assert header.file_name.name == f"{element.GlobalId}.ifc"
    assert header.file_name.originating_system == model.header.file_name.originating_system
    assert header.file_name.author == model.header.file_name.author
    assert header.file_name.time_stamp == model.header.file_name.time_stamp
    description = " ".join(header.file_description.description)
    assert re.search(
        rf"bimbot from acad2010_objects\.ifc: {element.is_a()} {re.escape(element.GlobalId)}", description
    )
    assert "ViewDefinition [CoordinationView" in description


@pytest.mark.parametrize("schema", ["IFC2X3", "IFC4", "IFC4X3"])
def test_split_file_reopens_and_reserialises(schema: str, tmp_path: Path) -> None:
    small, wall_1, _ = two_walls(schema)
    add_opening(small, wall_1)
    first, second = tmp_path / "first.ifc", tmp_path / "second.ifc"
    split_element(small.file, wall_1).write(str(first))
    reopened = ifcopenshell.open(str(first))
    reopened.write(str(second))
    again = ifcopenshell.open(str(second))
    assert len(list(again)) == len(list(reopened))
    assert sorted(r.GlobalId for r in again.by_type("IfcRoot")) == sorted(
        r.GlobalId for r in reopened.by_type("IfcRoot")
    )
    data = re.compile(r"DATA;.*ENDSEC;", re.S)
    assert data.search(second.read_text()).group() == data.search(first.read_text()).group()
