"""The mass chain: IfcQuantityWeight → vendor weight → mesh volume × density; never zero, source recorded."""

from __future__ import annotations

from pathlib import Path

import ifcopenshell.api.geometry
import ifcopenshell.api.material
import ifcopenshell.api.pset
import ifcopenshell.api.root
import ifcopenshell.api.style
import ifcopenshell.api.unit
import pytest
from ifc_builders import (
    add_beam,
    add_layers,
    add_material,
    add_pset,
    add_qto,
    add_type,
    add_wall,
    new_model,
    place,
    translation,
)

from bimbot.services.converter.mass import DEFAULT_DENSITY_KG_M3, element_mass, material_label
from bimbot.shared.ifc_input import open_model
from bimbot.shared.manifest import MassSource

VOLUME_M3 = 0.4  # a 5 m × 0.2 m × 0.4 m beam


def test_quantity_weight_wins_over_everything_else() -> None:
    small = new_model()
    beam = add_beam(small)
    add_material(small, [beam], "S235 Steel", "steel")
    add_qto(small, beam, "Qto_BeamBaseQuantities", {"NetWeight": 3000.0, "GrossWeight": 3100.0})
    add_pset(small, [beam], "PSet_Revit_Structural", {"Exact Weight": 9.0})
    result = element_mass(beam, VOLUME_M3)
    assert result.source == MassSource.QUANTITY_WEIGHT
    assert result.mass_kg == pytest.approx(3000.0)  # NetWeight before GrossWeight


def test_weight_on_the_type_counts_as_quantity_weight() -> None:
    small = new_model()
    beam = add_beam(small)
    beam_type = add_type(small, [beam], "IfcBeamType", "IPE")
    qto = ifcopenshell.api.pset.add_qto(small.file, product=beam_type, name="Qto_BeamBaseQuantities")
    ifcopenshell.api.pset.edit_qto(small.file, qto=qto, properties={"GrossWeight": 1234.0})
    assert element_mass(beam, VOLUME_M3).mass_kg == pytest.approx(1234.0)


def test_quantity_weight_in_grams_is_converted_to_kilograms() -> None:
    small = new_model()
    grams = ifcopenshell.api.unit.add_si_unit(small.file, unit_type="MASSUNIT")  # gram, no prefix
    ifcopenshell.api.unit.assign_unit(small.file, units=[grams])
    beam = add_beam(small)
    add_qto(small, beam, "Qto_BeamBaseQuantities", {"NetWeight": 2_500_000.0})
    assert element_mass(beam, VOLUME_M3).mass_kg == pytest.approx(2500.0)


def test_vendor_structural_weight_is_second() -> None:
    small = new_model()
    beam = add_beam(small)
    add_material(small, [beam], "Concrete", "concrete")
    add_pset(small, [beam], "Other", {"Weight": 5000.0})
    add_pset(small, [beam], "PSet_Revit_Structural", {"Exact Weight": 2000.0})
    result = element_mass(beam, VOLUME_M3)
    assert result.source == MassSource.VENDOR_PROPERTY
    assert result.mass_kg == pytest.approx(2000.0)  # the Structural set wins over a generic one


def test_implausible_weight_is_reported_and_passed_over() -> None:
    """The paper's converter made a concrete footing of 0.126 kg; bimbot refuses such a weight."""
    small = new_model()
    beam = add_beam(small)
    add_material(small, [beam], "C30/37 Concrete", "concrete")
    add_pset(small, [beam], "PSet_Revit_Structural", {"Exact Weight": 0.126})
    result = element_mass(beam, VOLUME_M3)
    assert result.source == MassSource.MATERIAL_DENSITY_TABLE
    assert result.mass_kg == pytest.approx(VOLUME_M3 * 2400.0)
    assert any("implausible" in warning for warning in result.warnings)


def test_material_density_property_is_used_with_the_mesh_volume() -> None:
    small = new_model()
    beam = add_beam(small)
    material = add_material(small, [beam], "Special alloy", "metal")
    pset = ifcopenshell.api.pset.add_pset(small.file, product=material, name="Pset_MaterialCommon")
    ifcopenshell.api.pset.edit_pset(small.file, pset=pset, properties={"MassDensity": 5000.0})
    result = element_mass(beam, VOLUME_M3)
    assert result.source == MassSource.MATERIAL_DENSITY_PROPERTY
    assert result.mass_kg == pytest.approx(VOLUME_M3 * 5000.0)


@pytest.mark.parametrize(
    ("material", "density"),
    [
        ("S235 Steel", 7850),
        ("Concrete C30/37", 2400),
        ("Glulam timber", 500),
        ("Aluminium 6061", 2700),
        ("Float glass", 2500),
        ("Vidrio", 2500),  # the Revit sample house's glass, in Spanish
        ("Cristal", 2500),
        ("Madera - Castaño", 500),
        ("Hormigón armado", 2400),
        ("Enlucido - Blanco", 900),
        ("Béton C25/30", 2400),
        ("Mauerwerk Ziegel", 1900),
    ],
)
def test_material_table_by_name(material: str, density: float) -> None:
    small = new_model()
    beam = add_beam(small)
    add_material(small, [beam], material, category="")
    result = element_mass(beam, VOLUME_M3)
    assert result.source == MassSource.MATERIAL_DENSITY_TABLE
    assert result.density_kg_m3 == density
    assert result.mass_kg == pytest.approx(VOLUME_M3 * density)


def test_unknown_material_falls_back_to_1000_with_a_warning() -> None:
    small = new_model()
    beam = add_beam(small)
    add_material(small, [beam], "Unobtainium", category="")
    result = element_mass(beam, VOLUME_M3)
    assert result.source == MassSource.DEFAULT_DENSITY
    assert result.mass_kg == pytest.approx(VOLUME_M3 * DEFAULT_DENSITY_KG_M3)
    assert result.warnings and "Unobtainium" in result.warnings[0]


def test_no_material_falls_back_to_1000_and_mass_is_positive() -> None:
    small = new_model()
    beam = add_beam(small)
    result = element_mass(beam, 1e-6)
    assert result.mass_kg > 0
    assert result.source == MassSource.DEFAULT_DENSITY


def test_zero_volume_is_refused() -> None:
    small = new_model()
    with pytest.raises(ValueError, match="positive"):
        element_mass(add_beam(small), 0.0)


def test_material_label_names_the_material() -> None:
    small = new_model()
    beam = add_beam(small)
    add_material(small, [beam], "S235 Steel", "steel")
    assert material_label(beam) == "S235 Steel"


def test_a_conversion_warning_names_the_element_not_only_its_guid(tmp_path: Path) -> None:
    from bimbot.services.converter.convert import convert_model

    small = new_model()
    beam = add_beam(small, "Beam B7")
    add_material(small, [beam], "Unobtainium", category="")
    source = tmp_path / "beam.ifc"
    small.file.write(str(source))
    manifest = convert_model(small.file, source, tmp_path / "out")
    expected = f"IfcBeam 'Beam B7' ({beam.GlobalId}): material 'Unobtainium': density unknown"
    assert any(warning.startswith(expected) for warning in manifest.warnings), manifest.warnings


GYP_M, STUD_M = 0.0159, 0.0921  # 5/8 in. gypsum board, 3-5/8 in. studs


def test_a_stud_partition_weighs_its_layers_not_solid_steel() -> None:
    """Revit's partitions are gypsum board on a "Metal - Stud Layer": the first named density found, steel's,
    used to weigh the whole wall (the Revit restaurant's 4 7/8 in. partitions: 7.5 t panels out of the crane's
    reach); the layers' mean by thickness, the stud layer a framed cavity, is 283 kg/m³."""
    small = new_model()
    wall = add_wall(small, length_m=4.0, height_m=3.0, thickness_m=2 * GYP_M + STUD_M)
    add_layers(small, [wall], [("J_Wall_Gyp", GYP_M), ("Metal - Stud Layer", STUD_M), ("J_Wall_Gyp", GYP_M)])
    volume_m3 = 4.0 * 3.0 * (2 * GYP_M + STUD_M)
    result = element_mass(wall, volume_m3)
    expected_kg_m3 = (2 * GYP_M * 900.0 + STUD_M * 70.0) / (2 * GYP_M + STUD_M)
    assert result.source == MassSource.MATERIAL_DENSITY_TABLE
    assert result.density_kg_m3 == pytest.approx(expected_kg_m3)
    assert result.mass_kg == pytest.approx(volume_m3 * expected_kg_m3)  # 420 kg, not 11.7 t
    assert not result.warnings


def test_furring_spelt_firring_and_a_metal_deck_are_weighed_as_the_air_they_mostly_are() -> None:
    """The WBDG clinic (a public Revit model): its "Insul Panel on Mtl. Stud" walls have a 38 mm "Metal -
    Firring" layer and its standing-seam roofs a 38 mm "Metal - Decking" over bar joists; both were
    weighed as solid steel (75 t walls, 89 t roofs, too heavy for any crane)."""
    small = new_model()
    layers = [("Metal - Firring", 0.038), ("Metal - Stud Layer", 0.152), ("Plasterboard", 0.016)]
    wall = add_wall(small, thickness_m=0.206)
    add_layers(small, [wall], layers)
    furred = element_mass(wall, 1.0)
    assert furred.density_kg_m3 == pytest.approx((0.19 * 70.0 + 0.016 * 900.0) / 0.206)
    roof = add_wall(small, thickness_m=0.33)
    add_layers(
        small,
        [roof],
        [
            ("Roofing - Metal", 0.006),
            ("Metal - Decking", 0.038),
            ("Structure - Steel Bar Joist Layer", 0.286),
        ],
    )
    decked = element_mass(roof, 1.0)
    assert decked.density_kg_m3 == pytest.approx((0.006 * 7850.0 + 0.038 * 260.0 + 0.286 * 70.0) / 0.33)


def test_a_layer_of_unknown_material_counts_at_the_default_density_and_is_named() -> None:
    """The restaurant's compound ceilings: studs and a finish "J_Ceiling_Dark" the table does not know."""
    small = new_model()
    ceiling = add_wall(small, thickness_m=0.054)
    add_layers(small, [ceiling], [("Metal - Stud Layer", 0.038), ("J_Ceiling_Dark", 0.016)])
    result = element_mass(ceiling, 1.0)
    assert result.density_kg_m3 == pytest.approx((0.038 * 70.0 + 0.016 * DEFAULT_DENSITY_KG_M3) / 0.054)
    assert result.source == MassSource.MATERIAL_DENSITY_TABLE  # the studs make most of it
    assert result.warnings and "'J_Ceiling_Dark'" in result.warnings[0]


def test_layers_with_a_density_property_and_an_air_gap() -> None:
    small = new_model()
    wall = add_wall(small, thickness_m=0.35)
    layers = add_layers(small, [wall], [("Brick", 0.1), ("Air gap", 0.05), ("Concrete", 0.2)])
    concrete = layers.MaterialLayers[2].Material
    pset = ifcopenshell.api.pset.add_pset(small.file, product=concrete, name="Pset_MaterialCommon")
    ifcopenshell.api.pset.edit_pset(small.file, pset=pset, properties={"MassDensity": 2300.0})
    result = element_mass(wall, 1.0)
    assert result.density_kg_m3 == pytest.approx((0.1 * 1900.0 + 0.05 * 1.2 + 0.2 * 2300.0) / 0.35)
    assert result.source == MassSource.MATERIAL_DENSITY_PROPERTY  # the concrete makes most of it


def test_a_poured_gypsum_underlayment_has_its_own_density() -> None:
    small = new_model()
    slab = add_wall(small)
    add_layers(small, [slab], [("J_Floor_Gyp_Crete", 0.05)], name="Floor:J_Floor_Concrete_PouredUnderlayment")
    assert element_mass(slab, 1.0).density_kg_m3 == pytest.approx(1650.0)


def _box_faces(low: tuple[float, float, float], high: tuple[float, float, float]) -> tuple[list, list]:
    (x0, y0, z0), (x1, y1, z1) = low, high
    vertices = [(x, y, z) for z in (z0, z1) for (x, y) in ((x0, y0), (x1, y0), (x1, y1), (x0, y1))]
    faces = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
    return vertices, faces


@pytest.mark.parametrize("schema", ["IFC2X3", "IFC4"])
def test_a_window_of_listed_materials_weighs_each_body_with_the_material_its_faces_are_styled_as(
    schema: str, tmp_path: Path
) -> None:
    """The Revit house's windows list glass, wood and stone with no shares: all was weighed as glass, the
    first, 2,500 kg/m³ (535 kg a window of mostly wood); each body now weighs with the material whose style
    its faces carry: a 0.02 m³ pane of glass and a 0.02 m³ wooden rail, 50 + 10 kg, not 100."""
    from bimbot.services.converter.convert import ConvertOptions, convert_model

    small = new_model(schema)
    file = small.file
    pane, rail = _box_faces((0.0, 0.0, 0.2), (1.0, 0.02, 1.2)), _box_faces((0.0, 0.0, 0.0), (1.0, 0.1, 0.2))
    window = ifcopenshell.api.root.create_entity(file, ifc_class="IfcWindow", name="Window")
    body = ifcopenshell.api.geometry.add_mesh_representation(
        file, context=small.body, vertices=[pane[0], rail[0]], faces=[pane[1], rail[1]]
    )
    ifcopenshell.api.geometry.assign_representation(file, product=window, representation=body)
    place(small, window, translation(), small.storey)
    listed = ifcopenshell.api.material.add_material_set(file, name="Window", set_type="IfcMaterialList")
    styles = []
    for name in ("Float glass", "Oak wood"):
        material = ifcopenshell.api.material.add_material(file, name=name)
        ifcopenshell.api.material.add_list_item(file, material_list=listed, material=material)
        style = ifcopenshell.api.style.add_style(file, name=name)
        grey = {"SurfaceColour": {"Name": None, "Red": 0.5, "Green": 0.5, "Blue": 0.5}}
        ifcopenshell.api.style.add_surface_style(file, style=style, attributes=grey)
        ifcopenshell.api.style.assign_material_style(
            file,
            material=material,
            style=style,
            context=small.body,
            should_use_presentation_style_assignment=schema == "IFC2X3",
        )
        styles.append(style)
    ifcopenshell.api.material.assign_material(
        file, products=[window], type="IfcMaterialList", material=listed
    )
    ifcopenshell.api.style.assign_representation_styles(
        file,
        shape_representation=body,
        styles=styles,
        should_use_presentation_style_assignment=schema == "IFC2X3",
    )
    source = tmp_path / "window.ifc"
    file.write(str(source))
    manifest = convert_model(
        open_model(source), source, tmp_path / "out", ConvertOptions(formats=(), split_ifc=False)
    )
    (converted,) = manifest.components
    assert converted.volume_m3 == pytest.approx(0.04)
    assert converted.mass_kg == pytest.approx(0.02 * 2500.0 + 0.02 * 500.0)


@pytest.mark.parametrize(
    ("ifc_class", "predefined", "density"),
    [
        ("IfcSlab", "FLOOR", 2400.0),  # a floor slab is concrete on a site
        ("IfcFooting", "PAD_FOOTING", 2400.0),
        ("IfcSlab", "ROOF", DEFAULT_DENSITY_KG_M3),  # a roof may be timber or metal deck
        ("IfcWall", None, DEFAULT_DENSITY_KG_M3),  # masonry, studs or concrete: nothing to assume
    ],
)
def test_unknown_material_of_a_class_that_is_concrete_is_weighed_as_concrete(
    ifc_class: str, predefined: str | None, density: float
) -> None:
    """The Revit house's 30 cm floors name only "Suelos por defecto": weighed as water they were 37.5 t,
    as concrete 90 t, which changes how a site builds them (cast, not lifted in planks)."""
    small = new_model()
    element = ifcopenshell.api.root.create_entity(small.file, ifc_class=ifc_class, predefined_type=predefined)
    add_material(small, [element], "Suelos por defecto", category="")
    result = element_mass(element, VOLUME_M3)
    assert result.source == MassSource.DEFAULT_DENSITY
    assert result.mass_kg == pytest.approx(VOLUME_M3 * density)
    (warning,) = result.warnings
    assert "Suelos por defecto" in warning and "density unknown" in warning
    assert (f"an {ifc_class} is taken for concrete, 2400 kg/m³" in warning) == (density == 2400.0)


@pytest.mark.parametrize(
    ("profile_class", "density"),
    [
        ("IfcCircleHollowProfileDef", 7850.0),
        ("IfcIShapeProfileDef", 7850.0),
        ("IfcRectangleProfileDef", 1000.0),
    ],
)
def test_a_member_of_unknown_material_drawn_with_a_steel_section_is_weighed_as_steel(
    profile_class: str, density: float
) -> None:
    """The Revit 2025 structural sample's HSS 114 tubes name their material "<Unnamed>": weighed as water a
    4.6 m tube was 13.8 kg, an eighth of its weight. A hollow or I section is a rolled steel profile; a
    rectangle says nothing (timber, concrete)."""
    small = new_model()
    f = small.file
    member = ifcopenshell.api.root.create_entity(f, ifc_class="IfcMember")
    add_material(small, [member], "<Unnamed>", category="")
    profile = {
        "IfcCircleHollowProfileDef": lambda: f.createIfcCircleHollowProfileDef(
            "AREA", None, None, 0.057, 0.0086
        ),
        "IfcIShapeProfileDef": lambda: f.createIfcIShapeProfileDef(
            "AREA", None, None, 0.165, 0.303, 0.006, 0.01
        ),
        "IfcRectangleProfileDef": lambda: f.createIfcRectangleProfileDef("AREA", None, None, 0.1, 0.2),
    }[profile_class]()
    solid = f.createIfcExtrudedAreaSolid(profile, None, f.createIfcDirection((0.0, 0.0, 1.0)), 4.6)
    body = f.createIfcShapeRepresentation(small.body, "Body", "SweptSolid", [solid])
    member.Representation = f.createIfcProductDefinitionShape(None, None, [body])
    result = element_mass(member, VOLUME_M3)
    assert result.mass_kg == pytest.approx(VOLUME_M3 * density)
    (warning,) = result.warnings
    assert ("taken for steel" in warning) == (density == 7850.0)
