"""Collision shapes of moving bodies: a set of convex parts per element, cheap where the IFC allows it.

Components are carried by robots, and PyBullet collides a moving body as convex shapes only. So:

1. ``collision_from_representation`` — an element whose Body is made of straight extrusions
   (``IfcExtrudedAreaSolid``, also behind ``IfcMappedItem`` / type representation maps) of parametric
   profiles is split exactly: each convex piece of the profile (``profiles.py``) becomes a convex prism. An
   I-section is three boxes, in a few milliseconds including the checks. The pieces are validated against
   the tessellated mesh (bounds, volume, every piece inside the mesh) because fillets, slopes, openings and
   profile conventions can make the parametric shape differ from what the element really is. Openings
   that remove less than ``1 - 1/MAX_VOLUME_RATIO`` of the volume (bolt holes) are filled in by the pieces.
2. ``extrusion_parts`` (:mod:`.prism_split`) — any other single straight extrusion (Revit's arbitrary
   profiles of lines and arcs, hollow sections with voids): the tessellated mesh is cut at mid-depth and
   its section split into convex pieces along its own edge lines, once per distinct section; validated
   like the parametric pieces.
3. ``collision_from_mesh`` — anything else: a convex mesh keeps one hull. A concave one is taken apart
   into its separate solids (brep items, the parts of a window); each convex solid keeps its hull, each
   closed concave solid is cut along its own face planes into convex pieces (:mod:`.plane_split`: walls
   with openings become exact boxes in milliseconds), and only what is left — concave pieces that are not
   closed — goes to PyBullet's V-HACD (``p.vhacd``, :mod:`.vhacd`) on a copy with its short axes
   stretched, parts clipped to the mesh's bounds, for at most a few pieces per element. On the acad2010
   sample this takes 0.9 s for all 52 elements where V-HACD alone took 6 s.

Frames and units: every input and output mesh is in the element's local frame (its object placement), in
metres — the frame of ``ifcopenshell.geom`` with ``use-world-coords`` False. IFC placements are composed in
IFC length units and their translations multiplied by ``unit_scale_m``.

Meshes are :class:`.mesh.TriMesh` (a ``trimesh.Trimesh`` is accepted as input). Everything here is pure
apart from the temporary files V-HACD needs; the caller caches by geometry id so identical geometry is
decomposed once, and passes a :class:`.prism_split.SectionCache` so identical sections are split once.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
from collections.abc import Iterator
from dataclasses import dataclass

import ifcopenshell
import ifcopenshell.util.placement
import ifcopenshell.util.representation
import numpy as np

from bimbot.shared.manifest import MAX_COLLISION_PARTS, CollisionMethod

from .mesh import MeshLike, TriMesh, as_trimesh_lite, convex_hull
from .part_merging import merge_nearest
from .placement import axis2placement_matrix
from .plane_split import split_into_convex_parts
from .prism_split import SectionCache, extrusion_parts
from .profiles import outline_tolerance_m, profile_polygons
from .vhacd import DEFAULT_MIN_AXIS_FRACTION, DEFAULT_VHACD_RESOLUTION, vhacd_parts

logger = logging.getLogger(__name__)

__all__ = [
    "CollisionShape",
    "collision_from_mesh",
    "collision_from_representation",
    "collision_shape",
    "vhacd_parts",
]

CONVEX_VOLUME_TOL = 0.01  # a watertight mesh whose hull is ≤ 1 % larger than itself counts as convex
OPEN_SHELL_GAP_FRACTION = 0.05  # an open convex shell may miss this much of its hull's surface (a gap)
BOUNDS_REL_TOL = 1e-4  # pieces' bounds vs mesh bounds, × the mesh's bbox diagonal (+ outline tolerance)
MIN_VOLUME_RATIO = 0.90  # pieces may miss fillet material ...
MAX_VOLUME_RATIO = 1.05  # ... or add rounded edges and filled small holes, but not more
MIN_THICKNESS_M = 1e-3  # a mesh whose hull is thinner on average collides as a box this thick
# V-HACD (0.1-0.5 s a piece) for at most this many concave open pieces of an element, the rest one hull each
# (noted): a count, not a time, so that a busy machine converts as a quiet one does
MAX_VHACD_PIECES = 3
MAX_PARTS = MAX_COLLISION_PARTS  # per element; more separate solids are merged into this many hulls
_MAX_MAPPING_DEPTH = 8


@dataclass(frozen=True)
class CollisionShape:
    """Convex parts of one element's collision shape, element-local frame, metres."""

    method: CollisionMethod
    parts: tuple[TriMesh, ...]
    note: str | None = None  # e.g. why a fallback was taken


class _NotDecomposableError(Exception):
    """The body cannot be decomposed from its representation; the message says why."""


# --- public API --------------------------------------------------------------------------------------------


def collision_shape(
    element: ifcopenshell.entity_instance,
    mesh_like: MeshLike,
    unit_scale_m: float,
    *,
    sections: SectionCache | None = None,
) -> CollisionShape:
    """The element's collision shape: exact profile pieces when possible, else the extrusion's section
    split, else hull, plane cuts or V-HACD of the mesh. ``sections`` shares section splits between calls."""
    mesh_local = as_trimesh_lite(mesh_like)
    try:
        return _shape_from_representation(element, mesh_local, unit_scale_m)
    except _NotDecomposableError as exc:
        reason = str(exc)
    try:
        return _shape_from_section(element, mesh_local, unit_scale_m, sections)
    except _NotDecomposableError as exc:
        logger.debug("%s: no section decomposition: %s", _label(element), exc)
    fallback = collision_from_mesh(mesh_local)
    note = f"profile decomposition not used: {reason}"
    return dataclasses.replace(fallback, note=f"{note}; {fallback.note}" if fallback.note else note)


def collision_from_representation(
    element: ifcopenshell.entity_instance, mesh_like: MeshLike, unit_scale_m: float
) -> CollisionShape | None:
    """Exact convex prisms of an element made of extruded parametric profiles, or None (reason logged)."""
    try:
        return _shape_from_representation(element, as_trimesh_lite(mesh_like), unit_scale_m)
    except _NotDecomposableError as exc:
        logger.debug("%s: no profile decomposition: %s", _label(element), exc)
        return None


def collision_from_mesh(
    mesh_like: MeshLike,
    *,
    vhacd_resolution: int = DEFAULT_VHACD_RESOLUTION,
    vhacd_min_axis_fraction: float = DEFAULT_MIN_AXIS_FRACTION,
) -> CollisionShape:
    """Convex parts of a mesh: one hull when convex; else per separate solid, a hull if it is convex, plane
    cuts along its own faces if it is a closed manifold (:mod:`.plane_split`), V-HACD for what is left."""
    mesh_local = as_trimesh_lite(mesh_like)
    if len(mesh_local.faces) == 0:
        raise ValueError("empty mesh has no collision shape")
    hull = _mesh_hull(mesh_local)
    if hull is None or not hull.volume > MIN_THICKNESS_M * hull.area / 2.0:  # mean thickness under 1 mm
        return CollisionShape(CollisionMethod.CONVEX_HULL, (_thick_box(mesh_local),), "flat mesh: thin box")
    if _is_convex(mesh_local, hull):
        return CollisionShape(CollisionMethod.CONVEX_HULL, (hull,))
    parts: list[TriMesh] = []
    used_vhacd = False
    notes: list[str] = []
    vhacd_left = MAX_VHACD_PIECES
    for solid in _solids(mesh_local):
        solid_parts, by_vhacd, note = _solid_parts(
            solid, vhacd_resolution, vhacd_min_axis_fraction, vhacd_left > 0
        )
        vhacd_left -= by_vhacd
        parts.extend(solid_parts)
        used_vhacd |= by_vhacd
        if note:
            notes.append(note)
    if not parts:
        return CollisionShape(CollisionMethod.CONVEX_HULL, (hull,), "no convex parts found: one hull")
    if len(parts) > MAX_PARTS:
        parts = merge_parts(parts, MAX_PARTS)
    method = CollisionMethod.VHACD if used_vhacd else CollisionMethod.MESH_SPLIT
    return CollisionShape(method, tuple(parts), "; ".join(dict.fromkeys(notes)) or None)


def _mesh_hull(mesh: TriMesh) -> TriMesh | None:
    return convex_hull(mesh.vertices)


def _solids(mesh: TriMesh) -> list[TriMesh]:
    """The mesh's separate pieces (connected by shared edges): items of a brep, parts of a window."""
    pieces = mesh.split()  # no repair: it would fan-fill holes, wrongly
    return [piece for piece in pieces if len(piece.faces) >= 4] or [mesh]


def _solid_parts(
    solid: TriMesh, vhacd_resolution: int, vhacd_min_axis_fraction: float, allow_vhacd: bool = True
) -> tuple[list[TriMesh], bool, str | None]:
    """(convex parts, whether V-HACD made them, a note) for one connected piece."""
    hull = _mesh_hull(solid)
    if hull is None or hull.volume <= 0:
        return [_thick_box(solid)], False, None
    if _is_convex(solid, hull):
        return [hull], False, None
    split = split_into_convex_parts(solid)
    if split is not None:
        return split.parts, False, None
    if not allow_vhacd:
        return [hull], False, f"V-HACD run on {MAX_VHACD_PIECES} pieces already: one hull for a concave piece"
    try:
        parts = vhacd_parts(solid, resolution=vhacd_resolution, min_axis_fraction=vhacd_min_axis_fraction)
    except (OSError, RuntimeError, ValueError) as exc:
        logger.warning("V-HACD failed (%s); using one hull of a concave piece", exc)
        return [hull], False, f"V-HACD failed ({exc}): one hull for a concave piece"
    return (parts or [hull]), bool(parts), None


def merge_parts(parts: list[TriMesh], limit: int) -> list[TriMesh]:
    """At most ``limit`` hulls: parts grouped along the longest axis of their centres, one hull per group."""
    centres = np.array([part.bounds.mean(axis=0) for part in parts])
    axis = int(np.argmax(np.ptp(centres, axis=0)))
    order = np.argsort(centres[:, axis])
    merged = []
    for group in np.array_split(order, limit):
        points = np.vstack([parts[index].vertices for index in group])
        hull = convex_hull(points)
        if hull is not None:
            merged.append(hull)
    return merged


# --- representation path ----------------------------------------------------------------------------------


def _shape_from_representation(
    element: ifcopenshell.entity_instance, mesh_local: TriMesh, unit_scale_m: float
) -> CollisionShape:
    representation = _body_representation(element)
    if representation is None:
        raise _NotDecomposableError("no Body representation")
    parts: list[TriMesh] = []
    outline_allowance_m = 0.0
    for item, matrix in _resolved_items(representation, np.eye(4), depth=0):
        if item.is_a() != "IfcExtrudedAreaSolid":
            raise _NotDecomposableError(f"body item {item.is_a()} is not a straight extrusion")
        polygons = profile_polygons(item.SweptArea, unit_scale_m)
        if polygons is None:
            raise _NotDecomposableError(
                f"profile {item.SweptArea.is_a()} #{item.SweptArea.id()} is not decomposable"
            )
        parts.extend(_extrude(polygons, item, matrix, unit_scale_m))
        outline_allowance_m = max(outline_allowance_m, outline_tolerance_m(item.SweptArea, unit_scale_m))
    if not parts:
        raise _NotDecomposableError("empty Body representation")
    _validate(parts, mesh_local, outline_allowance_m)
    return _profile_pieces(parts)


def _shape_from_section(
    element: ifcopenshell.entity_instance,
    mesh_local: TriMesh,
    unit_scale_m: float,
    sections: SectionCache | None,
) -> CollisionShape:
    """Convex prisms of a body that is one straight extrusion, split from its tessellated section."""
    representation = _body_representation(element)
    if representation is None:
        raise _NotDecomposableError("no Body representation")
    items = list(_resolved_items(representation, np.eye(4), depth=0))
    if len(items) != 1 or items[0][0].is_a() != "IfcExtrudedAreaSolid":
        raise _NotDecomposableError("body is not one straight extrusion")
    item, matrix = items[0]
    to_element = _extrusion_frame(item, matrix, unit_scale_m)
    direction = np.asarray(item.ExtrudedDirection.DirectionRatios, dtype=float)
    direction = direction / np.linalg.norm(direction)
    if abs(float(direction[2])) < 1.0 - 1e-9:
        raise _NotDecomposableError("extrusion is not perpendicular to its profile")
    if direction[2] < 0:  # extruded along -z: the same prism, seen from its other end
        to_element = to_element @ np.diag([1.0, -1.0, -1.0, 1.0])
    parts = extrusion_parts(mesh_local, to_element, float(item.Depth) * unit_scale_m, sections)
    if parts is None:
        raise _NotDecomposableError("mesh is not a closed prism of its extrusion")
    _validate(parts, mesh_local, 0.0)
    return _profile_pieces(parts)


def _profile_pieces(parts: list[TriMesh]) -> CollisionShape:
    """The exact pieces of a decomposed body, merged into :data:`MAX_PARTS` hulls when there are more
    (:mod:`.part_merging`): physics keeps no more (a railing's 113 posts, balusters and rails collided as
    its whole box, and the joints the converter measured on its pieces were not what physics saw)."""
    if len(parts) <= MAX_PARTS:
        return CollisionShape(CollisionMethod.PROFILE_DECOMPOSITION, tuple(parts))
    note = f"{len(parts)} profile pieces merged into {MAX_PARTS} hulls, neighbours first"
    return CollisionShape(CollisionMethod.PROFILE_DECOMPOSITION, tuple(merge_nearest(parts, MAX_PARTS)), note)


def _extrusion_frame(
    item: ifcopenshell.entity_instance, matrix: np.ndarray, unit_scale_m: float
) -> np.ndarray:
    """4×4 from an extrusion's position frame (profile plane XY) to the element frame, metres."""
    position = np.eye(4)
    if item.Position is not None:
        position = axis2placement_matrix(item.Position)
    to_element = matrix @ position
    to_element[:3, 3] *= unit_scale_m
    return to_element


def _body_representation(element: ifcopenshell.entity_instance) -> ifcopenshell.entity_instance | None:
    """The element's 'Body' shape representation (the MODEL_VIEW one first)."""
    with contextlib.suppress(AttributeError, TypeError):  # IFC2X3 representations may lack a context
        for view in ("MODEL_VIEW", None):
            rep = ifcopenshell.util.representation.get_representation(element, "Model", "Body", view)
            if rep is not None:
                return rep
    shape = getattr(element, "Representation", None)
    for rep in getattr(shape, "Representations", None) or ():
        if rep.RepresentationIdentifier == "Body":
            return rep
    return None


def _resolved_items(
    representation: ifcopenshell.entity_instance, matrix: np.ndarray, depth: int
) -> Iterator[tuple[ifcopenshell.entity_instance, np.ndarray]]:
    """(item, 4×4 matrix into the element frame in IFC units), with mapped items expanded."""
    if depth > _MAX_MAPPING_DEPTH:
        raise _NotDecomposableError("mapped items nested too deeply")
    for item in representation.Items:
        if not item.is_a("IfcMappedItem"):
            yield item, matrix
            continue
        mapping = ifcopenshell.util.placement.get_mappeditem_transformation(item)
        if mapping is None:
            raise _NotDecomposableError(f"mapping target {item.MappingTarget.is_a()} is not 3D")
        source = item.MappingSource.MappedRepresentation
        yield from _resolved_items(source, matrix @ np.asarray(mapping, dtype=float), depth + 1)


def _extrude(
    polygons: list[np.ndarray], item: ifcopenshell.entity_instance, matrix: np.ndarray, unit_scale_m: float
) -> list[TriMesh]:
    """Convex prisms of the pieces of one IfcExtrudedAreaSolid, element frame, metres."""
    to_element = _extrusion_frame(item, matrix, unit_scale_m)
    direction = np.asarray(item.ExtrudedDirection.DirectionRatios, dtype=float)
    offset_m = direction / np.linalg.norm(direction) * float(item.Depth) * unit_scale_m
    prisms = []
    for polygon in polygons:
        base = np.column_stack([polygon, np.zeros(len(polygon))])
        points = np.vstack([base, base + offset_m])
        hull = convex_hull(points @ to_element[:3, :3].T + to_element[:3, 3])
        if hull is None:
            raise _NotDecomposableError("degenerate extrusion")
        prisms.append(hull)
    return prisms


def _validate(parts: list[TriMesh], mesh: TriMesh, outline_allowance_m: float) -> None:
    """Raise _NotDecomposableError when the pieces do not describe the mesh: bounds, volume, containment."""
    lower = np.min([part.bounds[0] for part in parts], axis=0)
    upper = np.max([part.bounds[1] for part in parts], axis=0)
    deviation_m = float(np.max(np.abs(np.vstack([lower, upper]) - mesh.bounds)))
    tolerance_m = BOUNDS_REL_TOL * float(np.linalg.norm(mesh.extents)) + outline_allowance_m
    if deviation_m > tolerance_m:
        raise _NotDecomposableError(
            f"pieces' bounds differ from the mesh by {deviation_m:.3g} m (> {tolerance_m:.3g} m)"
        )
    if mesh.is_volume:
        ratio = sum(part.volume for part in parts) / mesh.volume
        if not MIN_VOLUME_RATIO <= ratio <= MAX_VOLUME_RATIO:
            raise _NotDecomposableError(f"pieces' volume is {ratio:.3f} × the mesh volume")
    # a point inside each convex piece: the mean of its vertices (its centre of mass costs ten integrals)
    winding = _winding_numbers(mesh, np.array([part.vertices.mean(axis=0) for part in parts]))
    if np.any(np.abs(winding) < 0.5):
        raise _NotDecomposableError(f"{int(np.sum(np.abs(winding) < 0.5))} piece(s) lie outside the mesh")


def _winding_numbers(mesh: TriMesh, points: np.ndarray) -> np.ndarray:
    """Generalised winding number of ``mesh`` at each point (≈1 inside, ≈0 outside; sum of solid angles,
    Van Oosterom & Strackee), all points at once."""
    corners = mesh.triangles[None, :, :, :] - np.asarray(points, dtype=float)[:, None, None, :]
    a, b, c = corners[:, :, 0, :], corners[:, :, 1, :], corners[:, :, 2, :]
    la, lb, lc = (np.sqrt(np.einsum("ptj,ptj->pt", v, v)) for v in (a, b, c))
    bc = np.stack(
        (
            b[..., 1] * c[..., 2] - b[..., 2] * c[..., 1],
            b[..., 2] * c[..., 0] - b[..., 0] * c[..., 2],
            b[..., 0] * c[..., 1] - b[..., 1] * c[..., 0],
        ),
        axis=-1,
    )
    numerator = np.einsum("ptj,ptj->pt", a, bc)
    denominator = (
        la * lb * lc
        + np.einsum("ptj,ptj->pt", a, b) * lc
        + np.einsum("ptj,ptj->pt", b, c) * la
        + np.einsum("ptj,ptj->pt", c, a) * lb
    )
    return np.arctan2(numerator, denominator).sum(axis=1) / (2.0 * np.pi)


# --- mesh path ---------------------------------------------------------------------------------------------


def _is_convex(mesh: TriMesh, hull: TriMesh) -> bool:
    """A closed mesh: its hull is at most 1 % larger. An open one (a brep item with a gap, which encloses no
    volume to compare): it covers nearly all of the hull's surface, and every vertex and face centre lies on
    that surface, as on any convex shell. (Three sides of a box lie on its hull too, and are no box.)"""
    if mesh.is_volume:
        return bool(hull.volume <= mesh.volume * (1.0 + CONVEX_VOLUME_TOL))
    if mesh.area < hull.area * (1.0 - OPEN_SHELL_GAP_FRACTION):
        return False
    faces = hull.valid_faces  # a degenerate hull face has no plane; its zero normal would pass every point
    normals = hull.face_normals[faces]
    offsets = -np.einsum("ij,ij->i", normals, hull.triangles[faces, 0, :])
    tolerance = 1e-6 * float(np.linalg.norm(hull.extents)) + 1e-9
    points = np.vstack([mesh.vertices, mesh.triangles_center])
    distance_to_nearest_plane = np.max(points @ normals.T + offsets, axis=1)
    return bool(np.all(distance_to_nearest_plane >= -tolerance))


def _thick_box(mesh: TriMesh) -> TriMesh:
    """Oriented bounding box of a flat mesh, thickened to MIN_THICKNESS_M: the plane from the vertices'
    principal axes, the least rectangle in it from trimesh (imported for this rare case: it needs scipy),
    as trimesh's own 3D oriented box fails on exactly coplanar points."""
    import trimesh.bounds
    import trimesh.creation

    points = np.asarray(mesh.vertices, dtype=float)
    centre = points.mean(axis=0)
    axes = np.linalg.svd(points - centre, full_matrices=True)[2]  # rows: in-plane, in-plane, normal
    planar = (points - centre) @ axes[:2].T
    to_box_2d, size_2d = trimesh.bounds.oriented_bounds_2D(planar)
    box_to_plane_2d = np.linalg.inv(to_box_2d)
    in_plane = box_to_plane_2d[:2, :2].T @ axes[:2]  # the rectangle's axes in the mesh frame
    transform = np.eye(4)
    transform[:3, 0], transform[:3, 1] = in_plane[0], in_plane[1]
    transform[:3, 2] = np.cross(in_plane[0], in_plane[1])
    height = float(np.ptp((points - centre) @ transform[:3, 2]))
    transform[:3, 3] = centre + box_to_plane_2d[:2, 2] @ axes[:2]
    extents = np.maximum([*size_2d, height], MIN_THICKNESS_M)
    solid = trimesh.creation.box(extents=extents, transform=transform)
    return TriMesh(np.asarray(solid.vertices, dtype=float), np.asarray(solid.faces, dtype=np.int64))


def _label(element: ifcopenshell.entity_instance) -> str:
    return f"{element.is_a()} {getattr(element, 'GlobalId', '')} #{element.id()}"
