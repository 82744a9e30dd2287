"""The excavation: a pit under every foundation, open until its foundation is placed in it.

Why: a component whose BIM target reaches below ground (a footing, a pile cap, a foundation slab) is
placed into an excavated pit, and what stands on it (a column) has nothing under it until it is there.
A plain ground plane at z = 0 would carry a column placed before its footing as if the footing were
there. So each such component gets a pit: its target's footprint at ground level, with a floor (a static
box) at its target's bottom — one pit per convex collision part that reaches below ground (a Revit strip
footing is a ring of strips at two depths: its bounding box would have put one floor 0.56 m deep under
the whole building). Where pits overlap, the excavation goes down to the deepest of them: a shallower
floor leaves out what a deeper pit covers (the hub's 125 mm ground slab had set its floor over the 559 mm
thickened slab's pit, so the thickened slab, released at its target, was pushed up out of that floor).

A component released into dynamics (:mod:`.handling`) with its centre of mass over an open pit does not
touch the ground plane: it drops into the pit and rests on the pit floor (a column 0.3 m lower than its
target, which its agent sees); beside a pit it is lowered onto the ground, overhanging the pit. The pit is
filled once its foundation is placed: from then on the foundation itself carries what stands on it.

Robots never drive into a pit (the ground plane still carries them: the site's robots are not simulated
falling into excavations) and the laser does not see the floors (they lie below every laser's height).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from bimbot.shared.manifest import MAX_COLLISION_PARTS, Component
from bimbot.shared.site_plan import Rect

from .client import p
from .collision_margin import obj_vertices
from .ray_scene import register_boxes
from .scene import STATIC_GROUP, STATIC_MASK, put_to_sleep, set_filter

BELOW_GROUND_M = 0.02  # a target bottom deeper than this below ground makes a pit
FLOOR_THICKNESS_M = 0.2
DEEPER_M = 0.01  # a pit this much deeper than another takes its footprint out of the other's floor
MIN_FLOOR_M = 0.01  # narrower floor strips (left between deeper pits) are left out

Box = tuple[tuple[float, float, float], tuple[float, float, float]]  # (low, high) corners, world, m


def collision_part_boxes(component: Component, build_dir: Path) -> list[Box]:
    """The world boxes of ``component``'s convex collision parts at its BIM target (its bounding box when
    it has none, or more than physics keeps)."""
    files = [build_dir / path for path in component.files.collision]
    if not files or len(files) > MAX_COLLISION_PARTS or not all(path.is_file() for path in files):
        return [(tuple(component.bbox_world.min_m), tuple(component.bbox_world.max_m))]  # type: ignore[list-item]
    pose = component.target_pose_world
    turn = Rotation.from_quat(pose.quat_xyzw).as_matrix()
    boxes: list[Box] = []
    for path in files:
        world = obj_vertices(path) @ turn.T + np.asarray(pose.position_m)
        low, high = world.min(axis=0), world.max(axis=0)
        boxes.append(
            ((float(low[0]), float(low[1]), float(low[2])), (float(high[0]), float(high[1]), float(high[2])))
        )
    return boxes


@dataclass(frozen=True)
class Pit:
    owner: str  # the GUID of the foundation that fills it
    footprint: Rect  # at ground level, world frame
    floor_z_m: float  # its floor: the foundation's bottom
    floor_body: int  # a static body holding this pit's floor (boxes, up to 16 a body; -1: deeper pits
    # cover all of it)


class Pits:
    """Every foundation's pit and its floor body; ``filled(guid)`` says whether a foundation is placed."""

    def __init__(
        self,
        client_id: int,
        components: Sequence[Component],
        filled: Callable[[str], bool],
        part_boxes: Callable[[Component], Sequence[Box]] | None = None,
    ):
        """``part_boxes``: a component's collision part boxes (:func:`collision_part_boxes`); without it
        each foundation's pit is its bounding box."""
        self.client_id = client_id
        self._filled = filled
        self.pits: list[Pit] = []
        for component in components:
            low, high = component.bbox_world.min_m, component.bbox_world.max_m
            if low[2] >= -BELOW_GROUND_M:
                continue
            boxes = part_boxes(component) if part_boxes is not None else [(tuple(low), tuple(high))]
            for (x0, y0, z0), (x1, y1, _) in boxes:
                if z0 < -BELOW_GROUND_M:
                    self.pits.append(Pit(component.guid, Rect((x0, y0), (x1, y1)), z0, -1))
        floors = [
            (index, rect)
            for index, pit in enumerate(self.pits)
            for rect in subtract(
                pit.footprint,
                [deeper.footprint for deeper in self.pits if deeper.floor_z_m < pit.floor_z_m - DEEPER_M],
            )
            if min(rect.size) >= MIN_FLOOR_M
        ]
        if not floors:
            return
        halves = [((r.size[0]) / 2.0, r.size[1] / 2.0, FLOOR_THICKNESS_M / 2.0) for _, r in floors]
        centres = [
            (
                (r.min_xy[0] + r.max_xy[0]) / 2.0,
                (r.min_xy[1] + r.max_xy[1]) / 2.0,
                self.pits[i].floor_z_m - FLOOR_THICKNESS_M / 2.0,
            )
            for i, r in floors
        ]
        # The floors are children of a few static bodies, not a body each: Bullet visits every body each
        # step (see scene.put_to_sleep). pybullet keeps at most MAX_COLLISION_PARTS children of a compound
        # shape and silently drops the rest — on a site with 324 footings, 308 of them fell through floors
        # that were not there — so a body holds that many floors, neighbours together (sorted by x, then y).
        order = sorted(range(len(floors)), key=lambda i: (centres[i][0], centres[i][1]))
        body_of_pit: dict[int, int] = {}
        for start in range(0, len(order), MAX_COLLISION_PARTS):
            chunk = order[start : start + MAX_COLLISION_PARTS]
            shape = p.createCollisionShapeArray(
                [p.GEOM_BOX] * len(chunk),
                halfExtents=[halves[i] for i in chunk],
                collisionFramePositions=[centres[i] for i in chunk],
                physicsClientId=client_id,
            )
            body = p.createMultiBody(0.0, shape, physicsClientId=client_id, useMaximalCoordinates=True)
            register_boxes(client_id, body, [halves[i] for i in chunk], [centres[i] for i in chunk])
            set_filter(client_id, body, STATIC_GROUP, STATIC_MASK)
            put_to_sleep(client_id, body)
            for i in chunk:
                body_of_pit.setdefault(floors[i][0], body)
        self.pits = [
            Pit(pit.owner, pit.footprint, pit.floor_z_m, body_of_pit.get(index, -1))
            for index, pit in enumerate(self.pits)
        ]

    def open_around(self, xy: tuple[float, float]) -> list[Pit]:
        """The open pits whose footprint holds the point ``xy`` (a released body's centre of mass: over an
        open pit it falls in; beside one it rests on the ground at the pit's edge, overhanging it)."""
        x, y = xy
        return [
            pit
            for pit in self.pits
            if not self._filled(pit.owner)
            and pit.footprint.min_xy[0] <= x <= pit.footprint.max_xy[0]
            and pit.footprint.min_xy[1] <= y <= pit.footprint.max_xy[1]
        ]


def subtract(rect: Rect, holes: Sequence[Rect]) -> list[Rect]:
    """``rect`` without ``holes``, as non-overlapping rectangles."""
    pieces = [rect]
    for hole in holes:
        if not rect.overlaps(hole):
            continue
        cut: list[Rect] = []
        for piece in pieces:
            if not piece.overlaps(hole):
                cut.append(piece)
                continue
            (x0, y0), (x1, y1) = piece.min_xy, piece.max_xy
            (hx0, hy0), (hx1, hy1) = hole.min_xy, hole.max_xy
            if hx0 > x0:
                cut.append(Rect((x0, y0), (hx0, y1)))  # left of the hole, full height
            if hx1 < x1:
                cut.append(Rect((hx1, y0), (x1, y1)))  # right of it
            mx0, mx1 = max(x0, hx0), min(x1, hx1)
            if hy0 > y0:
                cut.append(Rect((mx0, y0), (mx1, hy0)))  # below it, between those
            if hy1 < y1:
                cut.append(Rect((mx0, hy1), (mx1, y1)))  # above it
        pieces = cut
    return pieces
