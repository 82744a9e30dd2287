"""The mass chain: IfcQuantityWeight → vendor weight → mesh volume × density; never zero, source recorded."""

from __future__ import annotations

from pathlib import Path

import ifcopenshell.api.pset
import ifcopenshell.api.unit
import pytest
from ifc_builders import add_beam, add_material, add_pset, add_qto, add_type, new_model

from bimbot.services.converter.mass import DEFAULT_DENSITY_KG_M3, element_mass, material_label
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
