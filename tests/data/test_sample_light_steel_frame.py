"""Tests of the bundled sample model generator (light steel frame, paper §5.1) and its CLI."""

from __future__ import annotations

import graphlib
import importlib.resources
import subprocess
import sys
from collections import Counter
from pathlib import Path

import ifcopenshell
import ifcopenshell.geom
import ifcopenshell.util.element
import ifcopenshell.util.placement
import ifcopenshell.util.shape
import ifcopenshell.util.unit
import numpy as np
import pytest
from wall_clock import bound_s

from bimbot.data.light_steel_frame import (
    STEEL_DENSITY_KG_PER_M3,
    build_light_steel_frame,
    parse_bays,
)
from bimbot.shared.identifiers import is_valid_guid

ELEMENT_CLASSES = ("IfcFooting", "IfcColumn", "IfcBeam")


@pytest.fixture(scope="module")
def frame() -> ifcopenshell.file:
    return build_light_steel_frame(3, 3)


def _by_name(model: ifcopenshell.file) -> dict[str, ifcopenshell.entity_instance]:
    return {element.Name: element for element in model.by_type("IfcElement")}


def _counts(model: ifcopenshell.file) -> tuple[int, int, int]:
    return tuple(len(model.by_type(ifc_class)) for ifc_class in ELEMENT_CLASSES)


def _world_bbox_m(element: ifcopenshell.entity_instance) -> tuple[np.ndarray, np.ndarray]:
    settings = ifcopenshell.geom.settings()
    settings.set("use-world-coords", True)
    vertices = ifcopenshell.util.shape.get_vertices(
        ifcopenshell.geom.create_shape(settings, element).geometry
    )
    return vertices.min(axis=0), vertices.max(axis=0)


def _connections(model: ifcopenshell.file) -> set[tuple[str, str]]:
    return {
        (rel.RelatingElement.Name, rel.RelatedElement.Name) for rel in model.by_type("IfcRelConnectsElements")
    }


# --- structure and units ------------------------------------------------------------------------------------


def test_3x3_has_9_footings_9_columns_10_beams_like_the_paper(frame: ifcopenshell.file) -> None:
    assert _counts(frame) == (9, 9, 10)
    assert len(frame.by_type("IfcElement")) == 28


def test_every_element_is_in_the_storey_of_the_building_of_the_site_of_the_project(
    frame: ifcopenshell.file,
) -> None:
    (storey,) = frame.by_type("IfcBuildingStorey")
    (building,) = frame.by_type("IfcBuilding")
    (site,) = frame.by_type("IfcSite")
    (project,) = frame.by_type("IfcProject")
    assert (site.Name, building.Name, storey.Name) == (
        "Greenhouse Site",
        "Light steel frame shelter",
        "Level 0",
    )
    assert ifcopenshell.util.element.get_aggregate(storey) == building
    assert ifcopenshell.util.element.get_aggregate(building) == site
    assert ifcopenshell.util.element.get_aggregate(site) == project
    for element in frame.by_type("IfcElement"):
        assert ifcopenshell.util.element.get_container(element) == storey, element.Name


def test_schema_is_ifc4_and_length_unit_is_millimetre(frame: ifcopenshell.file) -> None:
    assert frame.schema == "IFC4"
    assert ifcopenshell.util.unit.calculate_unit_scale(frame) == pytest.approx(0.001)
    unit_types = {unit.UnitType for unit in frame.by_type("IfcProject")[0].UnitsInContext.Units}
    assert {"AREAUNIT", "VOLUMEUNIT", "MASSUNIT", "MASSDENSITYUNIT"} <= unit_types


@pytest.mark.parametrize(
    ("columns_x", "columns_y", "expected"),
    [
        (1, 1, (1, 1, 0)),
        (2, 1, (2, 2, 1)),
        (1, 3, (3, 3, 2)),  # one end frame only
        (2, 2, (4, 4, 4)),
        (4, 3, (12, 12, 13)),  # 3·3 longitudinal + 2·2 transverse
    ],
)
def test_element_counts_follow_the_grid_formula(columns_x: int, columns_y: int, expected: tuple) -> None:
    assert _counts(build_light_steel_frame(columns_x, columns_y)) == expected


def test_element_names_follow_the_grid_labels(frame: ifcopenshell.file) -> None:
    names = set(_by_name(frame))
    assert {"Footing A1", "Column C3", "Beam A1-A2", "Beam B2-B3", "Beam A1-B1", "Beam B3-C3"} <= names
    assert "Beam A2-B2" not in names  # transverse beams only on the end frames


# --- reproducibility ----------------------------------------------------------------------------------------


def _element_records(model: ifcopenshell.file) -> dict[str, tuple[str, str, np.ndarray]]:
    records = {}
    for element in model.by_type("IfcProduct"):
        matrix = ifcopenshell.util.placement.get_local_placement(element.ObjectPlacement)
        records[element.GlobalId] = (element.is_a(), element.Name, matrix)
    return records


def test_regenerating_gives_the_same_elements_as_the_committed_sample() -> None:
    committed_path = importlib.resources.files("bimbot") / "data" / "light_steel_frame.ifc"
    committed = _element_records(ifcopenshell.open(str(committed_path)))
    regenerated = _element_records(build_light_steel_frame())
    assert committed.keys() == regenerated.keys()
    for guid, (ifc_class, name, matrix) in committed.items():
        assert regenerated[guid][:2] == (ifc_class, name)
        np.testing.assert_allclose(regenerated[guid][2], matrix, atol=1e-6, err_msg=name)


def test_every_global_id_is_valid_unique_and_the_same_on_every_build(frame: ifcopenshell.file) -> None:
    guids = [entity.GlobalId for entity in frame.by_type("IfcRoot")]
    assert all(is_valid_guid(guid) for guid in guids)
    assert len(set(guids)) == len(guids)
    rebuilt = build_light_steel_frame(3, 3)
    assert guids == [entity.GlobalId for entity in rebuilt.by_type("IfcRoot")]


# --- types, materials, quantities ---------------------------------------------------------------------------


def test_occurrences_map_their_type_geometry(frame: ifcopenshell.file) -> None:
    for element in frame.by_type("IfcElement"):
        element_type = ifcopenshell.util.element.get_type(element)
        assert element_type is not None, element.Name
        (representation,) = element.Representation.Representations
        (item,) = representation.Items
        assert item.is_a("IfcMappedItem"), element.Name
        assert item.MappingSource in element_type.RepresentationMaps
    assert (
        len(frame.by_type("IfcTypeProduct")) == 4
    )  # footing, column, two beam lengths (x: to the end faces)


def test_different_spacings_give_one_beam_type_per_span_length() -> None:
    model = build_light_steel_frame(3, 3, spacing_x_mm=4000.0, spacing_y_mm=2500.0)
    lengths = {
        ifcopenshell.util.element.get_psets(beam)["Qto_BeamBaseQuantities"]["Length"]: beam
        for beam in model.by_type("IfcBeam")
    }
    assert set(lengths) == {4050.0, 2500.0}  # beams along x run on to the end columns' outer faces
    assert len(model.by_type("IfcBeamType")) == 2


def _material(element: ifcopenshell.entity_instance) -> ifcopenshell.entity_instance:
    material = ifcopenshell.util.element.get_material(element)
    assert material is not None and material.is_a("IfcMaterial"), element.Name
    return material


def test_steel_has_mass_density_7850_and_concrete_has_none(frame: ifcopenshell.file) -> None:
    for element in frame.by_type("IfcElement"):
        material = _material(element)
        psets = ifcopenshell.util.element.get_psets(material)
        if element.is_a("IfcFooting"):
            assert material.Name == "C30/37 Concrete"
            assert not any("MassDensity" in pset for pset in psets.values())
        else:
            assert (material.Name, material.Category) == ("S235 Steel", "steel")
            assert psets["Pset_MaterialCommon"]["MassDensity"] == pytest.approx(7850.0)


def _weights(element: ifcopenshell.entity_instance) -> list[ifcopenshell.entity_instance]:
    return [
        quantity
        for rel in element.IsDefinedBy
        if rel.is_a("IfcRelDefinesByProperties") and rel.RelatingPropertyDefinition.is_a("IfcElementQuantity")
        for quantity in rel.RelatingPropertyDefinition.Quantities
        if quantity.is_a("IfcQuantityWeight")
    ]


def test_beams_carry_a_net_weight_and_columns_and_footings_do_not(frame: ifcopenshell.file) -> None:
    for element in frame.by_type("IfcElement"):
        weights = _weights(element)
        if element.is_a("IfcBeam"):
            assert [weight.Name for weight in weights] == ["NetWeight"], element.Name
        else:
            assert weights == [], element.Name


def test_beam_net_weight_matches_its_geometry_volume_times_steel_density(frame: ifcopenshell.file) -> None:
    beam = _by_name(frame)["Beam A1-A2"]
    (weight,) = _weights(beam)
    settings = ifcopenshell.geom.settings()
    volume_m3 = ifcopenshell.util.shape.get_volume(ifcopenshell.geom.create_shape(settings, beam).geometry)
    assert weight.WeightValue == pytest.approx(volume_m3 * STEEL_DENSITY_KG_PER_M3, rel=1e-3)
    assert 30.0 < weight.WeightValue < 60.0  # an IPE 160 of 3 m is about 46 kg


# --- connections and schedule -------------------------------------------------------------------------------


def test_each_column_is_connected_to_its_footing(frame: ifcopenshell.file) -> None:
    connections = _connections(frame)
    for column in frame.by_type("IfcColumn"):
        label = column.Name.removeprefix("Column ")
        assert (f"Footing {label}", column.Name) in connections


def test_each_beam_is_connected_to_the_two_columns_at_its_ends(frame: ifcopenshell.file) -> None:
    connections = _connections(frame)
    for beam in frame.by_type("IfcBeam"):
        start, end = beam.Name.removeprefix("Beam ").split("-")
        supports = {relating for relating, related in connections if related == beam.Name}
        assert supports == {f"Column {start}", f"Column {end}"}, beam.Name


def _task_product(task: ifcopenshell.entity_instance) -> ifcopenshell.entity_instance:
    (rel,) = [rel for rel in task.HasAssignments if rel.is_a("IfcRelAssignsToProduct")]
    return rel.RelatingProduct


def test_schedule_has_one_task_per_element_assigned_to_its_product(frame: ifcopenshell.file) -> None:
    (schedule,) = frame.by_type("IfcWorkSchedule")
    assert schedule.Name == "Erection"
    scheduled = [obj for rel in schedule.Controls for obj in rel.RelatedObjects if obj.is_a("IfcTask")]
    assert len(scheduled) == len(frame.by_type("IfcTask"))
    products = Counter(_task_product(task) for task in scheduled)
    assert set(products) == set(frame.by_type("IfcElement"))
    assert set(products.values()) == {1}
    for task in scheduled:
        assert task.Name == f"Erect {_task_product(task).Name}"
        assert task.TaskTime is not None and task.TaskTime.ScheduleDuration


def test_sequence_is_acyclic_and_puts_supports_before_what_they_carry(frame: ifcopenshell.file) -> None:
    sorter: graphlib.TopologicalSorter[str] = graphlib.TopologicalSorter()
    for task in frame.by_type("IfcTask"):
        sorter.add(_task_product(task).Name)
    for rel in frame.by_type("IfcRelSequence"):
        assert rel.SequenceType == "FINISH_START"
        sorter.add(_task_product(rel.RelatedProcess).Name, _task_product(rel.RelatingProcess).Name)
    order = list(sorter.static_order())  # raises graphlib.CycleError on a cycle
    position = {name: index for index, name in enumerate(order)}
    assert len(frame.by_type("IfcRelSequence")) == len(order) - 1  # one chain
    for support, supported in _connections(frame):
        assert position[support] < position[supported], (support, supported)


# --- geometry and poses -------------------------------------------------------------------------------------


def test_column_stands_on_its_footing_with_a_100_mm_section_and_3_m_height(frame: ifcopenshell.file) -> None:
    elements = _by_name(frame)
    low, high = _world_bbox_m(elements["Column B2"])
    np.testing.assert_allclose(low, [2.95, 2.95, 0.0], atol=1e-6)
    np.testing.assert_allclose(high, [3.05, 3.05, 3.0], atol=1e-6)
    low, high = _world_bbox_m(elements["Footing B2"])
    np.testing.assert_allclose(low, [2.7, 2.7, -0.3], atol=1e-6)
    np.testing.assert_allclose(high, [3.3, 3.3, 0.0], atol=1e-6)


def test_beams_along_y_are_rotated_long_in_y_and_rest_on_the_beams_along_x(frame: ifcopenshell.file) -> None:
    beam = _by_name(frame)["Beam A3-B3"]
    matrix = ifcopenshell.util.placement.get_local_placement(beam.ObjectPlacement)
    np.testing.assert_allclose(matrix[:3, 0], [0.0, 1.0, 0.0], atol=1e-9)  # local x along world y
    low, high = _world_bbox_m(beam)
    np.testing.assert_allclose(low, [6.0 - 0.041, 0.0, 3.16], atol=1e-6)  # on the beams along x
    np.testing.assert_allclose(high, [6.0 + 0.041, 3.0, 3.32], atol=1e-6)


def test_beams_along_x_sit_on_the_column_tops_and_run_on_to_the_end_columns_outer_faces(
    frame: ifcopenshell.file,
) -> None:
    """An end frame's beam along y then bears on the beams along x with its whole flange (its axis on
    their end edge, it tipped off in the simulation as soon as it was placed a millimetre outwards)."""
    elements = _by_name(frame)
    low, high = _world_bbox_m(elements["Beam B1-B2"])
    np.testing.assert_allclose(low, [-0.05, 3.0 - 0.041, 3.0], atol=1e-6)  # the outer face of Column B1
    np.testing.assert_allclose(high, [3.0, 3.0 + 0.041, 3.16], atol=1e-6)
    low, high = _world_bbox_m(elements["Beam B2-B3"])
    np.testing.assert_allclose([low[0], high[0]], [3.0, 6.05], atol=1e-6)  # to the outer face of Column B3
    flange_low, flange_high = _world_bbox_m(elements["Beam A1-B1"])
    assert low[2] < flange_low[2] and flange_low[0] > -0.05 and flange_high[0] < 0.05  # whole flange on it


# --- bays parsing and the CLI -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "expected"), [("3x3", (3, 3)), ("4X2", (4, 2)), (" 58x58 ", (58, 58)), ("2×5", (2, 5))]
)
def test_parse_bays_accepts_n_by_m(text: str, expected: tuple[int, int]) -> None:
    assert parse_bays(text) == expected


@pytest.mark.parametrize("text", ["3by3", "3", "0x3", "3x0", "-1x3", "x", "1000x1"])
def test_parse_bays_rejects_anything_else_with_a_clear_message(text: str) -> None:
    with pytest.raises(ValueError, match="bays"):
        parse_bays(text)


def _bimbot(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "bimbot.cli", *args],
        check=False,
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=bound_s(120),
    )


def test_cli_writes_a_frame_that_reopens(tmp_path: Path) -> None:
    result = _bimbot("sample", "light-steel-frame", "-o", "tmp.ifc", "--bays", "2x2", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr
    # what it wrote, on stdout (commands log only warnings unless -v)
    assert result.stdout.startswith("wrote tmp.ifc: light-steel-frame 2x2, 4 footings, 4 columns, 4 beams")
    assert len(result.stdout.splitlines()) == 1
    assert _counts(ifcopenshell.open(str(tmp_path / "tmp.ifc"))) == (4, 4, 4)


@pytest.mark.parametrize("bays", ["0x3", "3by3"])
def test_cli_rejects_bad_bays_with_one_line_and_exit_code_2(tmp_path: Path, bays: str) -> None:
    result = _bimbot("sample", "light-steel-frame", "-o", "tmp.ifc", "--bays", bays, cwd=tmp_path)
    assert result.returncode == 2
    assert "Traceback" not in result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and bays in lines[0], result.stderr
    assert not (tmp_path / "tmp.ifc").exists()
