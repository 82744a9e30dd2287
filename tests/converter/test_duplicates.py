"""An element the model draws twice (same class, place and shape under two GlobalIds) is built once: the
copy is skipped with the kept one's name, its model folder removed, and nothing waits for it."""

from __future__ import annotations

from pathlib import Path

from ifc_builders import add_assembly, add_box, new_model

from bimbot.services.converter.convert import convert_model
from bimbot.shared.ifc_input import open_model
from bimbot.shared.sequence import read_sequence

DOOR_SIZE_M = (0.9, 0.05, 2.1)


def test_a_door_drawn_twice_is_built_once_and_its_copy_is_skipped_naming_it(tmp_path: Path) -> None:
    small = new_model()
    in_wall = add_box(small, "IfcDoor", "Door 693876", size_m=DOOR_SIZE_M, contained=False)
    add_assembly(small, [in_wall], name="Curtain wall")  # the IFC relates this one: it is kept
    copy = add_box(small, "IfcDoor", "Door 693876", size_m=DOOR_SIZE_M)
    narrower = add_box(small, "IfcDoor", "Narrower door", size_m=(0.8, 0.05, 2.1))  # same place, other shape
    beside = add_box(small, "IfcDoor", "Next door", size_m=DOOR_SIZE_M, corner_m=(3.0, 0.0, 0.0))
    source = tmp_path / "doors.ifc"
    small.file.write(str(source))
    out = tmp_path / "build"
    manifest = convert_model(open_model(source), source, out)

    built = {component.guid for component in manifest.components}
    assert built == {str(in_wall.GlobalId), str(narrower.GlobalId), str(beside.GlobalId)}
    skipped = {entry.guid: entry.reason for entry in manifest.skipped}
    assert f"same class, place and shape as Door 693876 ({in_wall.GlobalId})" in skipped[str(copy.GlobalId)]
    folders = {path.name for path in (out / "models").iterdir()}
    assert folders == {component.folder for component in manifest.components}
    assert {task.guid for task in read_sequence(out / manifest.sequence_file).tasks} == built
    world = (out / manifest.world_file).read_text()
    assert all(component.folder in world for component in manifest.components)
    assert str(copy.GlobalId) not in world
