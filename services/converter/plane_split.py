"""Convex decomposition of a closed mesh by cutting it with planes (manifold3d), for building elements.

Building elements are mostly made of flat faces meeting at right angles: a wall with openings, a stepped
slab, a notched plate. Cutting such a solid along the planes of its own faces splits it into pieces that are
exactly convex, where V-HACD's voxels blur the openings and cost 0.1–0.5 s per element. The search is
greedy: the piece whose convex hull exceeds its volume the most is cut by the plane, among candidates, that
makes the two hulls smallest (even if no smaller than the piece's: a ring needs two cuts before anything
shrinks); pieces within ``concavity_tol`` of their hull are kept. Candidate planes are
perpendicular to the element's own axes and to its dominant face normals, at the positions of its vertices
(every cut therefore lies on a plane the geometry already has).

Works on closed 2-manifold meshes only (``None`` otherwise, the caller falls back); pure, no files.
"""

from __future__ import annotations

from dataclasses import dataclass

import manifold3d
import numpy as np

from bimbot.shared.manifest import MAX_COLLISION_PARTS

from .mesh import MeshLike, TriMesh, as_trimesh_lite, manifold_to_mesh

CONCAVITY_TOL = 0.05  # a piece whose hull is ≤ 5 % larger than itself is convex enough
MAX_PARTS = MAX_COLLISION_PARTS
OFFSETS_PER_NORMAL = 9
DOMINANT_NORMALS = 3
# The search's budget, counted in work, not time, so that a conversion gives the same parts on a busy machine
# as on a quiet one: each cut tried costs the piece's triangles. 60,000 is about 0.3 s of one core here
# (the Revit samples: 180,000-230,000 a CPU second); under a load of 25 a 0.3 s wall-clock budget had
# cut the hub's footings short and drawn them 0.33 m into their neighbours.
WORK_BUDGET = 60_000


@dataclass(frozen=True)
class SplitResult:
    parts: list[TriMesh]  # convex hulls of the pieces, mesh frame
    hull_volume_ratio: float  # sum of the parts' volumes / mesh volume (1.0 = exact)


def to_manifold(mesh_like: MeshLike) -> manifold3d.Manifold | None:
    """The mesh as a manifold3d solid, or None when it is not a closed 2-manifold."""
    mesh = as_trimesh_lite(mesh_like)
    if not mesh.is_watertight or not mesh.is_winding_consistent or mesh.volume <= 0:
        return None
    solid = manifold3d.Manifold(
        manifold3d.Mesh(
            vert_properties=np.asarray(mesh.vertices, dtype=np.float32),
            tri_verts=np.asarray(mesh.faces, dtype=np.uint32),
        )
    )
    if solid.status() != manifold3d.Error.NoError or solid.is_empty() or solid.volume() <= 0:
        return None
    return solid


def split_into_convex_parts(
    mesh_like: MeshLike,
    *,
    concavity_tol: float = CONCAVITY_TOL,
    max_parts: int = MAX_PARTS,
    work_budget: int = WORK_BUDGET,
) -> SplitResult | None:
    """Convex parts of a closed mesh by greedy plane cuts; None when the mesh is not a closed manifold."""
    mesh = as_trimesh_lite(mesh_like)
    solid = to_manifold(mesh)
    if solid is None:
        return None
    normals = candidate_normals(mesh)
    work_left = work_budget
    open_pieces: list[tuple[float, manifold3d.Manifold]] = [(_excess(solid), solid)]
    final: list[manifold3d.Manifold] = []
    negligible_m3 = 1e-6 * solid.volume()
    while open_pieces and len(final) + len(open_pieces) < max_parts and work_left > 0:
        open_pieces.sort(key=lambda item: item[0])
        excess, piece = open_pieces.pop()
        volume = piece.volume()
        if volume <= negligible_m3:  # a sliver of faces enclosing nothing (degenerate input): dropped
            continue
        if excess <= concavity_tol * volume:
            final.append(piece)
            final.extend(item[1] for item in open_pieces)
            open_pieces = []
            break
        cut, work = _best_cut(piece, normals)
        work_left -= work
        if cut is None:
            final.append(piece)
            continue
        open_pieces.extend((_excess(half), half) for half in cut)
    final.extend(item[1] for item in open_pieces)
    hulls = [_hull_mesh(piece) for piece in final if piece.volume() > negligible_m3]
    parts = [hull for hull in hulls if hull is not None]
    if not parts:
        return None
    return SplitResult(parts, float(sum(part.volume for part in parts) / mesh.volume))


def candidate_normals(mesh: TriMesh) -> np.ndarray:
    """Unit normals of the cutting planes: the frame's axes, then the mesh's dominant face directions."""
    normals = [np.eye(3)[axis] for axis in range(3)]
    areas: dict[tuple[float, float, float], float] = {}
    for normal, area in zip(mesh.face_normals, mesh.area_faces, strict=True):
        direction = normal if normal[np.argmax(np.abs(normal))] > 0 else -normal  # n and -n: one plane family
        key = tuple(np.round(direction, 3))
        areas[key] = areas.get(key, 0.0) + float(area)
    for key, _ in sorted(areas.items(), key=lambda item: -item[1]):
        if len(normals) >= 3 + DOMINANT_NORMALS:
            break
        direction = np.array(key) / np.linalg.norm(key)
        if all(abs(float(direction @ known)) < 0.999 for known in normals):
            normals.append(direction)
    return np.array(normals)


def _best_cut(
    piece: manifold3d.Manifold, normals: np.ndarray
) -> tuple[tuple[manifold3d.Manifold, manifold3d.Manifold] | None, int]:
    """(the two halves of the cut that makes their hulls smallest, unless every cut makes them larger; the
    work it took: the piece's triangles times the cuts tried)."""
    mesh = piece.to_mesh()
    vertices = np.asarray(mesh.vert_properties[:, :3], dtype=float)
    triangles = len(mesh.tri_verts)
    hull_volume = piece.hull().volume()
    best: tuple[float, manifold3d.Manifold, manifold3d.Manifold] | None = None
    work = 0
    for normal in normals:
        for offset in _offsets(vertices @ normal):
            work += triangles
            below, above = piece.split_by_plane(tuple(float(v) for v in normal), float(offset))
            if below.is_empty() or above.is_empty():
                continue
            cost = below.hull().volume() + above.hull().volume()
            if best is None or cost < best[0]:
                best = (cost, above, below)
    # A cut that does not make the hulls smaller is still taken when none does: a frame around an opening
    # needs two cuts before the hulls shrink (each half of a ring is a U with the same hull as the ring).
    if best is None or best[0] > hull_volume * (1.0 + 1e-9):
        return None, work
    return (best[1], best[2]), work


def _offsets(projections: np.ndarray) -> np.ndarray:
    """Up to ``OFFSETS_PER_NORMAL`` distinct vertex positions strictly inside the piece along a normal."""
    values = np.unique(np.round(projections, 6))
    span = values[-1] - values[0] if len(values) else 0.0
    inside = (
        values[(values > values[0] + 1e-4 * span) & (values < values[-1] - 1e-4 * span)]
        if span
        else values[:0]
    )
    if len(inside) > OFFSETS_PER_NORMAL:
        inside = inside[np.linspace(0, len(inside) - 1, OFFSETS_PER_NORMAL).round().astype(int)]
    return inside


def _excess(piece: manifold3d.Manifold) -> float:
    """How much larger the piece's hull is than the piece (m³)."""
    return piece.hull().volume() - piece.volume()


def _hull_mesh(piece: manifold3d.Manifold) -> TriMesh | None:
    hull = manifold_to_mesh(piece.hull())
    return hull if len(hull.faces) >= 4 else None
