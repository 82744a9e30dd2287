"""A window filling an opening of a wall is placed after the wall: the converter records the hosting
(IfcRelFillsElement → opening → IfcRelVoidsElement) and the support graph follows it, whatever the heights."""

from __future__ import annotations

from pathlib import Path

import ifcopenshell.api.feature
import ifcopenshell.api.geometry
import ifcopenshell.api.root
from ifc_builders import add_opening, add_wall, new_model, place, translation

from bimbot.services.converter.convert import convert_model
from bimbot.shared.ifc_input import open_model
from bimbot.shared.support_graph import derive_sequence, support_predecessors


def test_a_window_in_a_wall_opening_follows_its_wall(tmp_path: Path) -> None:
    small = new_model()
    wall = add_wall(small, "Wall W", length_m=4.0, height_m=3.0, thickness_m=0.2)
    opening = add_opening(
        small, wall, width_m=1.0, height_m=1.0, depth_m=0.6, matrix_m=translation(1.5, -0.2, 1.0)
    )
    window = ifcopenshell.api.root.create_entity(small.file, ifc_class="IfcWindow", name="Window W1")
    body = ifcopenshell.api.geometry.add_wall_representation(
        small.file, context=small.body, length=1.0, height=1.0, thickness=0.05
    )
    ifcopenshell.api.geometry.assign_representation(small.file, product=window, representation=body)
    place(small, window, translation(1.5, 0.07, 1.0), small.storey)
    ifcopenshell.api.feature.add_filling(small.file, opening=opening, element=window)
    source = tmp_path / "wall_window.ifc"
    small.file.write(str(source))

    manifest = convert_model(open_model(source), source, tmp_path / "build")
    by_name = {component.name: component for component in manifest.components}
    assert set(by_name) == {"Wall W", "Window W1"}  # the opening is never a component
    window_links = {(link.role, link.other_guid) for link in by_name["Window W1"].connections}
    assert ("filling", wall.GlobalId) in window_links
    assert ("host", window.GlobalId) in {
        (link.role, link.other_guid) for link in by_name["Wall W"].connections
    }
    # the window's bottom (1.0 m) is above the wall's, but nothing rests on anything here but for the hosting
    assert support_predecessors(manifest.components)[window.GlobalId] == {wall.GlobalId}
    assert derive_sequence(manifest.components).guids() == [wall.GlobalId, window.GlobalId]
