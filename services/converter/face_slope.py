"""How steeply a component's broad faces slope in the world (pure): a flat slab 0°, a pitched roof panel
its pitch, a stair flight somewhere between its treads and its soffit.

A precast plank or slab on level bearings is let go once it sits: friction holds it. A roof panel on a
14° pitch is not: a site screws or nails it down to its wall plates and purlins before the crane lets go
(:mod:`.connection_kinds` makes such a bearing ``fastened``). Which one a component is follows from its
mesh: the area-weighted slope of the faces that lie within 60° of horizontal (its top and underside; its
edges and any vertical face are left out). The sign of a normal is not used, so a mesh wound either way
gives the same answer.
"""

from __future__ import annotations

import math

import numpy as np

from .mesh import MeshLike, as_trimesh_lite

BROAD_FACE_MIN_NZ = 0.5  # |normal·z| from here up: a face within 60° of horizontal (a top or underside)


def face_slope_deg(mesh: MeshLike, rotation: np.ndarray) -> float:
    """The area-weighted slope (degrees from horizontal, world) of ``mesh``'s faces within 60° of
    horizontal; ``rotation`` turns the mesh's axes into the world's. 0 for a mesh with no such face."""
    lite = as_trimesh_lite(mesh)
    if not len(lite.faces):
        return 0.0
    nz = np.abs(lite.face_normals @ np.asarray(rotation, dtype=np.float64)[2])
    areas = lite.area_faces
    broad = nz >= BROAD_FACE_MIN_NZ
    total = float(areas[broad].sum())
    if total <= 0.0:
        return 0.0
    slopes_rad = np.arccos(np.clip(nz[broad], 0.0, 1.0))
    return math.degrees(float((slopes_rad * areas[broad]).sum()) / total)
