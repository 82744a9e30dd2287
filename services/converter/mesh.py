"""A triangle mesh with the few operations the converter needs, on numpy and manifold3d only.

Why not trimesh: importing trimesh imports scipy (spatial, sparse, optimize, ndimage), ~0.5 s of a
``bimbot convert`` that otherwise starts in ~0.3 s, and its cached-property machinery costs more per call
than the numbers themselves on meshes of a few hundred triangles. What the converter uses of a mesh is
small: welding, watertightness and winding, volume, centre of mass and inertia (the same polyhedral
integrals trimesh uses, Eberly's), face normals and areas, the separate solids, and convex hulls
(manifold3d's QuickHull, which keeps the input points exactly). Rare paths (oriented bounding boxes of flat
meshes) convert to trimesh on demand with :meth:`TriMesh.to_trimesh`.

Inputs may be a :class:`TriMesh` or anything with ``vertices`` and ``faces`` (a ``trimesh.Trimesh``):
see :func:`as_trimesh_lite`. Arrays are never modified in place; a :class:`TriMesh` is immutable and caches
what it computes.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, Protocol

import manifold3d
import numpy as np

if TYPE_CHECKING:
    import trimesh

MERGE_DIGITS = 8  # vertices equal to 1e-8 m are one vertex (trimesh's default merge tolerance)
ZERO_CROSS = 100.0 * float(np.finfo(np.float64).resolution)  # |cross| at or below: no normal (as trimesh)
_INTEGRAL_DIVISORS = np.array([6, 24, 24, 24, 60, 60, 60, 120, 120, 120], dtype=np.float64)


class MeshLike(Protocol):
    @property
    def vertices(self) -> np.ndarray: ...

    @property
    def faces(self) -> np.ndarray: ...


@dataclass(frozen=True)
class MassIntegrals:
    """Volume, centre of mass and inertia about it (unit density, the mesh's axes)."""

    volume: float
    center_mass: np.ndarray  # (3,)
    inertia: np.ndarray  # (3, 3), SDF/trimesh convention (ixy = -∫xy dm)


@dataclass(frozen=True, eq=False)
class TriMesh:
    """Triangles as vertex indices; vertices in metres. Properties are computed once, on first use."""

    vertices: np.ndarray  # (n, 3) float64
    faces: np.ndarray  # (m, 3) int64

    # --- per face ------------------------------------------------------------------------------------

    @cached_property
    def triangles(self) -> np.ndarray:
        """(m, 3, 3) corner coordinates."""
        return self.vertices[self.faces]

    @cached_property
    def _crosses(self) -> np.ndarray:
        tri = self.triangles
        return cross_rows(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])

    @cached_property
    def area_faces(self) -> np.ndarray:
        return np.linalg.norm(self._crosses, axis=1) / 2.0

    @cached_property
    def face_normals(self) -> np.ndarray:
        """Unit normals by the right-hand rule; zero for degenerate faces (see :attr:`valid_faces`)."""
        normals = np.zeros_like(self._crosses)
        valid = self.valid_faces
        normals[valid] = self._crosses[valid] / (2.0 * self.area_faces[valid, None])
        return normals

    @cached_property
    def valid_faces(self) -> np.ndarray:
        """Faces with a normal: cross product longer than :data:`ZERO_CROSS`."""
        return 2.0 * self.area_faces > ZERO_CROSS

    @cached_property
    def triangles_center(self) -> np.ndarray:
        return self.triangles.mean(axis=1)

    # --- whole mesh ----------------------------------------------------------------------------------

    @cached_property
    def bounds(self) -> np.ndarray:
        """(2, 3): minimum and maximum corner of the vertices used by faces."""
        used = self.vertices[np.unique(self.faces)] if len(self.faces) else self.vertices
        return np.array([used.min(axis=0), used.max(axis=0)])

    @property
    def extents(self) -> np.ndarray:
        return self.bounds[1] - self.bounds[0]

    @property
    def area(self) -> float:
        return float(self.area_faces.sum())

    @cached_property
    def _edge_checks(self) -> tuple[bool, bool]:
        """(every edge in exactly two faces, every shared edge used once in each direction)."""
        if len(self.faces) == 0:
            return False, False
        edges = self.faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
        ordered = np.sort(edges, axis=1)
        order = np.lexsort((ordered[:, 1], ordered[:, 0]))
        ordered, edges = ordered[order], edges[order]
        if len(ordered) % 2:
            return False, False
        first, second = ordered[0::2], ordered[1::2]
        pairs_equal = np.all(first == second, axis=1)
        # exactly twice: each pair equal and no edge in two adjacent pairs
        distinct_pairs = np.any(first[1:] != first[:-1], axis=1) if len(first) > 1 else np.ones(0, bool)
        watertight = bool(pairs_equal.all() and distinct_pairs.all())
        winding = bool(np.all(edges[0::2][pairs_equal, 0] == edges[1::2][pairs_equal, 1]))
        return watertight, winding

    @property
    def is_watertight(self) -> bool:
        return self._edge_checks[0]

    @property
    def is_winding_consistent(self) -> bool:
        return self._edge_checks[1]

    @cached_property
    def mass_properties(self) -> MassIntegrals:
        return mass_integrals(self.triangles, self._crosses)

    @cached_property
    def volume(self) -> float:
        """Signed enclosed volume (m³); meaningful only for a closed, consistently wound mesh. The first of
        the mass integrals, alone (the others cost four times more and validation needs only this)."""
        tri = self.triangles
        return float(np.sum(self._crosses[:, 0] * (tri[:, 0, 0] + tri[:, 1, 0] + tri[:, 2, 0])) / 6.0)

    @property
    def center_mass(self) -> np.ndarray:
        return self.mass_properties.center_mass

    @property
    def is_volume(self) -> bool:
        """Closed, consistently wound, outward (positive volume): a solid."""
        return bool(
            self.is_watertight
            and self.is_winding_consistent
            and np.isfinite(self.center_mass).all()
            and self.volume > 0.0
        )

    @property
    def is_convex(self) -> bool:
        """A closed mesh equal to its own convex hull (volume within 1e-9 relative)."""
        hull = convex_hull(self.vertices)
        return self.is_volume and hull is not None and hull.volume <= self.volume * (1.0 + 1e-9)

    # --- derived meshes ------------------------------------------------------------------------------

    def inverted(self) -> TriMesh:
        return TriMesh(self.vertices, self.faces[:, ::-1].copy())

    def split(self) -> list[TriMesh]:
        """The separate pieces, faces connected through shared edges (no repair, open pieces kept)."""
        return [submesh(self.vertices, self.faces[faces]) for faces in self.piece_faces()]

    def piece_faces(self) -> list[np.ndarray]:
        """The face indices of each piece :meth:`split` gives, in the same order."""
        labels = _edge_connected_labels(self.faces)
        return [np.flatnonzero(labels == label) for label in np.unique(labels)]

    def to_trimesh(self) -> trimesh.Trimesh:
        """The same mesh as a ``trimesh.Trimesh`` (imports trimesh: for rare paths only)."""
        import trimesh

        return trimesh.Trimesh(self.vertices, self.faces, process=False)


def as_trimesh_lite(mesh: MeshLike) -> TriMesh:
    """``mesh`` as a :class:`TriMesh` sharing its arrays (float64 vertices, int64 faces)."""
    if isinstance(mesh, TriMesh):
        return mesh
    return TriMesh(np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int64))


def welded(vertices: np.ndarray, faces: np.ndarray, digits: int = MERGE_DIGITS) -> TriMesh:
    """Vertices equal to ``digits`` decimals merged and unreferenced ones dropped, in first-use order
    (as trimesh's ``process=True``); faces that become degenerate are kept."""
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    finite = np.isfinite(vertices).all(axis=1)
    if not finite.all():
        faces = faces[finite[faces].all(axis=1)]
    referenced = np.zeros(len(vertices), dtype=bool)
    referenced[faces] = True
    used = np.flatnonzero(referenced)
    keys = np.round(vertices[used] * 10.0**digits).astype(np.int64)
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")  # unique rows in the order they first appear
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    remap = np.zeros(len(vertices), dtype=np.int64)
    remap[used] = rank[inverse.reshape(-1)]
    return TriMesh(vertices[used[first[order]]], remap[faces])


def submesh(vertices: np.ndarray, faces: np.ndarray) -> TriMesh:
    """The mesh of ``faces`` with only the vertices they use, in first-use order."""
    used, inverse = np.unique(faces, return_inverse=True)
    return TriMesh(vertices[used], inverse.reshape(faces.shape).astype(np.int64))


def cross_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross products of two (n, 3) arrays (np.cross costs more than the arithmetic on small n)."""
    return np.column_stack(
        (
            a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1],
            a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
            a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0],
        )
    )


def mass_integrals(triangles: np.ndarray, crosses: np.ndarray | None = None) -> MassIntegrals:
    """Volume, centre of mass and inertia of a closed triangle surface, unit density.

    The polyhedral integrals of Eberly ("Polyhedral Mass Properties (Revisited)"), as trimesh computes
    them, so the converter's masses and inertias stay what they were.
    """
    tri = np.asarray(triangles, dtype=np.float64)
    if crosses is None:
        crosses = cross_rows(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    x0, x1, x2 = tri[:, 0, :], tri[:, 1, :], tri[:, 2, :]
    f1 = x0 + x1 + x2
    f2 = x0**2 + x1**2 + x0 * x1 + x2 * f1
    f3 = x0**3 + x0**2 * x1 + x0 * x1**2 + x1**3 + x2 * f2
    g0 = f2 + (x0 + f1) * x0
    g1 = f2 + (x1 + f1) * x1
    g2 = f2 + (x2 + f1) * x2
    integral = np.zeros((10, len(f1)))
    integral[0] = crosses[:, 0] * f1[:, 0]
    integral[1:4] = (crosses * f2).T
    integral[4:7] = (crosses * f3).T
    for i in range(3):
        j = (i + 1) % 3
        integral[i + 7] = crosses[:, i] * (x0[:, j] * g0[:, i] + x1[:, j] * g1[:, i] + x2[:, j] * g2[:, i])
    integrated = integral.sum(axis=1) / _INTEGRAL_DIVISORS
    volume = float(integrated[0])
    with np.errstate(divide="ignore", invalid="ignore"):
        com = integrated[1:4] / volume
    inertia = np.zeros((3, 3))
    inertia[0, 0] = integrated[5] + integrated[6] - volume * (com[[1, 2]] ** 2).sum()
    inertia[1, 1] = integrated[4] + integrated[6] - volume * (com[[0, 2]] ** 2).sum()
    inertia[2, 2] = integrated[4] + integrated[5] - volume * (com[[0, 1]] ** 2).sum()
    inertia[0, 1] = inertia[1, 0] = -(integrated[7] - volume * com[0] * com[1])
    inertia[1, 2] = inertia[2, 1] = -(integrated[8] - volume * com[1] * com[2])
    inertia[0, 2] = inertia[2, 0] = -(integrated[9] - volume * com[0] * com[2])
    return MassIntegrals(volume, com, inertia)


def convex_hull(points: np.ndarray) -> TriMesh | None:
    """Convex hull of a point set, outward winding, its vertices exactly input points; None when flat,
    empty or too small to enclose a volume."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(points) < 4:
        return None
    hull = manifold3d.Manifold.hull_points(points)
    if hull.is_empty() or not hull.volume() > 0.0:
        return None
    return manifold_to_mesh(hull)


def manifold_to_mesh(solid: manifold3d.Manifold) -> TriMesh:
    """A manifold3d solid's surface in double precision."""
    mesh = solid.to_mesh64()
    return TriMesh(
        np.ascontiguousarray(np.asarray(mesh.vert_properties)[:, :3], dtype=np.float64),
        np.asarray(mesh.tri_verts, dtype=np.int64),
    )


def _edge_connected_labels(faces: np.ndarray) -> np.ndarray:
    """A component label per face: faces sharing an edge that exactly two faces use get the same label
    (trimesh's face adjacency: a non-manifold edge joins nothing); union-find, vectorised."""
    count = len(faces)
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    owner = np.repeat(np.arange(count), 3)
    order = np.lexsort((edges[:, 1], edges[:, 0]))
    edges, owner = edges[order], owner[order]
    new_run = np.ones(len(edges) + 1, dtype=bool)
    new_run[1:-1] = np.any(edges[1:] != edges[:-1], axis=1)
    starts = np.flatnonzero(new_run)
    run_start, run_length = starts[:-1], np.diff(starts)
    pairs = run_start[run_length == 2]
    a, b = owner[pairs], owner[pairs + 1]
    parent = np.arange(count)
    while True:
        pa, pb = parent[a], parent[b]
        differ = pa != pb
        if not differ.any():
            break
        low, high = np.minimum(pa, pb)[differ], np.maximum(pa, pb)[differ]
        np.minimum.at(parent, high, low)
        while True:  # path compression until every face points at a root
            grand = parent[parent]
            if np.array_equal(grand, parent):
                break
            parent = grand
    return parent
