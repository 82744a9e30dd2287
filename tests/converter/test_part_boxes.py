"""A component of several collision parts carries each part's box: the robots' maps and the access check
drive through a doorway under its lintel instead of round the wall's whole bounding box."""

from __future__ import annotations

from pathlib import Path

from ifc_builders import add_opening, add_wall, new_model, translation

from bimbot.services.converter.convert import convert_model
from bimbot.shared.ifc_input import open_model
from bimbot.shared.manifest import BoundingBox

DOOR_X_M = (2.0, 3.2)  # the doorway along the wall, from the floor up to 2.2 m
DOOR_TOP_M = 2.2


def _meets(box: BoundingBox, x_range: tuple[float, float], z_range: tuple[float, float]) -> bool:
    return (
        box.max_m[0] > x_range[0]
        and box.min_m[0] < x_range[1]
        and box.max_m[2] > z_range[0]
        and box.min_m[2] < z_range[1]
    )


def test_a_wall_with_a_doorway_keeps_its_parts_boxes_and_none_fills_the_doorway(tmp_path: Path) -> None:
    small = new_model()
    wall = add_wall(small, "Door wall", length_m=6.0, height_m=3.0, thickness_m=0.2)
    add_opening(
        small,
        wall,
        width_m=DOOR_X_M[1] - DOOR_X_M[0],
        height_m=DOOR_TOP_M,
        matrix_m=translation(2.0, -0.2, 0),
    )
    plain = add_wall(small, "Plain wall", length_m=6.0, matrix_m=translation(0, 5.0, 0))
    source = tmp_path / "door.ifc"
    small.file.write(str(source))
    manifest = convert_model(open_model(source), source, tmp_path / "build")
    by_guid = {component.guid: component for component in manifest.components}
    door_wall, plain_wall = by_guid[str(wall.GlobalId)], by_guid[str(plain.GlobalId)]
    boxes = door_wall.part_boxes_local
    assert len(boxes) == door_wall.collision_parts >= 3  # beside the doorway, either side, and over it
    inside = (DOOR_X_M[0] + 0.05, DOOR_X_M[1] - 0.05)
    assert not any(_meets(box, inside, (0.02, DOOR_TOP_M - 0.05)) for box in boxes)  # the doorway is free
    assert any(_meets(box, inside, (DOOR_TOP_M + 0.05, 3.0)) for box in boxes)  # the lintel over it
    assert plain_wall.part_boxes_local == []  # one part: its bounding box is its shape
