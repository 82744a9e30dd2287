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

A component released into dynamics (:mod:`.releasing`) with its centre of mass over an open pit does not
touch the ground plane: it drops into the pit and rests on the pit floor (a column 0.3 m lower than its
target, which its agent sees); beside a pit it is lowered onto the ground, overhanging the pit. The pit is
filled once its foundation is placed: from then on the foundation itself carries what stands on it.

The ground plane has no hole, so a body released over an open pit does not touch it at all; the ground
round every pit is kept as static boxes instead, its **rim** (``RIM_M`` wide, down to the deepest floor:
the pit's walls too), touched by released components only. An excavation is dug ``WORKING_SPACE_M``
wider than its foundation on every side (its floor too), so a foundation set down a few millimetres off
still goes in. One set down further off does not slide into the soil beside its pit: like a load a crane
lowers until it touches, it is lifted onto what is under it (:meth:`Pits.lift_onto_ground`: the rim, or a
shallower pit's floor) and settles from there, tipping into its pit or resting on the edge. Before the
rim, such a slab on the Revit hub (0.3 m off its 0.58 m wide pit inside the ground slab's) was released
half inside the ground slab's floor, thrown out by the contact solver, and fell through the ground.

Robots never drive into a pit (the ground plane still carries them: the site's robots are not simulated
falling into excavations) and the laser does not see the floors or rims (they lie below every laser's
height, and the rims' group, :data:`~.scene.PIT_EDGE_GROUP`, is in no robot's or ray's mask).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from bimbot.shared.excavation import BELOW_GROUND_M, WORKING_SPACE_M
from bimbot.shared.manifest import MAX_COLLISION_PARTS, Component
from bimbot.shared.site_plan import Rect

from .client import p
from .collision_margin import obj_vertices
from .ray_scene import register_boxes
from .scene import DYNAMIC_GROUP, PIT_EDGE_GROUP, STATIC_GROUP, STATIC_MASK, put_to_sleep, set_filter

FLOOR_THICKNESS_M = 0.2
DEEPER_M = 0.01  # a pit this much deeper than another takes its footprint out of the other's floor
MIN_FLOOR_M = 0.01  # narrower floor strips (left between deeper pits) are left out
RIM_M = 2.0  # the ground round a pit kept as boxes, for what is released over it (the plane is off for it)
LIFT_SLOP_M = 0.005  # a released body overlapping the rim or a floor less than this is the solver's

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
        holes = [pit.footprint.grown(WORKING_SPACE_M) for pit in self.pits]
        floors = [
            (index, rect)
            for index, pit in enumerate(self.pits)
            for rect in subtract(
                holes[index],
                [
                    holes[i]
                    for i, deeper in enumerate(self.pits)
                    if deeper.floor_z_m < pit.floor_z_m - DEEPER_M
                ],
            )
            if min(rect.size) >= MIN_FLOOR_M
        ]
        body_of_floor = self._static_boxes(
            [((r.size[0]) / 2.0, r.size[1] / 2.0, FLOOR_THICKNESS_M / 2.0) for _, r in floors],
            [
                (
                    (r.min_xy[0] + r.max_xy[0]) / 2.0,
                    (r.min_xy[1] + r.max_xy[1]) / 2.0,
                    self.pits[i].floor_z_m - FLOOR_THICKNESS_M / 2.0,
                )
                for i, r in floors
            ],
            group=STATIC_GROUP,
            mask=STATIC_MASK,
        )
        body_of_pit: dict[int, int] = {}
        for (index, _), body in zip(floors, body_of_floor, strict=True):
            body_of_pit.setdefault(index, body)
        self.pits = [
            Pit(pit.owner, pit.footprint, pit.floor_z_m, body_of_pit.get(index, -1))
            for index, pit in enumerate(self.pits)
        ]
        self.levels_m = sorted({0.0, *(pit.floor_z_m for pit in self.pits)})
        rims = self._rims(holes)
        self.ground_bodies = frozenset(body_of_floor) | frozenset(rims)

    def _rims(self, holes: Sequence[Rect]) -> list[int]:
        """The ground round every pit, as static boxes from z = 0 down below the deepest floor; what is
        released over a pit (the ground plane off for it) rests on them where it hangs over the edge."""
        if not holes:
            return []
        bottom_z = min(pit.floor_z_m for pit in self.pits) - FLOOR_THICKNESS_M
        pieces = [
            piece
            for hole in holes
            for piece in subtract(
                hole.grown(RIM_M), [other for other in holes if other.overlaps(hole.grown(RIM_M))]
            )
            if min(piece.size) >= MIN_FLOOR_M
        ]
        return self._static_boxes(
            [(r.size[0] / 2.0, r.size[1] / 2.0, -bottom_z / 2.0) for r in pieces],
            [
                ((r.min_xy[0] + r.max_xy[0]) / 2.0, (r.min_xy[1] + r.max_xy[1]) / 2.0, bottom_z / 2.0)
                for r in pieces
            ],
            group=PIT_EDGE_GROUP,
            mask=DYNAMIC_GROUP,
        )

    def _static_boxes(
        self,
        halves: Sequence[tuple[float, float, float]],
        centres: Sequence[tuple[float, float, float]],
        *,
        group: int,
        mask: int,
    ) -> list[int]:
        """Axis-aligned static boxes, asleep, known to the laser's compiled caster (which filters them by
        group as Bullet does); the body holding each box, in order."""
        # Children of a few static bodies, not a body each: Bullet visits every body each step (see
        # scene.put_to_sleep). pybullet keeps at most MAX_COLLISION_PARTS children of a compound shape and
        # silently drops the rest — on a site with 324 footings, 308 of them fell through floors that were
        # not there — so a body holds that many boxes, neighbours together (sorted by x, then y).
        client_id = self.client_id
        order = sorted(range(len(halves)), key=lambda i: (centres[i][0], centres[i][1]))
        body_of = [-1] * len(halves)
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
            set_filter(client_id, body, group, mask)
            put_to_sleep(client_id, body)
            for i in chunk:
                body_of[i] = body
        return body_of

    def lift_onto_ground(self, body_id: int) -> float:
        """How far up ``body_id``, released over an open pit, goes to rest on what is under it rather than
        inside it: the rim round the pit or a shallower pit's floor (a load lowered until it touches). 0
        when it overlaps neither deeper than ``LIFT_SLOP_M``; the body is left lifted."""
        cid = self.client_id
        position, orientation = p.getBasePositionAndOrientation(body_id, physicsClientId=cid)
        bottom_z = p.getAABB(body_id, -1, physicsClientId=cid)[0][2]
        lift = 0.0
        for level in [None, *(z for z in self.levels_m if z > bottom_z + LIFT_SLOP_M)]:
            if level is not None:
                lift = level - bottom_z
                p.resetBasePositionAndOrientation(
                    body_id, (position[0], position[1], position[2] + lift), orientation, physicsClientId=cid
                )
            if not self._in_the_ground(body_id):
                break
        return lift

    def _in_the_ground(self, body_id: int) -> bool:
        """Whether ``body_id`` overlaps a rim or a floor deeper than ``LIFT_SLOP_M``."""
        cid = self.client_id
        p.performCollisionDetection(physicsClientId=cid)
        low, high = p.getAABB(body_id, -1, physicsClientId=cid)
        near = {found[0] for found in p.getOverlappingObjects(low, high, physicsClientId=cid) or ()}
        return any(
            point[8] < -LIFT_SLOP_M
            for other in near & self.ground_bodies
            for point in p.getClosestPoints(body_id, other, 0.0, physicsClientId=cid)
        )

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
