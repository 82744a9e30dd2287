"""Context massing: detached shells round an architectural project are left out, the project is built."""

from __future__ import annotations

from pathlib import Path

import ifcopenshell
from component_boxes import box_component
from ifc_builders import SmallModel, add_box, add_layers, new_model
from test_methods import _by_name, _convert

from bimbot.services.converter.context_massing import MIN_HEIGHT_M, context_blocks
from bimbot.services.converter.material_kind import material_kind, material_texts
from bimbot.shared.manifest import Component, Manifest
from bimbot.shared.methods_file import MaterialKind


def _as(component: Component, ifc_class: str) -> Component:
    return component.model_copy(update={"ifc_class": ifc_class})


def _shell(prefix: str, x_m: float, height_m: float) -> list[Component]:
    """Four 200 mm walls round a 10 × 10 m plan at ``x_m``, ``height_m`` tall, and a roof slab on top."""
    walls = [
        box_component(f"{prefix}s", (10.0, 0.2, height_m), (x_m, 0.0, 0.0)),
        box_component(f"{prefix}n", (10.0, 0.2, height_m), (x_m, 9.8, 0.0)),
        box_component(f"{prefix}w", (0.2, 10.0, height_m), (x_m, 0.0, 0.0)),
        box_component(f"{prefix}e", (0.2, 10.0, height_m), (x_m + 9.8, 0.0, 0.0)),
    ]
    roof = box_component(f"{prefix}roof", (10.0, 10.0, 0.15), (x_m, 0.0, height_m))
    return [*(_as(wall, "IfcWallStandardCase") for wall in walls), _as(roof, "IfcSlab")]


def _project() -> list[Component]:
    """A two-storey house: the same shell, a floor between its storeys, a door and a window."""
    house = _shell("house", 0.0, 7.5)
    floor = _as(box_component("floor", (10.0, 10.0, 0.2), (0.0, 0.0, 3.6)), "IfcSlab")
    door = _as(box_component("door", (1.0, 0.2, 2.1), (4.0, 0.0, 0.0)), "IfcDoor")
    window = _as(box_component("window", (1.2, 0.2, 1.2), (2.0, 9.8, 4.5)), "IfcWindow")
    return [*house, floor, door, window]


def test_a_tall_detached_shell_with_no_door_round_a_project_with_doors_is_context_massing() -> None:
    """The Revit office's 18 neighbouring blocks: painted "Generic - 200mm" walls 18-46 m tall with a
    roof on top and nothing inside; built as work they were 4,805 of its 5,761 components."""
    neighbour = _shell("nb", 30.0, 24.0)
    blocks = context_blocks([*_project(), *neighbour])
    assert [sorted(block.guids) for block in blocks] == [sorted(item.guid for item in neighbour)]
    reason = blocks[0].reason()
    assert reason.startswith("not part of the work (context massing)")
    assert "4 wall(s) and 1 slab(s) or roof(s), 24.1 m tall, 20.0 m from the project" in reason
    assert "--build-context" in reason


def test_what_a_builder_would_build_is_never_context_massing() -> None:
    """A garden wall is low; a detached garage has a door; a structural model has no door anywhere (its
    cores are work); a detached block with a column is a structure; the project itself is always built."""
    garden = _shell("garden", 30.0, MIN_HEIGHT_M - 1.0)
    assert context_blocks([*_project(), *garden]) == []
    garage = _shell("garage", 30.0, 9.0)
    garage_door = _as(box_component("garage-door", (3.0, 0.2, 2.5), (33.0, 0.0, 0.0)), "IfcDoor")
    assert context_blocks([*_project(), *garage, garage_door]) == []
    structural = [c for c in _project() if c.ifc_class not in ("IfcDoor", "IfcWindow")]
    assert context_blocks([*structural, *_shell("core", 30.0, 24.0)]) == []
    column = _as(box_component("column", (0.4, 0.4, 24.0), (35.0, 5.0, 0.0)), "IfcColumn")
    assert context_blocks([*_project(), *_shell("frame", 30.0, 24.0), column]) == []
    assert context_blocks(_shell("only", 0.0, 24.0)) == []


def test_a_block_that_touches_the_project_is_part_of_it() -> None:
    """Plan boxes within 1 m join blocks (a wing built against the project is the project)."""
    wing = _shell("wing", 10.5, 24.0)
    assert context_blocks([*_project(), *wing]) == []


def _model_with_neighbour() -> SmallModel:
    small = new_model()
    for name, corner, size in (
        ("house south", (0.0, 0.0, 0.0), (10.0, 0.2, 7.0)),
        ("house north", (0.0, 9.8, 0.0), (10.0, 0.2, 7.0)),
        ("house west", (0.0, 0.2, 0.0), (0.2, 9.6, 7.0)),
        ("house east", (9.8, 0.2, 0.0), (0.2, 9.6, 7.0)),
    ):
        add_box(small, "IfcWall", name, size_m=size, corner_m=corner)
    add_box(small, "IfcDoor", "house door", size_m=(1.0, 0.1, 2.1), corner_m=(4.0, -0.3, 0.0))
    for name, corner, size in (
        ("neighbour south", (40.0, 0.0, 0.0), (10.0, 0.2, 20.0)),
        ("neighbour north", (40.0, 9.8, 0.0), (10.0, 0.2, 20.0)),
        ("neighbour west", (40.0, 0.2, 0.0), (0.2, 9.6, 20.0)),
        ("neighbour east", (49.8, 0.2, 0.0), (0.2, 9.6, 20.0)),
    ):
        add_box(small, "IfcWall", name, size_m=size, corner_m=corner)
    return small


def _elements(manifest: Manifest) -> set[str]:
    """The names of the elements built (a panel's element's)."""
    return {name.split(" panel ")[0] for name in _by_name(manifest)}


def test_the_converter_leaves_the_neighbours_out_with_their_reason_and_builds_them_when_asked(
    tmp_path: Path,
) -> None:
    small = _model_with_neighbour()
    manifest = _convert(small, tmp_path / "default")
    assert _elements(manifest) == {"house south", "house north", "house west", "house east", "house door"}
    skipped = {entry.name: entry.reason for entry in manifest.skipped}
    for side in ("south", "north", "west", "east"):
        assert skipped[f"neighbour {side}"].startswith("not part of the work (context massing)")
    out = tmp_path / "default" / "out"
    folders = {path.relative_to(out).as_posix() for path in (out / "models").iterdir()}
    assert folders == {c.files.model_dir for c in manifest.components}, "the neighbours' folders removed"
    built = _convert(small, tmp_path / "asked", build_context=True)
    assert {f"neighbour {side}" for side in ("south", "north", "west", "east")} <= _elements(built)


def test_a_plaster_layer_thicker_than_any_plaster_says_nothing_of_what_the_wall_is_made_of() -> None:
    """The Revit office's "MockUp Exterior": 600 mm of "Plaster" and 30 mm of "Leather, weathered" over
    five storeys, read as gypsum, was lifted whole (17-290 t) where a wall of unknown make is cast; a
    plaster coat or a drywall partition drawn as one layer stays gypsum."""
    small = new_model()
    thick = add_box(small, "IfcWall", "mock-up", size_m=(10.0, 0.63, 3.0))
    thin = add_box(small, "IfcWall", "partition", size_m=(10.0, 0.1, 3.0), corner_m=(0.0, 5.0, 0.0))
    brick = add_box(small, "IfcWall", "rendered brick", size_m=(10.0, 0.3, 3.0), corner_m=(0.0, 9.0, 0.0))
    add_layers(small, [thick], [("Plaster", 0.6), ("Leather, weathered", 0.03)], name="MockUp")
    add_layers(small, [thin], [("Gypsum Wall Board", 0.1)], name="Partition")
    add_layers(small, [brick], [("Plaster", 0.015), ("Brick, Common", 0.27), ("Plaster", 0.015)], name="B")
    assert material_kind(material_texts(thick)) is MaterialKind.UNKNOWN
    assert material_kind(material_texts(thin)) is MaterialKind.GYPSUM
    assert material_kind(material_texts(brick)) is MaterialKind.MASONRY
    assert isinstance(small.file, ifcopenshell.file)
