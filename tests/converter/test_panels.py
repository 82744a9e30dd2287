"""Panelised elements in a conversion: each panel a valid component of its own, the element listed with its
panels and joints, the windows and the slab's planks after the wall panels that carry them."""

from __future__ import annotations

import itertools
from pathlib import Path

import ifcopenshell.api.feature
import ifcopenshell.api.geometry
import ifcopenshell.api.pset
import ifcopenshell.api.root
import numpy as np
import pybullet
import pytest
from ifc_builders import (
    SmallModel,
    add_beam,
    add_material,
    add_opening,
    add_wall,
    new_model,
    place,
    translation,
)
from sdf_checks import sdf_check_files

from bimbot.services.converter.convert import ConvertOptions, convert_model
from bimbot.services.converter.final_method import default_limits
from bimbot.services.converter.panel_writer import not_panelised, panel_guid
from bimbot.shared.construction_methods import ConstructionMethod, MethodDecision, MethodSource
from bimbot.shared.identifiers import guid_to_folder, is_valid_guid
from bimbot.shared.ifc_input import open_model
from bimbot.shared.manifest import Component, Manifest
from bimbot.shared.methods_file import load_methods
from bimbot.shared.sequence import check_sequence, read_sequence
from bimbot.shared.site_layout import plan_site
from bimbot.shared.support_graph import support_predecessors, support_violations

WALL_M = (16.9, 3.0, 0.2)  # length, height, thickness
WINDOWS_X = ((5.0, 6.5), (10.8, 12.3))  # where the equal thirds' cuts (5.63 m, 11.27 m) would fall
SPAN_M = 7.4
PANELISED = MethodDecision(
    method=ConstructionMethod.PANELISED, source=MethodSource.USER, note="precast, as the user asked"
)


def _window(small: SmallModel, wall, x0: float, name: str):
    opening = add_opening(
        small, wall, width_m=1.5, height_m=1.2, depth_m=0.6, matrix_m=translation(x0, -0.2, 0.9)
    )
    window = ifcopenshell.api.root.create_entity(small.file, ifc_class="IfcWindow", name=name)
    body = ifcopenshell.api.geometry.add_wall_representation(
        small.file, context=small.body, length=1.5, height=1.2, thickness=0.05
    )
    ifcopenshell.api.geometry.assign_representation(small.file, product=window, representation=body)
    place(small, window, translation(x0, 0.07, 0.9), small.storey)
    ifcopenshell.api.feature.add_filling(small.file, opening=opening, element=window)
    return window


def _house(path: Path) -> dict[str, str]:
    """Two 16.9 m walls 7.4 m apart (one with two windows), a 0.3 m slab on them, a column beside."""
    small = new_model()
    length, height, thickness = WALL_M
    front = add_wall(small, "Front", length_m=length, height_m=height, thickness_m=thickness)
    back = add_wall(
        small,
        "Back",
        length_m=length,
        height_m=height,
        thickness_m=thickness,
        matrix_m=translation(0, 7.2, 0),
    )
    windows = [_window(small, front, x0, f"Window {i}") for i, (x0, _) in enumerate(WINDOWS_X, 1)]
    slab = ifcopenshell.api.root.create_entity(small.file, ifc_class="IfcSlab", name="Roof")
    body = ifcopenshell.api.geometry.add_wall_representation(
        small.file, context=small.body, length=length, height=0.3, thickness=SPAN_M
    )
    ifcopenshell.api.geometry.assign_representation(small.file, product=slab, representation=body)
    place(small, slab, translation(0, 0, height), small.storey)
    # a light precast floor (1,000 kg/m³ by its material's property): 37.5 t
    floor = add_material(small, [slab], "Precast floor", category="")
    pset = ifcopenshell.api.pset.add_pset(small.file, product=floor, name="Pset_MaterialCommon")
    ifcopenshell.api.pset.edit_pset(small.file, pset=pset, properties={"MassDensity": 1000.0})
    column = add_beam(small, "Column", length_m=3.0, matrix_m=translation(20, 0, 0), schema_class="IfcColumn")
    small.file.write(str(path))
    guids = {"front": front, "back": back, "slab": slab, "column": column, "w1": windows[0], "w2": windows[1]}
    return {key: str(element.GlobalId) for key, element in guids.items()}


@pytest.fixture(scope="module")
def build(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Manifest, dict[str, str]]:
    out = tmp_path_factory.mktemp("panels")
    source = out / "house.ifc"
    guids = _house(source)
    decisions = {guids[key]: PANELISED for key in ("front", "back", "slab", "column")}
    manifest = convert_model(open_model(source), source, out / "build", ConvertOptions(decisions=decisions))
    return out / "build", manifest, guids


def _panels(manifest: Manifest, parent: str) -> list[Component]:
    return [c for c in manifest.components if c.parent_guid == parent]


def _span(component: Component, axis: int) -> tuple[float, float]:
    return component.bbox_world.min_m[axis], component.bbox_world.max_m[axis]


def test_a_panelised_element_becomes_its_panels(build: tuple[Path, Manifest, dict[str, str]]) -> None:
    _, manifest, guids = build
    parents = {entry.guid: entry for entry in manifest.panelised}
    assert set(parents) == {guids["front"], guids["back"], guids["slab"]}
    in_manifest = {c.guid for c in manifest.components}
    assert not in_manifest & set(parents)  # the element is no component itself
    all_panels = [c for c in manifest.components if c.parent_guid]
    assert len({c.guid for c in all_panels}) == len(all_panels)
    for parent, entry in parents.items():
        panels = _panels(manifest, parent)
        assert [c.guid for c in panels] == list(entry.panel_guids)
        assert [c.guid for c in panels] == [panel_guid(parent, i) for i in range(len(panels))]
        assert all(is_valid_guid(c.guid) and c.folder == guid_to_folder(c.guid) for c in panels)
        assert [c.name for c in panels] == [
            f"{entry.name} panel {i}/{len(panels)}" for i in range(1, len(panels) + 1)
        ]
        assert {(c.ifc_class, c.method, c.method_source, c.files.split_ifc) for c in panels} == {
            (entry.ifc_class, ConstructionMethod.PANELISED, MethodSource.USER, "")
        }
        assert all(c.method_note == entry.why for c in panels)
        assert sum(c.mass_kg for c in panels) == pytest.approx(entry.mass_kg, rel=0.01)  # less the joints
        assert sum(c.mass_kg for c in panels) < entry.mass_kg
        assert max(c.mass_kg for c in panels) <= default_limits().lift_capacity_kg
        assert f"over the {default_limits().lift_capacity_kg:,.0f} kg lift capacity" in entry.why


def test_wall_panels_keep_the_openings_and_the_volume(build: tuple[Path, Manifest, dict[str, str]]) -> None:
    _, manifest, guids = build
    panels = sorted(_panels(manifest, guids["front"]), key=lambda c: c.bbox_world.min_m[0])
    assert len(panels) >= 2  # 9,420 kg of wall (no material: 1,000 kg/m³) over the 8 t crane's chart
    length, height, thickness = WALL_M
    volume = length * height * thickness - 2 * 1.5 * 1.2 * thickness
    assert sum(c.volume_m3 for c in panels) == pytest.approx(volume, rel=0.01)
    assert all(c.bbox_world.max_m[2] - c.bbox_world.min_m[2] == pytest.approx(height) for c in panels)
    for a, b in WINDOWS_X:  # each window's opening lies within one panel
        assert any(lo <= a and b <= hi for lo, hi in (_span(c, 0) for c in panels)), (a, b)
    entry = next(e for e in manifest.panelised if e.guid == guids["front"])
    assert [(j.guids, j.kind, round(j.length_m, 3)) for j in entry.joints] == [
        ((left.guid, right.guid), "vertical", height) for left, right in itertools.pairwise(panels)
    ]


def test_slab_planks_run_along_the_span(build: tuple[Path, Manifest, dict[str, str]]) -> None:
    _, manifest, guids = build
    planks = _panels(manifest, guids["slab"])
    # 37.5 t: five planks would be within the 8 t crane's chart, but a truck carries 2.55 m: eight of 2.11 m
    assert len(planks) == 8
    for plank in planks:
        low, high = np.array(plank.bbox_world.min_m), np.array(plank.bbox_world.max_m)
        assert high[1] - low[1] == pytest.approx(SPAN_M)
        assert 1.2 <= high[0] - low[0] <= 2.4
    entry = next(e for e in manifest.panelised if e.guid == guids["slab"])
    assert len(entry.joints) == 7 and {j.kind for j in entry.joints} == {"longitudinal"}


def test_an_element_that_is_not_cut_stays_whole_and_says_why(
    build: tuple[Path, Manifest, dict[str, str]],
) -> None:
    _, manifest, guids = build
    column = manifest.component(guids["column"])
    assert column.parent_guid is None
    assert any("not panelised: an IfcColumn is not cut into panels" in note for note in column.warnings)
    # the warning says what it became instead
    assert any(note.endswith(f"→ {column.method.value.replace('_', ' ')}") for note in column.warnings)


def test_panels_are_valid_models_at_their_places(build: tuple[Path, Manifest, dict[str, str]]) -> None:
    out, manifest, _ = build
    panels = [c for c in manifest.components if c.parent_guid]
    files = [out / c.files.sdf_file for c in panels] + [out / manifest.world_file]
    checked = sdf_check_files(files, out / "models")
    assert {path: answer for path, answer in checked.items() if answer != "Valid."} == {}
    client = pybullet.connect(pybullet.DIRECT)
    try:
        bodies = pybullet.loadSDF(str(out / manifest.world_file), physicsClientId=client)
        names = {pybullet.getBodyInfo(b, physicsClientId=client)[1].decode(): b for b in bodies}
        assert {c.guid for c in panels} <= set(names)
        for panel in panels:
            body = names[panel.guid]
            assert pybullet.getDynamicsInfo(body, -1, physicsClientId=client)[0] == pytest.approx(
                panel.mass_kg
            )
            low, high = pybullet.getAABB(body, physicsClientId=client)
            np.testing.assert_allclose(low, panel.bbox_world.min_m, atol=0.02)
            np.testing.assert_allclose(high, panel.bbox_world.max_m, atol=0.02)
    finally:
        pybullet.disconnect(client)


def test_the_derived_sequence_sets_windows_and_planks_after_the_wall_panels(
    build: tuple[Path, Manifest, dict[str, str]],
) -> None:
    out, manifest, guids = build
    sequence = read_sequence(out / manifest.sequence_file)
    check_sequence(sequence)  # no cycle
    assert sorted(sequence.guids()) == sorted(c.guid for c in manifest.components)
    preds = support_predecessors(manifest.components)
    assert support_violations(sequence.guids(), preds) == []
    wall_panels = {c.guid for c in manifest.components if c.parent_guid in (guids["front"], guids["back"])}
    for window in ("w1", "w2"):
        hosts = preds[guids[window]]
        assert len(hosts) == 1 and hosts <= wall_panels
    for plank in _panels(manifest, guids["slab"]):
        assert len(preds[plank.guid] & wall_panels) >= 2  # it rests on both walls
    site = plan_site(manifest.components)
    assert set(site.slots) == {c.guid for c in manifest.components}


HOUSE_HEAVY_WALL = "2idC0G3ezCdhA9WVjWemcz"  # 16.78 m, 4,884 kg (plaster on hollow brick), no opening
HOUSE_WINDOW_WALL = "2idC0G3ezCdhA9WVjWemc$"  # 16.89 m, 2,906 kg, nine windows 0.2 m apart
HOUSE_ROOF_SLAB = "1s5utE$rDDfRKgzV6jUJ0r"  # 16.9 × 7.4 × 0.3 m, on the walls at 3 m


def test_the_revit_house_walls_split_and_its_concrete_floor_is_not_cut_beyond_the_lift(
    samples_dir: Path, tmp_path: Path
) -> None:
    source = samples_dir / "revit2021_sample_project.ifc"
    decisions = {guid: PANELISED for guid in (HOUSE_HEAVY_WALL, HOUSE_WINDOW_WALL, HOUSE_ROOF_SLAB)}
    options = ConvertOptions(decisions=decisions, formats=(), split_ifc=False)  # the split, not the files
    manifest = convert_model(open_model(source), source, tmp_path, options)
    # its floor names no material it is known by: taken for concrete, 90 t, and no plank a crane on site
    # picks up (1.2 m wide, the narrowest a precaster makes) is light enough: not cut, and it says why
    assert _panels(manifest, HOUSE_ROOF_SLAB) == []
    roof = manifest.component(HOUSE_ROOF_SLAB)
    assert round(roof.mass_kg) == 90043
    assert (
        "a 1.2 m plank would weigh 6,394 kg, over the 3,000 kg lift capacity (the largest ground payload "
        "that hands a part off to a crane)" in roof.method_note
    )
    assert [round(c.mass_kg) for c in _panels(manifest, HOUSE_HEAVY_WALL)] == [
        2440,
        2440,
    ]  # 2,442 less a joint
    wall_panels = _panels(manifest, HOUSE_WINDOW_WALL)
    assert len(wall_panels) == 2 and sum(c.mass_kg for c in wall_panels) == pytest.approx(
        2901, abs=1
    )  # 2,906 less a joint
    panel_guids = {c.guid for c in wall_panels}
    windows = [
        c
        for c in manifest.components
        if any(link.role == "filling" and link.other_guid in panel_guids for link in c.connections)
    ]
    assert len(windows) == 9  # the wall's windows are hosted by its panels now
    spans = [_span(c, 1) for c in wall_panels]
    for window in windows:  # each lies within one of the panels
        low, high = _span(window, 1)
        assert any(a - 0.01 <= low and high <= b + 0.01 for a, b in spans), window.name
    preds = support_predecessors(manifest.components)
    assert preds[HOUSE_ROOF_SLAB] & {p.guid for p in wall_panels}  # the floor rests on the wall's panels
    check_sequence(read_sequence(tmp_path / manifest.sequence_file))


def test_a_concrete_element_no_cut_keeps_within_the_limits_is_cast_in_place_not_lifted_whole() -> None:
    """FZK-Haus's 20 t concrete floor with a stair opening that no cut avoids was lifted whole, beyond
    every machine, and 58 components waited on it for ever; a site forms and pours such a slab where it
    stands. An element of another material stays lifted whole (the fleet check then says if none can)."""
    methods = load_methods("prefab")
    slab = MethodDecision(
        method=ConstructionMethod.PANELISED, source=MethodSource.RULE, note="too heavy", material="concrete"
    )
    cast = not_panelised(slab, "no cut avoids its openings", methods)
    assert cast.method is ConstructionMethod.CAST_IN_PLACE
    assert cast.note == "too heavy; not panelised (no cut avoids its openings): cast in place"
    timber = slab.model_copy(update={"material": "timber"})
    assert not_panelised(timber, "no cut", methods).method is ConstructionMethod.LIFTED
    assert not_panelised(slab, "no cut", None).method is ConstructionMethod.LIFTED


def test_a_masonry_wall_no_cut_keeps_within_the_limits_is_laid_where_it_stands() -> None:
    """The Revit duplex's 26 t brick-on-block walls (17.8 m, openings no panel cut avoids) would be lifted
    whole, beyond every machine; a site lays them course by course. The lifted-only file lays nothing."""
    wall = MethodDecision(
        method=ConstructionMethod.PANELISED, source=MethodSource.RULE, note="too heavy", material="masonry"
    )
    laid = not_panelised(wall, "no cut avoids its openings", load_methods("prefab"))
    assert laid.method is ConstructionMethod.LAID
    assert laid.note == "too heavy; not panelised (no cut avoids its openings): laid where it stands"
    assert not_panelised(wall, "no cut", load_methods("lifted")).method is ConstructionMethod.LIFTED


def test_a_slab_of_unknown_material_no_cut_fits_is_cast_in_place_as_concrete_other_classes_stay_lifted() -> (
    None
):
    """FZK-Haus's upper floor (material "Solid", 11.8 × 9.8 × 0.2 m, 20 t, a stair opening no plank cut
    avoids) was lifted whole, beyond every machine, and the storey above waited on it; a site casts such a
    slab. The methods file names the classes so cast (``cast_unknown_classes``): a column of unknown
    material stays lifted whole, and the lifted-only file casts nothing. A wall no storey-high panel fits
    (a core wall of the Revit office, 44 m tall) is cast too under the prefab preset."""
    model = ifcopenshell.file(schema="IFC4")
    slab_element = ifcopenshell.api.root.create_entity(model, ifc_class="IfcSlab")
    column = ifcopenshell.api.root.create_entity(model, ifc_class="IfcColumn")
    unknown = MethodDecision(
        method=ConstructionMethod.PANELISED, source=MethodSource.RULE, note="too heavy", material="unknown"
    )
    cast = not_panelised(unknown, "no cut avoids its openings", load_methods("prefab"), slab_element)
    assert cast.method is ConstructionMethod.CAST_IN_PLACE
    assert cast.note.endswith("material unknown, cast in place as concrete")
    assert not_panelised(unknown, "no cut", load_methods("conventional"), slab_element).method is (
        ConstructionMethod.CAST_IN_PLACE
    )
    assert (
        not_panelised(unknown, "no cut", load_methods("prefab"), column).method is ConstructionMethod.LIFTED
    )
    core_wall = ifcopenshell.api.root.create_entity(model, ifc_class="IfcWall")  # a shaft's wall, 44 m tall
    assert not_panelised(unknown, "no cut", load_methods("prefab"), core_wall).method is (
        ConstructionMethod.CAST_IN_PLACE
    )
    assert not_panelised(unknown, "no cut", load_methods("lifted"), slab_element).method is (
        ConstructionMethod.LIFTED
    )
