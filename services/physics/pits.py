"""The excavation: a pit under every foundation, open until its foundation is placed in it.

Why: a component whose BIM target reaches below ground (a footing, a pile cap, a foundation slab) is
placed into an excavated pit, and what stands on it (a column) has nothing under it until it is there.
A plain ground plane at z = 0 would carry a column placed before its footing as if the footing were
there. So each such component gets a pit: its target's footprint at ground level, with a floor (a static
box) at its target's bottom. A component released into dynamics (:mod:`.handling`) with its centre of
mass over an open pit does not touch the ground plane: it drops into the pit and rests on the pit floor
(a column 0.3 m lower than its target, which its agent sees); beside a pit it is lowered onto the ground,
overhanging the pit. The pit is filled once its foundation is placed: from then on the
foundation itself carries what stands on it.

Robots never drive into a pit (the ground plane still carries them: the site's robots are not simulated
falling into excavations) and the laser does not see the floors (they lie below every laser's height).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

from bimbot.shared.manifest import MAX_COLLISION_PARTS, Component
from bimbot.shared.site_plan import Rect

from .client import p
from .ray_scene import register_boxes
from .scene import STATIC_GROUP, STATIC_MASK, put_to_sleep, set_filter

BELOW_GROUND_M = 0.02  # a target bottom deeper than this below ground makes a pit
FLOOR_THICKNESS_M = 0.2


@dataclass(frozen=True)
class Pit:
    owner: str  # the GUID of the foundation that fills it
    footprint: Rect  # at ground level, world frame
    floor_z_m: float  # its floor: the foundation's bottom
    floor_body: int  # the static body holding this pit's floor (a box; up to 16 floors a body)


class Pits:
    """Every foundation's pit and its floor body; ``filled(guid)`` says whether a foundation is placed."""

    def __init__(self, client_id: int, components: Sequence[Component], filled: Callable[[str], bool]):
        self.client_id = client_id
        self._filled = filled
        self.pits: list[Pit] = []
        halves: list[tuple[float, float, float]] = []
        centres: list[tuple[float, float, float]] = []
        for component in components:
            low, high = component.bbox_world.min_m, component.bbox_world.max_m
            if low[2] >= -BELOW_GROUND_M:
                continue
            self.pits.append(Pit(component.guid, Rect((low[0], low[1]), (high[0], high[1])), low[2], -1))
            halves.append(((high[0] - low[0]) / 2.0, (high[1] - low[1]) / 2.0, FLOOR_THICKNESS_M / 2.0))
            centres.append(
                ((low[0] + high[0]) / 2.0, (low[1] + high[1]) / 2.0, low[2] - FLOOR_THICKNESS_M / 2.0)
            )
        if not self.pits:
            return
        # The floors are children of a few static bodies, not a body each: Bullet visits every body each
        # step (see scene.put_to_sleep). pybullet keeps at most MAX_COLLISION_PARTS children of a compound
        # shape and silently drops the rest — on a site with 324 footings, 308 of them fell through floors
        # that were not there — so a body holds that many floors, neighbours together (sorted by x, then y).
        order = sorted(range(len(self.pits)), key=lambda i: (centres[i][0], centres[i][1]))
        floor_of: dict[int, int] = {}
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
            floor_of.update(dict.fromkeys(chunk, body))
        self.pits = [
            Pit(pit.owner, pit.footprint, pit.floor_z_m, floor_of[index])
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
