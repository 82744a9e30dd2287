"""Merge a body's convex pieces into at most so many hulls, neighbours first, the least volume added.

Why: pybullet keeps at most :data:`~bimbot.shared.manifest.MAX_COLLISION_PARTS` children of a compound shape,
and an exact profile decomposition can give more: a circular hollow section is 24 annular sectors, the
Janesville restaurant's bridge railing 113 posts, balusters and rails. Merged along the body's longest axis
(:func:`.collision.merge_parts`, the mesh path's rule) a tube's sectors are grouped across its bore and the
tube is filled; merged here, two pieces become one only where their hull adds the least volume of any
nearby pair: a tube stays a tube of wider sectors, a railing keeps its open bays as long as it can.
"""

from __future__ import annotations

import heapq
from collections.abc import Sequence

import manifold3d
import numpy as np

from .mesh import TriMesh, convex_hull, manifold_to_mesh

NEIGHBOURS = 6  # each piece is weighed against this many pieces nearest to it (centre to centre)


def merge_nearest(parts: Sequence[TriMesh], limit: int) -> list[TriMesh]:
    """``parts`` merged pairwise, the pair whose hull adds the least volume first, until at most ``limit``
    are left; each result is the convex hull of the pieces it holds. Deterministic (ties by index)."""
    if len(parts) <= limit:
        return list(parts)
    points = [np.asarray(part.vertices, dtype=float) for part in parts]
    volumes = [_hull_volume(piece) for piece in points]
    alive = set(range(len(parts)))
    heap: list[tuple[float, int, int]] = []

    def weigh(index: int) -> None:
        others = sorted(alive - {index})
        centre = points[index].mean(axis=0)
        distances = [float(np.linalg.norm(points[other].mean(axis=0) - centre)) for other in others]
        for _, other in sorted(zip(distances, others, strict=True))[:NEIGHBOURS]:
            added = _hull_volume(np.vstack([points[index], points[other]])) - volumes[index] - volumes[other]
            heapq.heappush(heap, (added, min(index, other), max(index, other)))

    for index in sorted(alive):
        weigh(index)
    while len(alive) > limit:
        if not heap:  # every pair weighed was merged away: weigh what is left again
            for index in sorted(alive):
                weigh(index)
        _, first, second = heapq.heappop(heap)
        if first not in alive or second not in alive:
            continue
        hull_points, hull_volume = _hull(np.vstack([points[first], points[second]]))
        merged = len(points)
        points.append(hull_points)
        volumes.append(hull_volume)
        alive -= {first, second}
        alive.add(merged)
        weigh(merged)
    hulls = [convex_hull(points[index]) for index in sorted(alive)]
    return [hull for hull in hulls if hull is not None]


def _manifold_hull(points: np.ndarray) -> manifold3d.Manifold | None:
    """The convex hull of ``points`` as a manifold, None when it has no volume."""
    if len(points) < 4:
        return None
    hull = manifold3d.Manifold.hull_points(points)
    return None if hull.is_empty() or hull.volume() <= 0.0 else hull


def _hull(points: np.ndarray) -> tuple[np.ndarray, float]:
    """The vertices of ``points``' convex hull and its volume, from one hull (all the points and 0 when
    it has no volume)."""
    hull = _manifold_hull(points)
    if hull is None:
        return points, 0.0
    return np.asarray(manifold_to_mesh(hull).vertices, dtype=float), float(hull.volume())


def _hull_volume(points: np.ndarray) -> float:
    """The volume of ``points``' convex hull (no mesh made: weighed for every pair of neighbours)."""
    hull = _manifold_hull(points)
    return 0.0 if hull is None else float(hull.volume())
