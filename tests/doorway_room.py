"""A room of existing walls round a component, as one component of collision parts with a doorway: what
the robots' maps and the access check must drive through (shared by the shared and the robot tests)."""

from __future__ import annotations

from bimbot.shared.manifest import BoundingBox, Component


def room_round(column: Component, template: Component, doorway_to_m: float) -> Component:
    """Existing walls round ``column`` (a 6 m square room, 3 m high) as one component of six collision
    parts: three walls, the west wall's two piers and the lintel over the west doorway (2.5 m wide) spans
    from ``doorway_to_m`` up (0 closes the doorway)."""
    t, h = 0.3, 3.0

    def box(*corners: float) -> BoundingBox:  # x, y, z of the low corner, then of the high one
        return BoundingBox(min_m=corners[:3], max_m=corners[3:])

    parts = [
        box(-3.0, 3.0 - t, 0.0, 3.0, 3.0, h),  # north
        box(-3.0, -3.0, 0.0, 3.0, -3.0 + t, h),  # south
        box(3.0 - t, -3.0, 0.0, 3.0, 3.0, h),  # east
        box(-3.0, -3.0, 0.0, -3.0 + t, -1.25, h),  # west, south of the doorway
        box(-3.0, 1.25, 0.0, -3.0 + t, 3.0, h),  # west, north of it
        box(-3.0, -1.25, doorway_to_m, -3.0 + t, 1.25, h),  # the lintel (a wall when it reaches the floor)
    ]
    cx, cy, _ = column.target_pose_world.position_m
    at = template.target_pose_world.model_copy(update={"position_m": (cx, cy, 0.0)})
    return template.model_copy(
        update={
            "guid": "0RingWallsRoundR1000000",
            "name": "Ring",
            "ifc_class": "IfcWall",
            "bbox_local": box(-3.0, -3.0, 0.0, 3.0, 3.0, h),
            "part_boxes_local": parts,
            "target_pose_world": at,
        }
    )
