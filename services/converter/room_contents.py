"""What a room holds stands in it: what such an element draws deep under the floor of its room is cut off.

Why: IFC contains a room's furniture, fittings and equipment in its ``IfcSpace``
(``IfcRelContainedInSpatialStructure``): they stand in the room, on its floor, and a site sets them there
once that floor is laid. An element so contained that reaches deeper under the room's floor than a floor's
build-up (:data:`FLOOR_BUILD_UP_M`: a finish on its screed or topping, within which an item may stand on
the slab with the finish laid round it) draws part of itself through the floor and the slabs under it,
where no site builds anything of it: a nested part of an authoring tool's family exported at the wrong
height. Physics would find that part in the floor (a clash that pushes the floor or the element off its
target), and the support graph would order the element before the floor it stands on, by its lowest point.

So the geometry of such an element is cut at its room's floor: the part above is what is built. Only room
contents (:data:`CONTENT_CLASSES`: furnishings, and proxies, which is what an authoring tool exports a
fitting without an IFC class of its own as) are cut, and only one standing mostly above the floor (what
lies under the floor is less than what rises above it): an element mostly under its room's floor is no
content of that room, and is left as drawn. A closed solid is capped where it is cut (it stays a solid); an
open surface, as exports draw fittings, is clipped triangle by triangle. The room's floor is the lowest point
of the ``IfcSpace``'s own geometry, else its placement. Pure apart from ifcopenshell's geometry kernel.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import cast

import ifcopenshell
import ifcopenshell.geom
import ifcopenshell.util.element
import ifcopenshell.util.placement
import ifcopenshell.util.shape
import ifcopenshell.util.unit
import numpy as np
from ifcopenshell import ifcopenshell_wrapper

from .mesh import TriMesh, manifold_to_mesh
from .plane_split import to_manifold
from .tessellation import ElementShape, Geometry

CONTENT_CLASSES = ("IfcFurnishingElement", "IfcBuildingElementProxy")  # with subclasses (IfcFurniture…)
FLOOR_BUILD_UP_M = 0.15  # a floor's finish and screed or topping: an item may stand on the slab under it
ON_PLANE_M = 1e-9  # a vertex this close to the cut is on it (kept)


@dataclass(frozen=True)
class RoomFloor:
    """The floor of the room an element stands in."""

    z_m: float  # IFC world z, metres
    room: str  # the room's name, for the note on the element


def room_floors(
    model: ifcopenshell.file, elements: Sequence[ifcopenshell.entity_instance]
) -> dict[int, RoomFloor]:
    """Step id → the floor of its room, for each of ``elements`` of :data:`CONTENT_CLASSES` contained in
    an ``IfcSpace``."""
    unit_scale_m = float(ifcopenshell.util.unit.calculate_unit_scale(model))
    floors: dict[int, RoomFloor | None] = {}
    found: dict[int, RoomFloor] = {}
    for element in elements:
        if not any(element.is_a(name) for name in CONTENT_CLASSES):
            continue
        space = ifcopenshell.util.element.get_container(element)
        if space is None or not space.is_a("IfcSpace"):
            continue
        if space.id() not in floors:
            floors[space.id()] = _space_floor(space, unit_scale_m)
        floor = floors[space.id()]
        if floor is not None:
            found[element.id()] = floor
    return found


def _space_floor(space: ifcopenshell.entity_instance, unit_scale_m: float) -> RoomFloor | None:
    """The lowest point of the space's geometry (IFC world z, metres), else its placement's z."""
    room = str(getattr(space, "LongName", None) or space.Name or f"#{space.id()}")
    z_m: float | None = None
    if space.Representation is not None:
        settings = ifcopenshell.geom.settings()
        settings.set("use-world-coords", True)
        try:
            shape = ifcopenshell.geom.create_shape(settings, space)
            # a product's shape with these settings is a triangulation_element (see tessellation.py)
            geometry = cast(ifcopenshell_wrapper.triangulation, getattr(shape, "geometry", shape))
            vertices = ifcopenshell.util.shape.get_vertices(geometry)
            if len(vertices):
                z_m = float(np.asarray(vertices)[:, 2].min())
        except RuntimeError:
            z_m = None  # no geometry the kernel builds: its placement is its floor
    if z_m is None and space.ObjectPlacement is not None:
        z_m = (
            float(ifcopenshell.util.placement.get_local_placement(space.ObjectPlacement)[2, 3]) * unit_scale_m
        )
    return None if z_m is None else RoomFloor(z_m, room)


def cut_at_room_floor(shape: ElementShape, floor: RoomFloor | None) -> tuple[ElementShape, str | None]:
    """``shape`` cut at ``floor`` when it reaches deeper under it than :data:`FLOOR_BUILD_UP_M` and stands
    mostly above it, with a note saying so; else ``shape`` as it is and None."""
    if floor is None:
        return shape, None
    matrix = np.asarray(shape.placement_world_m, dtype=float)
    geometry = shape.geometry
    heights = geometry.vertices_local_m @ matrix[2, :3] + matrix[2, 3]  # IFC world z of each vertex
    below_m, above_m = floor.z_m - float(heights.min()), float(heights.max()) - floor.z_m
    if below_m <= FLOOR_BUILD_UP_M or below_m >= above_m:
        return shape, None
    # the floor as a plane of the element's frame: world z ≥ floor, as normal · local ≥ offset
    normal, offset = matrix[2, :3], floor.z_m - float(matrix[2, 3])
    cut = _cut(geometry, normal, offset)
    if cut is None:
        return shape, None
    note = (
        f"drawn {below_m:.3f} m under the floor of the room that holds it ({floor.room}): cut at that floor, "
        "what a site builds of it (a room's content stands on its floor)"
    )
    return ElementShape(shape.step_id, shape.placement_world_m, cut), note


def _cut(geometry: Geometry, normal: np.ndarray, offset: float) -> Geometry | None:
    """The part of ``geometry`` on the side of the plane ``normal · x = offset`` the normal points to; a
    closed solid without face styles capped (manifold3d), anything else clipped; None when nothing is left."""
    plane = ",".join(f"{value:.6f}" for value in (*normal, offset))
    geometry_id = f"{geometry.geometry_id}:cut@{plane}"
    if len(geometry.face_style_ids) == 0:
        solid = to_manifold(TriMesh(geometry.vertices_local_m, geometry.faces))
        if solid is not None:
            unit = normal / np.linalg.norm(normal)
            kept = solid.trim_by_plane(tuple(float(v) for v in unit), offset / float(np.linalg.norm(normal)))
            if kept.is_empty():
                return None
            mesh = manifold_to_mesh(kept)
            return Geometry(geometry_id, mesh.vertices, mesh.faces)
    vertices, faces, source = clip_triangles(geometry.vertices_local_m, geometry.faces, normal, offset)
    if len(faces) == 0:
        return None
    styles = geometry.face_style_ids[source] if len(geometry.face_style_ids) else geometry.face_style_ids
    return Geometry(geometry_id, vertices, faces, styles)


def clip_triangles(
    vertices: np.ndarray, faces: np.ndarray, normal: np.ndarray, offset: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The triangles' parts where ``normal · x ≥ offset``: (vertices, faces, the source face of each face).
    A triangle across the plane keeps its part as one or two triangles wound as it was; the new vertices
    lie on its edges (unwelded); a vertex on the plane counts as kept; only the vertices the faces use."""
    vertices = np.asarray(vertices, dtype=float)
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    distance = vertices @ np.asarray(normal, dtype=float) - offset
    inside = distance[faces] >= -ON_PLANE_M
    count = inside.sum(axis=1)
    out_vertices = [vertices]
    out_faces = [faces[count == 3]]
    sources = [np.flatnonzero(count == 3)]
    next_index = len(vertices)
    for kept in (1, 2):
        rows = np.flatnonzero(count == kept)
        # roll each triangle so that its odd vertex (the one kept, or the one cut off) comes first
        odd = np.argmax(inside[rows] if kept == 1 else ~inside[rows], axis=1)
        order = (odd[:, None] + np.arange(3)[None, :]) % 3
        tri = np.take_along_axis(faces[rows], order, axis=1)
        d = distance[tri]
        # what only touches the plane from below keeps no area
        touching = d[:, 0] <= ON_PLANE_M if kept == 1 else np.maximum(d[:, 1], d[:, 2]) <= ON_PLANE_M
        rows, tri, d = rows[~touching], tri[~touching], d[~touching]
        if len(rows) == 0:
            continue
        first, second = _on_edge(vertices, tri, d, 0, 1), _on_edge(vertices, tri, d, 0, 2)
        n = len(rows)
        a, b = next_index + np.arange(n), next_index + n + np.arange(n)  # on edges 0-1 and 0-2
        out_vertices += [first, second]
        next_index += 2 * n
        if kept == 1:  # the odd vertex is kept: (v0, on 0-1, on 0-2)
            out_faces.append(np.stack([tri[:, 0], a, b], axis=1))
            sources.append(rows)
        else:  # the odd vertex is cut off: the quad (on 0-1, v1, v2, on 0-2) as two triangles
            out_faces += [np.stack([a, tri[:, 1], tri[:, 2]], axis=1), np.stack([a, tri[:, 2], b], axis=1)]
            sources += [rows, rows]
    used, compact = np.unique(np.concatenate(out_faces), return_inverse=True)  # only what the faces use
    return np.concatenate(out_vertices)[used], compact.reshape(-1, 3), np.concatenate(sources)


def _on_edge(vertices: np.ndarray, tri: np.ndarray, d: np.ndarray, i: int, j: int) -> np.ndarray:
    """Where each triangle's edge from vertex ``i`` to ``j`` crosses the plane (``d``: signed distances)."""
    t = (d[:, i] / (d[:, i] - d[:, j]))[:, None]
    return vertices[tri[:, i]] + t * (vertices[tri[:, j]] - vertices[tri[:, i]])
