"""Bolts, anchors and shop-welded plates are built with their hosts (``with_host``): found through the IFC
relations or by geometry, their parts and mass in the host's body, and no component of their own."""

from __future__ import annotations

from pathlib import Path

import ifcopenshell.api.aggregate
import ifcopenshell.guid
import pytest
from ifc_builders import SmallModel, add_assembly, add_box, add_material, new_model
from lxml import etree

from bimbot.services.converter.convert import ConvertOptions, convert_model
from bimbot.shared.construction_methods import ConstructionMethod, MethodSource
from bimbot.shared.ifc_input import open_model
from bimbot.shared.manifest import MAX_COLLISION_PARTS, Manifest
from bimbot.shared.sequence import read_sequence

STEEL_KG_M3, CONCRETE_KG_M3 = 7850.0, 2400.0


def _column_on_a_footing(*, anchor_related: bool) -> tuple[SmallModel, dict[str, object]]:
    """A concrete footing in the ground, a steel column on a base plate on it, and an anchor bolt cast
    into the footing through the plate (related to footing and column by the connection it realises)."""
    small = new_model()
    footing = add_box(small, "IfcFooting", "Footing", size_m=(1.0, 1.0, 0.5), corner_m=(-0.5, -0.5, -0.5))
    plate = add_box(small, "IfcPlate", "Base plate", size_m=(0.4, 0.4, 0.02), corner_m=(-0.2, -0.2, 0.0))
    column = add_box(small, "IfcColumn", "Column", size_m=(0.2, 0.2, 3.0), corner_m=(-0.1, -0.1, 0.02))
    bolt = add_box(
        small,
        "IfcMechanicalFastener",
        "Anchor bolt",
        size_m=(0.03, 0.03, 0.45),
        corner_m=(0.12, 0.12, -0.4),
        predefined_type="ANCHORBOLT",
    )
    add_material(small, [footing], "Concrete")
    add_material(small, [plate, column, bolt], "S355 steel", category="steel")
    if anchor_related:
        small.file.create_entity(
            "IfcRelConnectsWithRealizingElements",
            GlobalId=ifcopenshell.guid.new(),
            RelatingElement=footing,
            RelatedElement=column,
            RealizingElements=[bolt],
        )
    return small, {"footing": footing, "plate": plate, "column": column, "bolt": bolt}


def _convert(small: SmallModel, tmp_path: Path, **options: object) -> Manifest:
    source = tmp_path / "model.ifc"
    small.file.write(str(source))
    chosen = ConvertOptions(formats=("obj",), split_ifc=False, **options)  # type: ignore[arg-type]
    return convert_model(open_model(source), source, tmp_path / "out", chosen)


def test_an_anchor_bolt_goes_in_its_footing_and_a_base_plate_with_its_column(tmp_path: Path) -> None:
    small, made = _column_on_a_footing(anchor_related=True)
    manifest = _convert(small, tmp_path)
    by_name = {c.name: c for c in manifest.components}
    assert set(by_name) == {"Footing", "Column"}  # the guests are components no more
    footing, column = by_name["Footing"], by_name["Column"]
    # the anchor: named by the connection it realises, and embedded in the footing (not the steel column)
    assert [(g.name, g.relation) for g in footing.guests] == [
        ("Anchor bolt", "IfcRelConnectsWithRealizingElements")
    ]
    # the base plate: no relation; it touches the column and the footing, and goes with the steel
    assert [(g.name, g.relation) for g in column.guests] == [("Base plate", "contact")]
    assert footing.method is ConstructionMethod.CAST_IN_PLACE and column.method is ConstructionMethod.LIFTED

    plate_kg = 0.4 * 0.4 * 0.02 * STEEL_KG_M3
    column_kg = 0.2 * 0.2 * 3.0 * STEEL_KG_M3
    assert column.guests[0].mass_kg == pytest.approx(plate_kg)
    assert column.mass_kg == pytest.approx(column_kg + plate_kg)
    assert footing.mass_kg == pytest.approx(0.5 * CONCRETE_KG_M3 + 0.03 * 0.03 * 0.45 * STEEL_KG_M3)
    # the combined centre of mass, in the column's frame (its corner at the origin): the plate pulls it down
    expected_z = (column_kg * 1.5 + plate_kg * -0.01) / (column_kg + plate_kg)
    assert column.com_local_m[2] == pytest.approx(expected_z)
    # parallel axes: about the common centre, x-axis inertia of a 3 m bar and a plate 1.5 m below its centre
    bar = column_kg * (0.2**2 + 3.0**2) / 12 + column_kg * (1.5 - expected_z) ** 2
    sheet = plate_kg * (0.4**2 + 0.02**2) / 12 + plate_kg * (-0.01 - expected_z) ** 2
    assert column.inertia_kg_m2.ixx == pytest.approx(bar + sheet, rel=1e-6)
    assert column.bbox_world.min_m[2] == pytest.approx(0.0) and column.bbox_local.min_m[0] == pytest.approx(
        -0.1
    )
    # its body collides with the plate too, and its model file says so
    assert column.collision_parts == len(column.files.collision) == 2
    sdf = etree.parse(str(tmp_path / "out" / column.files.sdf_file))
    assert float(sdf.findtext(".//inertial/mass")) == pytest.approx(column.mass_kg)
    assert len(sdf.findall(".//collision")) == 2
    # the guest's visual stays in its own folder for a viewer, placed in the host's frame
    plate = column.guests[0]
    assert (tmp_path / "out" / plate.visual_obj).is_file()
    assert plate.position_in_host_m == pytest.approx((-0.1, -0.1, -0.02))
    # nothing else expects the guests: the world, the sequence
    world = (tmp_path / "out" / manifest.world_file).read_text()
    assert made["bolt"].GlobalId not in world and made["plate"].GlobalId not in world  # type: ignore[attr-defined]
    sequence = read_sequence(tmp_path / "out" / manifest.sequence_file)
    assert sorted(sequence.guids()) == sorted(c.guid for c in manifest.components)


def test_a_plate_aggregated_into_its_column_is_its_guest_and_the_column_is_still_built(
    tmp_path: Path,
) -> None:
    small, made = _column_on_a_footing(anchor_related=False)
    ifcopenshell.api.aggregate.assign_object(
        small.file,
        products=[made["plate"]],
        relating_object=made["column"],  # type: ignore[list-item]
    )
    manifest = _convert(small, tmp_path)
    column = next(c for c in manifest.components if c.name == "Column")
    assert [(g.name, g.relation) for g in column.guests] == [("Base plate", "IfcRelAggregates")]
    # no relation for the anchor here: found by geometry, embedded in the footing
    footing = next(c for c in manifest.components if c.name == "Footing")
    assert [(g.name, g.relation) for g in footing.guests] == [("Anchor bolt", "embedded")]


def test_a_plate_of_a_shop_assembly_goes_with_its_main_member_which_is_lifted(tmp_path: Path) -> None:
    small = new_model()
    beam = add_box(
        small, "IfcBeam", "Beam", size_m=(4.0, 0.2, 0.3), corner_m=(0.0, 0.0, 3.0), contained=False
    )
    plate = add_box(
        small, "IfcPlate", "End plate", size_m=(0.02, 0.3, 0.4), corner_m=(4.0, -0.05, 2.95), contained=False
    )
    add_material(small, [beam, plate], "Steel", category="steel")
    add_assembly(small, [beam, plate], "Frame girder")
    manifest = _convert(small, tmp_path)
    (girder,) = manifest.components
    assert (girder.name, girder.method, girder.method_source) == (
        "Beam",
        ConstructionMethod.LIFTED,
        MethodSource.IFC,
    )
    assert girder.method_note.startswith(
        "a part of the prefabricated assembly IfcElementAssembly 'Frame girder'"
    )
    assert [(g.name, g.relation) for g in girder.guests] == [("End plate", "IfcRelAggregates")]


def test_a_guest_whose_host_is_not_built_stays_a_lifted_component_with_a_warning(tmp_path: Path) -> None:
    small, _ = _column_on_a_footing(anchor_related=True)
    manifest = _convert(small, tmp_path, exclude=("IfcFooting", "IfcColumn", "IfcPlate"))
    (bolt,) = manifest.components
    assert (bolt.method, bolt.method_source) == (ConstructionMethod.LIFTED, MethodSource.RULE)
    assert "no host" in bolt.method_note
    assert any("built with its host, but" in warning for warning in manifest.warnings)


def test_many_guests_keep_the_host_within_the_collision_part_limit(tmp_path: Path) -> None:
    small = new_model()
    beam = add_box(small, "IfcBeam", "Beam", size_m=(6.0, 0.2, 0.4), corner_m=(0.0, 0.0, 3.0))
    bolts = [
        add_box(
            small, "IfcFastener", f"Bolt {i}", size_m=(0.02, 0.3, 0.02), corner_m=(0.3 * i + 0.1, -0.05, 3.2)
        )
        for i in range(18)
    ]
    add_material(small, [beam, *bolts], "Steel", category="steel")
    manifest = _convert(small, tmp_path)
    (host,) = manifest.components
    assert len(host.guests) == 18 and {g.relation for g in host.guests} == {"embedded"}
    assert host.collision_parts == len(host.files.collision) <= MAX_COLLISION_PARTS
    assert host.mass_kg == pytest.approx(6.0 * 0.2 * 0.4 * 7850 + 18 * 0.02 * 0.3 * 0.02 * 7850)
