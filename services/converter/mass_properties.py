"""Volume, centre of mass and inertia of a component mesh, per kilogram so any mass can be applied later.

Computed once per distinct geometry (elements that share a tessellation share these numbers) with the
exact polyhedral integrals of :mod:`.mesh` (the ones trimesh uses). A mesh that is not watertight has no
meaningful enclosed volume as a whole: then it is taken piece by piece (faces connected through shared
edges), each closed piece with its exact volume and each open one with its convex hull's, and the inertia
is that of a solid box filling the mesh's bounding box, centred on it; the result says so, and the manifest
reports it. One convex hull over the whole mesh had filled what lies between the pieces: acad2010's roof
of 33 open planes weighed 3,167 t (its hull 3,167 m³, its pieces' 202 m³), the Revit hub's strip footing
(two closed rings that only touch, so not watertight together) 69.6 m³ against its own 10.6 m³.
Where the pieces give nothing (a flat open mesh), the whole hull's volume, then the bounding box's.

Inertia tensors follow SDF: about the centre of mass, in the element frame's axes, with off-diagonal
entries equal to the tensor's entries (``ixy = -∫xy dm``), which is trimesh's convention as well.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bimbot.shared.manifest import InertiaSource

from .mesh import MeshLike, TriMesh, as_trimesh_lite, convex_hull, welded

MIN_THICKNESS_M = 0.001


@dataclass(frozen=True)
class MassProperties:
    volume_m3: float
    watertight: bool
    com_local_m: np.ndarray  # (3,)
    inertia_per_kg_m2: np.ndarray  # (3, 3) about the CoM, element axes; multiply by the mass in kg
    source: InertiaSource
    bbox_local_m: np.ndarray  # (2, 3): min, max

    def inertia_kg_m2(self, mass_kg: float) -> np.ndarray:
        return self.inertia_per_kg_m2 * mass_kg


def mesh_from_arrays(vertices_m: np.ndarray, faces: np.ndarray) -> TriMesh:
    """A mesh with merged vertices and consistent outward winding where the topology allows it."""
    mesh = welded(vertices_m, faces)
    if mesh.is_watertight and mesh.volume < 0:
        mesh = mesh.inverted()
    return mesh


def mass_properties(mesh_like: MeshLike) -> MassProperties:
    mesh = as_trimesh_lite(mesh_like)
    bbox = np.array(mesh.bounds, dtype=float)
    if mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0:
        props = mesh.mass_properties  # density 1: mass == volume
        return MassProperties(
            volume_m3=float(props.volume),
            watertight=True,
            com_local_m=np.array(props.center_mass, dtype=float),
            inertia_per_kg_m2=np.array(props.inertia, dtype=float) / float(props.volume),
            source=InertiaSource.MESH,
            bbox_local_m=bbox,
        )
    return _bounding_box_fallback(mesh, bbox)


def piecewise_volume_m3(mesh: TriMesh) -> float:
    """The volume of a mesh that is not watertight as a whole: each closed piece's own, each open piece's
    convex hull's (0 when flat)."""
    total = 0.0
    for piece in mesh.split():
        if piece.is_watertight and piece.is_winding_consistent:
            total += abs(piece.volume)
        else:
            hull = convex_hull(piece.vertices)
            total += hull.volume if hull is not None else 0.0
    return total


def _bounding_box_fallback(mesh: TriMesh, bbox: np.ndarray) -> MassProperties:
    extents = np.maximum(bbox[1] - bbox[0], MIN_THICKNESS_M)
    volume = piecewise_volume_m3(mesh)
    if not volume > 1e-12:
        hull = convex_hull(mesh.vertices)
        volume = hull.volume if hull is not None else 0.0  # flat or too few points: no hull volume
    if not volume > 1e-12:
        volume = float(np.prod(extents))
    return MassProperties(
        volume_m3=volume,
        watertight=False,
        com_local_m=(bbox[0] + bbox[1]) / 2.0,
        inertia_per_kg_m2=box_inertia_per_kg(extents),
        source=InertiaSource.BOUNDING_BOX_FALLBACK,
        bbox_local_m=bbox,
    )


def box_inertia_per_kg(extents_m: np.ndarray) -> np.ndarray:
    """Inertia of a solid box of unit mass about its centre: diag((b²+c²)/12, …)."""
    a2, b2, c2 = np.square(np.asarray(extents_m, dtype=float))
    return np.diag([(b2 + c2) / 12.0, (a2 + c2) / 12.0, (a2 + b2) / 12.0])
