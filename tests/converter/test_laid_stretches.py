"""A laid wall longer than a block layer covers from one set-up is laid in stretches, one from each."""

from __future__ import annotations

from pathlib import Path

from ifc_builders import add_box, add_material, add_opening, new_model, translation

from bimbot.services.converter.convert import ConvertOptions, convert_model
from bimbot.services.converter.summary_line import elements_summary
from bimbot.shared.construction_methods import ConstructionMethod
from bimbot.shared.fleet import default_fleet
from bimbot.shared.ifc_input import open_model
from bimbot.shared.methods_file import load_methods


def test_a_brick_wall_longer_than_half_the_block_layers_reach_is_laid_in_stretches(tmp_path: Path) -> None:
    """The Revit office's "MockUp Exterior Ground Floor" walls (engineering brick, 630 mm, 32 and 50 m
    along a return) were laid whole: from none of its block layer's set-ups did the 32 m boom cover the
    whole wall, and 1,264 components resting on them were never built. The default block layer reaches
    32 m: a 40 m wall is laid in three stretches of at most 16 m, a 12 m wall whole."""
    small = new_model()
    long = add_box(small, "IfcWall", "long brick wall", size_m=(40.0, 0.3, 3.0))
    short = add_box(small, "IfcWall", "short brick wall", size_m=(12.0, 0.3, 3.0), corner_m=(0.0, 5.0, 0.0))
    add_material(small, [long, short], "Brick, Common", category="brick")
    # a window near one end: the stretches' volumes differ, their lengths do not (cut across the
    # thickness instead, each would have run the wall's whole length)
    add_opening(small, long, width_m=2.0, height_m=1.2, depth_m=0.6, matrix_m=translation(3.0, -0.15, 1.0))
    source = tmp_path / "model.ifc"
    small.file.write(str(source))
    options = ConvertOptions(
        methods=load_methods("conventional"), fleet=default_fleet(), formats=(), split_ifc=False
    )
    manifest = convert_model(open_model(source), source, tmp_path / "out", options)
    by_name = {str(c.name): c for c in manifest.components}
    assert by_name["short brick wall"].method is ConstructionMethod.LAID
    stretches = [c for name, c in by_name.items() if name.startswith("long brick wall stretch ")]
    assert len(stretches) == 3 and {c.method for c in stretches} == {ConstructionMethod.LAID}
    assert {c.parent_guid for c in stretches} == {long.GlobalId}
    for stretch in stretches:
        low, high = stretch.bbox_world.min_m, stretch.bbox_world.max_m
        assert high[0] - low[0] <= 16.0 + 1e-6 and abs(high[2] - low[2] - 3.0) < 1e-6
    assert "40.0 m long, more than a block layer lays from one set-up (16.0 m, half its boom's reach)" in (
        stretches[0].method_note
    )
    (entry,) = manifest.panelised
    assert entry.method is ConstructionMethod.LAID and len(entry.joints) == 2
    assert abs(sum(c.mass_kg for c in stretches) - entry.mass_kg) < 1e-6 * entry.mass_kg
    assert len({round(c.volume_m3 or 0.0, 3) for c in stretches}) > 1, "the window's stretch is lighter"
    assert "1 laid in 3 stretches" in elements_summary(manifest)
