"""The generated site model (tests/site_models.py) converts with the classes, masses, skipped list and
sequence the integration tests rely on, in IFC2X3, IFC4 and IFC4X3."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from site_models import (
    HEAVY_MASS_KG,
    HEAVY_NAME,
    ROOM_CENTRE_M,
    ROOM_WALLS,
    WALLS_FIRST_ORDER,
    build_site_model,
    construction_order,
    expected_masses_kg,
)

from bimbot.services.converter.convert import ConvertOptions, convert_model
from bimbot.shared.ifc_input import open_model
from bimbot.shared.manifest import Component, Manifest, MassSource
from bimbot.shared.methods_file import load_methods
from bimbot.shared.reasons import ReasonCode
from bimbot.shared.robot_description import DEFAULT_ROBOT
from bimbot.shared.sequence import read_sequence
from bimbot.shared.support_graph import support_predecessors

LIFTED = load_methods("lifted")


def _convert(tmp_path: Path, options: ConvertOptions | None = None, **model_options: object) -> Manifest:
    """The site model converted with the paper's ``lifted`` methods, as the integration tests build it: its
    heavy part stays one component too heavy to lift (the default methods would cast or panelise it)."""
    source = build_site_model(**model_options).write(tmp_path / "site.ifc")  # type: ignore[arg-type]
    chosen = options or ConvertOptions(methods=LIFTED)
    return convert_model(open_model(source), source, tmp_path / "out", chosen)


def _by_name(manifest: Manifest) -> dict[str, Component]:
    return {component.name: component for component in manifest.components if component.name}


@pytest.mark.parametrize("schema", ["IFC2X3", "IFC4", "IFC4X3"])
def test_site_model_converts_with_its_classes_masses_and_the_table_skipped(
    schema: str, tmp_path: Path
) -> None:
    manifest = _convert(tmp_path, schema=schema)
    components = _by_name(manifest)
    assert {name: c.ifc_class for name, c in components.items()} == {
        "Footing A1": "IfcFooting",
        "Column A1": "IfcColumn",
        "Column A2": "IfcColumn",
        "Beam A1-A2": "IfcBeam",
        "Column R1": "IfcColumn",
        **dict.fromkeys(ROOM_WALLS, "IfcWall"),
    }
    masses = expected_masses_kg()
    for name, component in components.items():
        assert component.mass_kg == pytest.approx(masses[name], rel=1e-6), name
        assert component.mass_source == MassSource.MATERIAL_DENSITY_PROPERTY
    (table,) = manifest.skipped
    assert table.name == "Table R1" and table.ifc_class in ("IfcFurnishingElement", "IfcFurniture")
    assert table.reason.startswith("not a building element (IfcFurnishingElement)")
    assert manifest.warnings == []


def test_only_the_heavy_part_is_beyond_the_default_robot_payload(tmp_path: Path) -> None:
    for heavy in ("footing", "slab"):
        components = _by_name(_convert(tmp_path / heavy, heavy=heavy))
        heavy_one = components[HEAVY_NAME[heavy]]
        assert heavy_one.mass_kg == pytest.approx(HEAVY_MASS_KG[heavy]) and heavy_one.mass_kg > 5000.0
        refusal = DEFAULT_ROBOT.refusal(heavy_one.mass_kg, heavy_one.bbox_world.max_m[2])
        assert refusal is not None and refusal.code == ReasonCode.TOO_HEAVY
        for name, component in components.items():
            if name != HEAVY_NAME[heavy]:
                assert DEFAULT_ROBOT.refusal(component.mass_kg, component.bbox_world.max_m[2]) is None, name


def test_the_heavy_footing_carries_column_a1_and_the_heavy_slab_carries_nothing(tmp_path: Path) -> None:
    footing = _convert(tmp_path / "f")
    guid = {c.name: c.guid for c in footing.components}
    predecessors = support_predecessors(footing.components)
    assert guid["Footing A1"] in predecessors[guid["Column A1"]]
    assert predecessors[guid["Beam A1-A2"]] >= {guid["Column A1"], guid["Column A2"]}
    slab = _convert(tmp_path / "s", heavy="slab")
    guid = {c.name: c.guid for c in slab.components}
    predecessors = support_predecessors(slab.components)
    assert not any(guid["Slab H1"] in preds for preds in predecessors.values())
    assert len(_convert(tmp_path / "n", heavy=None, room=False).components) == 3


def test_the_four_walls_cut_the_room_column_off_from_the_default_robot(tmp_path: Path) -> None:
    components = _by_name(_convert(tmp_path))
    column = components["Column R1"]
    low = np.min([components[name].bbox_world.min_m for name in ROOM_WALLS], axis=0)
    high = np.max([components[name].bbox_world.max_m for name in ROOM_WALLS], axis=0)
    assert np.all(low[:2] < column.bbox_world.min_m[:2]) and np.all(column.bbox_world.max_m[:2] < high[:2])
    assert np.mean([low[:2], high[:2]], axis=0) == pytest.approx(ROOM_CENTRE_M)
    # the walls close the ring: each corner is covered by two walls, no gap on any side
    rects = [(components[n].bbox_world.min_m[:2], components[n].bbox_world.max_m[:2]) for n in ROOM_WALLS]
    for x, y in [(low[0] + 0.05, low[1] + 0.05), (high[0] - 0.05, high[1] - 0.05), (low[0] + 0.05, 0.0)]:
        assert any(r[0][0] <= x <= r[1][0] and r[0][1] <= y <= r[1][1] for r in rects), (x, y)
    # a robot outside the walls stands at least its radius beyond them: too far to reach the column
    nearest_outside = (high[0] - low[0]) / 2 + DEFAULT_ROBOT.radius_m
    column_half = (column.bbox_world.max_m[0] - column.bbox_world.min_m[0]) / 2
    assert nearest_outside - column_half > DEFAULT_ROBOT.reach_m
    assert components["Column R1"].bbox_world.max_m[2] <= components["Wall R-S"].bbox_world.max_m[2] + 1e-9


@pytest.mark.parametrize("schema", ["IFC2X3", "IFC4"])
def test_a_schedule_gives_the_sequence_a_bad_order_included(schema: str, tmp_path: Path) -> None:
    manifest = _convert(tmp_path, schema=schema, schedule=WALLS_FIRST_ORDER)
    assert manifest.sequence_source == "ifc_schedule"
    names = {c.guid: c.name for c in manifest.components}
    sequence = read_sequence(tmp_path / "out" / manifest.sequence_file)
    assert [names[task.guid] for task in sequence.tasks] == list(WALLS_FIRST_ORDER)
    assert WALLS_FIRST_ORDER.index("Column R1") > max(WALLS_FIRST_ORDER.index(w) for w in ROOM_WALLS)
    assert construction_order().index("Column R1") < min(construction_order().index(w) for w in ROOM_WALLS)


def test_include_furniture_builds_the_table_and_guids_are_stable(tmp_path: Path) -> None:
    manifest = _convert(tmp_path, ConvertOptions(include=("IfcFurnishingElement",), methods=LIFTED))
    assert "Table R1" in _by_name(manifest) and manifest.skipped == []
    assert build_site_model().guid("Column R1") == build_site_model(heavy="slab").guid("Column R1")


def test_a_schedule_naming_an_absent_element_is_refused() -> None:
    with pytest.raises(ValueError, match="Slab H1"):
        build_site_model(heavy="footing", schedule=construction_order(heavy="slab"))
