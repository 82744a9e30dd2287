"""Small fittings drawn as proxies are left out with their reason; light long parts stay."""

from __future__ import annotations

from pathlib import Path

from component_boxes import box_component
from ifc_builders import add_box, new_model
from test_methods import _by_name, _convert

from bimbot.services.converter.small_fittings import small_fitting_reasons


def test_a_handle_is_a_small_fitting_and_a_trim_board_a_panel_or_a_wall_is_not() -> None:
    """The Revit office's 212 handles, 38 g and 15 cm each, were tasks for the carrier and the crane's hook
    (one missed its tolerance three times and failed the run); a trim board or rail is long however light."""
    handle = box_component("handle", (0.15, 0.04, 0.05), (0.0, 0.0, 4.2), mass_kg=0.038)
    trim = box_component("trim", (1.2, 0.02, 0.1), (1.0, 0.0, 0.0), mass_kg=0.3)
    heavy = box_component("block", (0.4, 0.4, 0.4), (3.0, 0.0, 0.0), mass_kg=64.0)
    reasons = small_fitting_reasons([handle, trim, heavy])
    assert list(reasons) == ["handle"]
    assert reasons["handle"].startswith(
        "not a building element (a small fitting): 38 g, 0.15 m at its longest"
    )
    wall = box_component("wall-handle", (0.15, 0.04, 0.05), (5.0, 0.0, 0.0), mass_kg=0.038)
    assert small_fitting_reasons([wall.model_copy(update={"ifc_class": "IfcWall"})]) == {}
    assert small_fitting_reasons([handle]) == {}, "a model of nothing but small parts is converted as it is"


def test_the_converter_leaves_a_handle_out_and_builds_the_cabinet_board_it_is_drawn_on(
    tmp_path: Path,
) -> None:
    small = new_model()
    add_box(
        small,
        "IfcBuildingElementProxy",
        "Handtag skåp",
        size_m=(0.15, 0.03, 0.04),
        corner_m=(0.5, -0.03, 1.0),
    )
    add_box(
        small, "IfcBuildingElementProxy", "Cabinet side", size_m=(0.6, 0.02, 0.9), corner_m=(0.0, 0.0, 0.3)
    )
    manifest = _convert(small, tmp_path)
    assert set(_by_name(manifest)) == {"Cabinet side"}
    [skipped] = [entry for entry in manifest.skipped if entry.name == "Handtag skåp"]
    assert skipped.reason.startswith("not a building element (a small fitting)")
