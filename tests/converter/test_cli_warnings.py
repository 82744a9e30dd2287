"""Which converter warnings reach the terminal: those that change the build first."""

from __future__ import annotations

from bimbot.services.converter.cli import warnings_to_show


def test_warnings_that_change_masses_or_clashes_come_before_geometry_notes() -> None:
    notes = [f"IfcMember 'M{i}': profile decomposition not used: body item IfcFacetedBrep" for i in range(12)]
    density = "IfcSlab 'Suelo': material 'Suelos por defecto': density unknown, using 1000 kg/m³"
    clash = "IfcWall 'W' and IfcDoor 'D' overlap 40 mm: a clash in the IFC"
    shown = warnings_to_show([*notes, density, clash], limit=10)
    assert shown[:2] == [density, clash]
    assert shown[2:] == notes[:8]  # the rest in the manifest's order
    assert warnings_to_show(notes, limit=3) == notes[:3]
