"""Pairs of components the model draws into each other: how deep and where, measured on their collision parts.

Why: real models draw joints as overlaps (a column 50 mm into its footing, a beam's end in a wall, a window
in its wall), and physics, which pushes overlapping parts apart, must know them before a robot sets one
down. The measure is the one physics makes: each convex collision part becomes a Bullet hull at the
component's BIM pose (pybullet DIRECT, inset by Bullet's 1 mm hull margin as physics insets them, so the
margin puts the surface back on the geometry), and the depth of a pair is the deepest penetration
``getClosestPoints`` reports between any of their parts (GJK/EPA: the shortest move that separates them).
Where the overlap lies is the intersection of the penetrating parts (manifold3d, exact for convex parts):
its vertices tell a member's end in its support from two members crossing through each other.

Cost: a broad phase on the components' world bounding boxes first (sorted along x; only boxes that overlap
by more than ``contact_m`` on every axis can hold a penetration that deep), then on the parts' boxes; only
the components of a candidate pair are read and built. Pure apart from reading the collision OBJs the
converter wrote and a private pybullet client.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any

import manifold3d
import numpy as np

from bimbot.shared.manifest import Component

from .placement import matrix_from_quat
from .vhacd import _pybullet

_log = logging.getLogger(__name__)

HULL_MARGIN_M = 0.001  # Bullet's collision margin outside a convex hull (physics insets its parts by it)
BROAD_MARGIN_M = 0.002  # collision parts may reach a little past the mesh's box (hulls of open meshes)


@dataclass(frozen=True, eq=False)
class Overlap:
    """Two components (``first < second`` by GUID) whose parts penetrate ``depth_m`` deep at their targets."""

    first: str
    second: str
    depth_m: float
    # the penetrating pairs of convex parts (vertices, world frame; ``first``'s part, then ``second``'s)
    part_pairs: tuple[tuple[np.ndarray, np.ndarray], ...] = ()
    # every convex part of each (vertices, world frame): what lies under the overlap too
    first_parts: tuple[np.ndarray, ...] = ()
    second_parts: tuple[np.ndarray, ...] = ()

    @cached_property
    def region_m(self) -> np.ndarray:
        """The vertices ``(n, 3)`` (world frame) of where the two overlap: the intersection of each
        penetrating pair of parts (manifold3d; computed when asked, as only a rule's test needs it)."""
        return np.concatenate([_intersection(a, b) for a, b in self.part_pairs])

    def bottoms_under_m(self) -> tuple[float, float]:
        """How low ``first`` and ``second`` reach right under where they overlap: the lowest point of each
        one's parts within the region's plan box (a sloped rafter's section over its purlin, not its end at
        the eaves). All its parts, not only those that penetrate: a wall drawn into the roof panel it
        carries penetrates it with the lintel over a window, and the wall under that lintel reaches the
        ground (the lintel alone, 2 cm above the panel's underside, put the roof before its wall)."""
        region = self.region_m
        low, high = region[:, :2].min(axis=0), region[:, :2].max(axis=0)
        first = _lowest(self.first_parts, [a for a, _ in self.part_pairs], low, high)
        second = _lowest(self.second_parts, [b for _, b in self.part_pairs], low, high)
        return round(first, 4), round(second, 4)


def _lowest(
    parts: Sequence[np.ndarray], penetrating: Sequence[np.ndarray], low_xy: np.ndarray, high_xy: np.ndarray
) -> float:
    """The lowest point of ``parts`` within the prism over a plan box; of the ``penetrating`` parts (each
    its lowest point where it misses the prism, a sliver) when no part reaches into it."""
    within = [z for z in (_bottom_within(part, low_xy, high_xy) for part in parts) if z is not None]
    if within:
        return min(within)
    return min(
        float(part[:, 2].min()) if (z := _bottom_within(part, low_xy, high_xy)) is None else z
        for part in penetrating
    )


def _bottom_within(vertices: np.ndarray, low_xy: np.ndarray, high_xy: np.ndarray) -> float | None:
    """The lowest point of the convex part ``vertices`` within the vertical prism over a plan box; None
    where the part misses it."""
    part_low, part_high = vertices[:, :2].min(axis=0), vertices[:, :2].max(axis=0)
    if np.any(part_high < low_xy) or np.any(part_low > high_xy + 1e-3):
        return None  # its box misses the prism: no solid needed
    size = np.maximum(high_xy - low_xy, 1e-3)
    z0, z1 = float(vertices[:, 2].min()) - 1.0, float(vertices[:, 2].max()) + 1.0
    prism = manifold3d.Manifold.cube([float(size[0]), float(size[1]), z1 - z0]).translate(
        [float(low_xy[0]), float(low_xy[1]), z0]
    )
    solid = manifold3d.Manifold.hull_points(vertices) ^ prism
    if solid.is_empty():
        return None
    return float(np.asarray(solid.to_mesh().vert_properties)[:, 2].min())


def candidate_pairs(components: Sequence[Component], contact_m: float) -> list[tuple[int, int]]:
    """Index pairs ``(i, j)``, ``i < j``, whose world boxes overlap by more than ``contact_m`` on every axis
    (sweep along x: each box meets only those starting before it ends)."""
    if len(components) < 2:
        return []
    low = np.array([c.bbox_world.min_m for c in components], dtype=float) - BROAD_MARGIN_M
    high = np.array([c.bbox_world.max_m for c in components], dtype=float) + BROAD_MARGIN_M
    order = np.argsort(low[:, 0], kind="stable")
    starts = low[order, 0]
    pairs: list[tuple[int, int]] = []
    for rank, index in enumerate(order):
        end = int(np.searchsorted(starts, high[index, 0] - contact_m, side="left"))
        others = order[rank + 1 : end]
        if len(others) == 0:
            continue
        overlap = np.minimum(high[others], high[index]) - np.maximum(low[others], low[index])
        for other in others[np.all(overlap > contact_m, axis=1)]:
            pairs.append((min(int(index), int(other)), max(int(index), int(other))))
    return sorted(pairs)


def measure_overlaps(components: Sequence[Component], out_dir: Path, contact_m: float) -> list[Overlap]:
    """Every pair of ``components`` (their collision OBJs under ``out_dir``) that penetrates deeper than
    ``contact_m`` at their BIM targets, by GUID pair. A negative ``contact_m`` takes pairs drawn up to that
    far apart too (a gap: ``depth_m`` is then minus the gap), as a framed end's erection clearance asks."""
    pairs = candidate_pairs(components, contact_m)
    if not pairs:
        return []
    found: list[Overlap] = []
    with _bullet() as (p, cid):
        parts = {
            index: _parts(p, cid, components[index], out_dir)
            for index in sorted({index for pair in pairs for index in pair})
        }
        for i, j in pairs:
            overlap = _pair_overlap(p, cid, parts[i], parts[j], contact_m)
            if overlap is not None:
                depth_m, part_pairs = overlap
                first, second = sorted((components[i].guid, components[j].guid))
                all_i = tuple(part.vertices_world_m for part in parts[i])
                all_j = tuple(part.vertices_world_m for part in parts[j])
                if first != components[i].guid:  # each pair of parts: the first component's part first
                    part_pairs = tuple((b, a) for a, b in part_pairs)
                    all_i, all_j = all_j, all_i
                found.append(Overlap(first, second, depth_m, part_pairs, all_i, all_j))
    _log.debug(
        "%d candidate pair(s) by their boxes, %d overlap deeper than a contact",
        len(pairs),
        len(found),
    )
    return sorted(found, key=lambda item: (item.first, item.second))


@dataclass(frozen=True, eq=False)
class _Part:
    shape: int  # its Bullet collision shape (inset by the hull margin), in the component frame
    position_m: tuple[float, float, float]  # the component's target pose
    quat_xyzw: tuple[float, float, float, float]
    vertices_world_m: np.ndarray  # (n, 3), the part's own vertices at the component's target
    low_m: np.ndarray  # its box in the world
    high_m: np.ndarray


def _pair_overlap(
    p: Any, cid: int, parts_a: list[_Part], parts_b: list[_Part], contact_m: float
) -> tuple[float, tuple[tuple[np.ndarray, np.ndarray], ...]] | None:
    """(depth, penetrating part pairs) of two components, or None when they only touch."""
    deepest = -math.inf
    penetrating: list[tuple[np.ndarray, np.ndarray]] = []
    reach_m = max(0.0, -contact_m)  # how far apart parts may be and still count (a gap within a clearance)
    for a in parts_a:
        for b in parts_b:
            if np.any(np.minimum(a.high_m, b.high_m) - np.maximum(a.low_m, b.low_m) <= contact_m):
                continue
            points = p.getClosestPoints(
                -1,
                -1,
                reach_m,
                collisionShapeA=a.shape,
                collisionShapeB=b.shape,
                collisionShapePositionA=a.position_m,
                collisionShapePositionB=b.position_m,
                collisionShapeOrientationA=a.quat_xyzw,
                collisionShapeOrientationB=b.quat_xyzw,
                physicsClientId=cid,
            )
            depth_m = max((-float(point[8]) for point in points or ()), default=-math.inf)
            if depth_m > contact_m:
                deepest = max(deepest, depth_m)
                penetrating.append((a.vertices_world_m, b.vertices_world_m))
    if deepest <= contact_m:
        return None
    return deepest, tuple(penetrating)


def _intersection(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The vertices of the intersection of two convex parts (their hulls); where their boxes overlap when
    manifold3d finds no volume (a sliver)."""
    solid = manifold3d.Manifold.hull_points(a) ^ manifold3d.Manifold.hull_points(b)
    if not solid.is_empty():
        vertices = np.asarray(solid.to_mesh().vert_properties, dtype=float)[:, :3]
        if len(vertices):
            return vertices
    low, high = np.maximum(a.min(axis=0), b.min(axis=0)), np.minimum(a.max(axis=0), b.max(axis=0))
    return np.array([low, high])


def _parts(p: Any, cid: int, component: Component, out_dir: Path) -> list[_Part]:
    """The convex collision parts of ``component`` as Bullet shapes, at its BIM target."""
    pose = component.target_pose_world
    position = (float(pose.position_m[0]), float(pose.position_m[1]), float(pose.position_m[2]))
    quat = tuple(float(q) for q in pose.quat_xyzw)
    turn = matrix_from_quat(pose.quat_xyzw)
    parts: list[_Part] = []
    for name in component.files.collision:
        try:
            vertices = obj_vertices(out_dir / name)
        except (OSError, ValueError) as error:
            _log.debug("%s: collision part %s not read (%s)", component.guid, name, error)
            continue
        shape = p.createCollisionShape(
            p.GEOM_MESH, vertices=inset_by_margin(vertices).tolist(), physicsClientId=cid
        )
        if shape < 0:
            continue
        world = vertices @ turn.T + np.asarray(position)
        parts.append(_Part(shape, position, quat, world, world.min(axis=0), world.max(axis=0)))  # type: ignore[arg-type]
    return parts


def inset_by_margin(vertices: np.ndarray, margin_m: float = HULL_MARGIN_M) -> np.ndarray:
    """A part's vertices scaled about its box's centre so each face comes in by ``margin_m`` (Bullet adds
    it back outside the hull); an axis thinner than four margins is left as it is (physics does the same)."""
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    extent, centre = high - low, (high + low) / 2.0
    scale = np.where(extent > 4.0 * margin_m, (extent - 2.0 * margin_m) / np.maximum(extent, 1e-12), 1.0)
    return (vertices - centre) * scale + centre


def obj_vertices(path: Path) -> np.ndarray:
    """The vertices of a Wavefront OBJ mesh (its ``v`` lines), in its own frame."""
    lines = path.read_text(encoding="utf-8").splitlines()
    rows = [line.split()[1:4] for line in lines if line.startswith("v ")]
    if not rows:
        raise ValueError("no vertices")
    return np.asarray(rows, dtype=float)


@contextmanager
def _bullet() -> Iterator[tuple[Any, int]]:
    """A private DIRECT pybullet client (no gravity, nothing stepped), disconnected afterwards."""
    p = _pybullet()
    cid = p.connect(p.DIRECT)
    if cid < 0:
        raise RuntimeError("could not connect a pybullet physics server")
    try:
        yield p, cid
    finally:
        p.disconnect(physicsClientId=cid)
