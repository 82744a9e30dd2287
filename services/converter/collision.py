"""Collision shapes of moving bodies: a set of convex parts per element, cheap where the IFC allows it.

Components are carried by robots, and PyBullet collides a moving body as convex shapes only. So:

1. ``collision_from_representation`` — an element whose Body is made of straight extrusions
   (``IfcExtrudedAreaSolid``, also behind ``IfcMappedItem`` / type representation maps) of parametric
   profiles is split exactly: each convex piece of the profile (``profiles.py``) becomes a convex prism. An
   I-section is three boxes, in a few milliseconds including the checks. The pieces are validated against
   the tessellated mesh (bounds, volume, every piece inside the mesh) because fillets, slopes, openings and
   profile conventions can make the parametric shape differ from what the element really is. Openings
   that remove less than ``1 - 1/MAX_VOLUME_RATIO`` of the volume (bolt holes) are filled in by the pieces.
2. ``collision_from_mesh`` — anything else: a convex mesh keeps one hull. A concave one is taken apart
   into its separate solids (brep items, the parts of a window); each convex solid keeps its hull, each
   closed concave solid is cut along its own face planes into convex pieces (:mod:`.plane_split`: walls
   with openings become exact boxes in milliseconds), and only what is left — concave pieces that are not
   closed — goes to PyBullet's V-HACD (``p.vhacd``) on a copy with its short axes stretched, parts clipped
   to the mesh's bounds (see ``vhacd_parts`` and the measurements above ``DEFAULT_VHACD_RESOLUTION``),
   within a time budget per element. On the acad2010 sample this takes 0.9 s for all 52 elements where
   V-HACD alone took 6 s.

Frames and units: every input and output mesh is in the element's local frame (its object placement), in
metres — the frame of ``ifcopenshell.geom`` with ``use-world-coords`` False. IFC placements are composed in
IFC length units and their translations multiplied by ``unit_scale_m``.

Everything here is pure apart from the temporary files V-HACD needs; the caller caches by geometry id so
identical geometry is decomposed once.
"""

from __future__ import annotations

import contextlib
import ctypes
import dataclasses
import importlib
import logging
import os
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

import ifcopenshell
import ifcopenshell.util.placement
import ifcopenshell.util.representation
import numpy as np
import trimesh
from scipy.spatial import ConvexHull, HalfspaceIntersection, QhullError

from bimbot.services.converter.plane_split import split_into_convex_parts
from bimbot.services.converter.profiles import outline_tolerance_m, profile_polygons
from bimbot.shared.manifest import CollisionMethod

logger = logging.getLogger(__name__)

# V-HACD settings (see ``vhacd_parts``). V-HACD never goes below 64 voxels along the longest axis, so the
# voxel budget "resolution" hardly matters at 10,000–100,000; what decides time and quality is how far the
# short axes are stretched first. Measured with ``bench/collision.py --sweep`` and the acad2010 sample
# (time, parts, parts' volume / mesh volume, where 1.00 is exact and one hull of the I-beam is 8.5):
#                                  stretched to 1.0 (cube)   0.5 (chosen)          0.25
#   I-beam IPE400-like, 6 m         0.41 s  3  1.44           0.19 s  3  1.93       0.08 s  3  4.17
#   U300 channel, 3 m               0.38 s  4  1.10           0.21 s  4  1.32       0.09 s  3  2.57
#   L100 angle, 1 m                 0.19 s  2  1.07           0.09 s  2  1.18       0.04 s  2  1.69
#   window (faceted brep)           1.15 s  8  1.29           0.54 s  7  1.42       0.30 s  8  1.57
#   walls with openings (6)         0.26–0.76 s  2–4          0.04–0.16 s  1–3      0.02–0.08 s  1–2
#   13 concave acad2010 meshes, total  6.0 s                  2.1 s                 1.1 s
# Plain p.vhacd at its default resolution 100,000 on the I-beam: 0.43 s, 3 parts, 4.31; at 10,000: one
# hull. The profile path does the same I-beam exactly in ~5 ms.
DEFAULT_VHACD_RESOLUTION = 10_000
DEFAULT_MIN_AXIS_FRACTION = 0.5

CONVEX_VOLUME_TOL = 0.01  # a watertight mesh whose hull is ≤ 1 % larger than itself counts as convex
BOUNDS_REL_TOL = 1e-4  # pieces' bounds vs mesh bounds, × the mesh's bbox diagonal (+ outline tolerance)
MIN_VOLUME_RATIO = 0.90  # pieces may miss fillet material ...
MAX_VOLUME_RATIO = 1.05  # ... or add rounded edges and filled small holes, but not more
MIN_THICKNESS_M = 1e-3  # a mesh whose hull is thinner on average collides as a box this thick
VHACD_BUDGET_S = 1.0  # per element; concave open pieces beyond it get one hull each (noted)
MAX_PARTS = 32  # collision parts per element; more separate solids are merged into this many hulls
_MAX_MAPPING_DEPTH = 8
_FD_LOCK = threading.Lock()  # guards the process-wide stdout/stderr swap, see _silenced


@dataclass(frozen=True)
class CollisionShape:
    """Convex parts of one element's collision shape, element-local frame, metres."""

    method: CollisionMethod
    parts: tuple[trimesh.Trimesh, ...]
    note: str | None = None  # e.g. why a fallback was taken


class _NotDecomposableError(Exception):
    """The body cannot be decomposed from its representation; the message says why."""


# --- public API --------------------------------------------------------------------------------------------


def collision_shape(
    element: ifcopenshell.entity_instance, mesh_local: trimesh.Trimesh, unit_scale_m: float
) -> CollisionShape:
    """The element's collision shape: exact profile pieces when possible, else hull or V-HACD of the mesh."""
    try:
        return _shape_from_representation(element, mesh_local, unit_scale_m)
    except _NotDecomposableError as exc:
        reason = str(exc)
    fallback = collision_from_mesh(mesh_local)
    note = f"profile decomposition not used: {reason}"
    return dataclasses.replace(fallback, note=f"{note}; {fallback.note}" if fallback.note else note)


def collision_from_representation(
    element: ifcopenshell.entity_instance, mesh_local: trimesh.Trimesh, unit_scale_m: float
) -> CollisionShape | None:
    """Exact convex prisms of an element made of extruded parametric profiles, or None (reason logged)."""
    try:
        return _shape_from_representation(element, mesh_local, unit_scale_m)
    except _NotDecomposableError as exc:
        logger.debug("%s: no profile decomposition: %s", _label(element), exc)
        return None


def collision_from_mesh(
    mesh_local: trimesh.Trimesh,
    *,
    vhacd_resolution: int = DEFAULT_VHACD_RESOLUTION,
    vhacd_min_axis_fraction: float = DEFAULT_MIN_AXIS_FRACTION,
) -> CollisionShape:
    """Convex parts of a mesh: one hull when convex; else per separate solid, a hull if it is convex, plane
    cuts along its own faces if it is a closed manifold (:mod:`.plane_split`), V-HACD for what is left."""
    if len(mesh_local.faces) == 0:
        raise ValueError("empty mesh has no collision shape")
    hull = _mesh_hull(mesh_local)
    if hull is None or not hull.volume > MIN_THICKNESS_M * hull.area / 2.0:  # mean thickness under 1 mm
        return CollisionShape(CollisionMethod.CONVEX_HULL, (_thick_box(mesh_local),), "flat mesh: thin box")
    if _is_convex(mesh_local, hull):
        return CollisionShape(CollisionMethod.CONVEX_HULL, (hull,))
    parts: list[trimesh.Trimesh] = []
    used_vhacd = False
    notes: list[str] = []
    vhacd_deadline = time.perf_counter() + VHACD_BUDGET_S
    for solid in _solids(mesh_local):
        allow_vhacd = time.perf_counter() < vhacd_deadline
        solid_parts, by_vhacd, note = _solid_parts(
            solid, vhacd_resolution, vhacd_min_axis_fraction, allow_vhacd
        )
        parts.extend(solid_parts)
        used_vhacd |= by_vhacd
        if note:
            notes.append(note)
    if not parts:
        return CollisionShape(CollisionMethod.CONVEX_HULL, (hull,), "no convex parts found: one hull")
    if len(parts) > MAX_PARTS:
        parts = _merge_parts(parts, MAX_PARTS)
    method = CollisionMethod.VHACD if used_vhacd else CollisionMethod.MESH_SPLIT
    return CollisionShape(method, tuple(parts), "; ".join(dict.fromkeys(notes)) or None)


def _mesh_hull(mesh: trimesh.Trimesh) -> trimesh.Trimesh | None:
    return _hull(mesh.vertices)


def _solids(mesh: trimesh.Trimesh) -> list[trimesh.Trimesh]:
    """The mesh's separate pieces (connected by shared edges): items of a brep, parts of a window."""
    pieces = mesh.split(only_watertight=False, repair=False)  # repair would fan-fill holes, wrongly
    return [piece for piece in pieces if len(piece.faces) >= 4] or [mesh]


def _solid_parts(
    solid: trimesh.Trimesh, vhacd_resolution: int, vhacd_min_axis_fraction: float, allow_vhacd: bool = True
) -> tuple[list[trimesh.Trimesh], bool, str | None]:
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
        return [hull], False, f"V-HACD time budget ({VHACD_BUDGET_S:g} s) spent: one hull for a concave piece"
    try:
        parts = vhacd_parts(solid, resolution=vhacd_resolution, min_axis_fraction=vhacd_min_axis_fraction)
    except (OSError, RuntimeError, ValueError) as exc:
        logger.warning("V-HACD failed (%s); using one hull of a concave piece", exc)
        return [hull], False, f"V-HACD failed ({exc}): one hull for a concave piece"
    return (parts or [hull]), bool(parts), None


def _merge_parts(parts: list[trimesh.Trimesh], limit: int) -> list[trimesh.Trimesh]:
    """At most ``limit`` hulls: parts grouped along the longest axis of their centres, one hull per group."""
    centres = np.array([part.bounds.mean(axis=0) for part in parts])
    axis = int(np.argmax(np.ptp(centres, axis=0)))
    order = np.argsort(centres[:, axis])
    merged = []
    for group in np.array_split(order, limit):
        points = np.vstack([parts[index].vertices for index in group])
        hull = _hull(points)
        if hull is not None:
            merged.append(hull)
    return merged


def vhacd_parts(
    mesh: trimesh.Trimesh,
    *,
    resolution: int = DEFAULT_VHACD_RESOLUTION,
    min_axis_fraction: float = DEFAULT_MIN_AXIS_FRACTION,
    **vhacd_params: float,
) -> list[trimesh.Trimesh]:
    """Convex parts of ``mesh`` by PyBullet's V-HACD, clipped to the mesh's bounds.

    V-HACD runs on a copy of the mesh (temporary OBJ files; its console output is silenced) whose short
    axes are stretched to at least ``min_axis_fraction`` of the longest; the parts are scaled back, which
    keeps them convex. V-HACD never voxelises coarser than 64 voxels along the longest axis and
    ``resolution`` only adds voxels beyond that, so for a 6 m beam a voxel is 94 mm, wider than a flange:
    the section is lost and the beam becomes one hull. Stretched, the section gets 32 voxels or more.

    The longest axis is put on Z while V-HACD runs: its voxeliser takes the voxel size from the wrong axis
    when the two largest extents are equal and not on Z (a 400×400×20 mm plate became 10^8 voxels and 12 s
    instead of 16,000 voxels and 0.06 s).

    Voxel hulls overshoot the surface by up to half a voxel; clipping to the mesh's axis-aligned bounds keeps
    a member from poking into its neighbours at the ends. ``vhacd_params`` are passed to ``p.vhacd``.
    """
    lower, upper = mesh.bounds
    extents = np.maximum(upper - lower, 1e-12)
    scale = np.maximum(1.0, min_axis_fraction * float(np.max(extents)) / extents)
    roll = 2 - int(np.argmax(extents * scale))  # cyclic, so handedness and face winding are kept
    centre = (lower + upper) / 2.0
    with tempfile.TemporaryDirectory(prefix="bimbot_vhacd_") as tmp:
        src, dst, log = (Path(tmp) / name for name in ("in.obj", "out.obj", "log.txt"))
        _write_obj(src, np.roll((mesh.vertices - centre) * scale, roll, axis=1), mesh.faces)
        pybullet = _pybullet()
        with _silenced(1):
            pybullet.vhacd(str(src), str(dst), str(log), resolution=int(resolution), **vhacd_params)
        if not dst.exists():
            raise RuntimeError("V-HACD wrote no output")
        groups = _read_obj_groups(dst)
    parts = []
    for vertices in groups:
        part = _hull(np.roll(vertices, -roll, axis=1) / scale + centre)
        if part is not None:
            parts.append(_clip_to_box(part, lower, upper))
    return parts


# --- representation path ----------------------------------------------------------------------------------


def _shape_from_representation(
    element: ifcopenshell.entity_instance, mesh_local: trimesh.Trimesh, unit_scale_m: float
) -> CollisionShape:
    representation = _body_representation(element)
    if representation is None:
        raise _NotDecomposableError("no Body representation")
    parts: list[trimesh.Trimesh] = []
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
    return CollisionShape(CollisionMethod.PROFILE_DECOMPOSITION, tuple(parts))


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
) -> list[trimesh.Trimesh]:
    """Convex prisms of the pieces of one IfcExtrudedAreaSolid, element frame, metres."""
    position = np.eye(4)
    if item.Position is not None:
        position = np.asarray(ifcopenshell.util.placement.get_axis2placement(item.Position), dtype=float)
    to_element = matrix @ position
    to_element[:3, 3] *= unit_scale_m
    direction = np.asarray(item.ExtrudedDirection.DirectionRatios, dtype=float)
    offset_m = direction / np.linalg.norm(direction) * float(item.Depth) * unit_scale_m
    prisms = []
    for polygon in polygons:
        base = np.column_stack([polygon, np.zeros(len(polygon))])
        points = np.vstack([base, base + offset_m])
        hull = _hull(points @ to_element[:3, :3].T + to_element[:3, 3])
        if hull is None:
            raise _NotDecomposableError("degenerate extrusion")
        prisms.append(hull)
    return prisms


def _validate(parts: list[trimesh.Trimesh], mesh: trimesh.Trimesh, outline_allowance_m: float) -> None:
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
    winding = _winding_numbers(mesh, np.array([part.center_mass for part in parts]))
    if np.any(np.abs(winding) < 0.5):
        raise _NotDecomposableError(f"{int(np.sum(np.abs(winding) < 0.5))} piece(s) lie outside the mesh")


def _winding_numbers(mesh: trimesh.Trimesh, points: np.ndarray) -> np.ndarray:
    """Generalised winding number of ``mesh`` at each point (≈1 inside, ≈0 outside; sum of solid angles)."""
    return np.array([_winding_number(mesh.triangles, point) for point in points])


def _winding_number(triangles: np.ndarray, point: np.ndarray) -> float:
    a, b, c = (triangles[:, k, :] - point for k in range(3))
    la, lb, lc = (np.linalg.norm(v, axis=1) for v in (a, b, c))
    numerator = np.einsum("ij,ij->i", a, np.cross(b, c))
    denominator = (
        la * lb * lc
        + np.einsum("ij,ij->i", a, b) * lc
        + np.einsum("ij,ij->i", b, c) * la
        + np.einsum("ij,ij->i", c, a) * lb
    )
    return float(np.sum(np.arctan2(numerator, denominator)) / (2.0 * np.pi))


# --- mesh path ---------------------------------------------------------------------------------------------


def _is_convex(mesh: trimesh.Trimesh, hull: trimesh.Trimesh) -> bool:
    """A closed mesh: its hull is at most 1 % larger. An open one (a brep item with a gap, which encloses no
    volume to compare): every vertex and face centre lies on the hull's surface, as on any convex shell."""
    if mesh.is_volume:
        return bool(hull.volume <= mesh.volume * (1.0 + CONVEX_VOLUME_TOL))
    normals = hull.face_normals
    offsets = -np.einsum("ij,ij->i", normals, hull.triangles[:, 0, :])
    tolerance = 1e-6 * float(np.linalg.norm(hull.extents)) + 1e-9
    points = np.vstack([mesh.vertices, mesh.triangles_center])
    distance_to_nearest_plane = np.max(points @ normals.T + offsets, axis=1)
    return bool(np.all(distance_to_nearest_plane >= -tolerance))


def _hull(points: np.ndarray) -> trimesh.Trimesh | None:
    """Convex hull of a point set (scipy's Qhull, outward winding); None when it is flat or too small.

    trimesh's ``convex_hull`` repairs normals through a face graph, which costs ~1 ms a hull; a hull's
    faces can be oriented directly, against its centroid.
    """
    points = np.asarray(points, dtype=float)
    if len(points) < 4:
        return None
    try:
        qhull = ConvexHull(points)
    except QhullError:
        return None
    if not qhull.volume > 0.0:
        return None
    vertices = points[qhull.vertices]
    remap = np.full(len(points), -1, dtype=np.int64)
    remap[qhull.vertices] = np.arange(len(qhull.vertices))
    faces = remap[qhull.simplices]
    triangles = vertices[faces]
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    inward = np.einsum("ij,ij->i", normals, triangles[:, 0] - vertices.mean(axis=0)) < 0
    faces[inward] = faces[inward][:, ::-1]
    return trimesh.Trimesh(vertices, faces, process=False)


def _clip_to_box(part: trimesh.Trimesh, lower: np.ndarray, upper: np.ndarray) -> trimesh.Trimesh:
    """The convex ``part`` intersected with the box [lower, upper]; ``part`` itself if that fails."""
    if np.all(part.bounds[0] >= lower) and np.all(part.bounds[1] <= upper):
        return part
    normals = part.face_normals
    offsets = -np.einsum("ij,ij->i", normals, part.triangles[:, 0, :])
    eye = np.eye(3)
    halfspaces = np.vstack(
        [np.column_stack([normals, offsets]), np.column_stack([eye, -upper]), np.column_stack([-eye, lower])]
    )
    margin = 0.01 * (upper - lower)
    inside = np.clip(part.center_mass, lower + margin, upper - margin)
    if np.any(halfspaces[:, :3] @ inside + halfspaces[:, 3] >= 0.0):
        return part
    try:
        clipped = _hull(HalfspaceIntersection(halfspaces, inside).intersections)
    except QhullError:
        return part
    return clipped if clipped is not None else part


def _thick_box(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """Oriented bounding box of a flat mesh, thickened to MIN_THICKNESS_M."""
    box = mesh.bounding_box_oriented
    extents = np.maximum(box.primitive.extents, MIN_THICKNESS_M)
    return trimesh.creation.box(extents=extents, transform=box.primitive.transform)


def _write_obj(path: Path, vertices: np.ndarray, faces: np.ndarray) -> None:
    lines = [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in vertices]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    path.write_text("\n".join(lines) + "\n", encoding="ascii")


def _read_obj_groups(path: Path) -> list[np.ndarray]:
    """Vertices used by each object ('o' / 'g' block) of an OBJ file (V-HACD writes one per hull)."""
    vertices: list[list[float]] = []
    groups: list[set[int]] = [set()]
    for line in path.read_text(encoding="ascii", errors="replace").splitlines():
        fields = line.split()
        if not fields:
            continue
        if fields[0] == "v":
            vertices.append([float(v) for v in fields[1:4]])
        elif fields[0] == "f":
            groups[-1].update(int(token.split("/")[0]) - 1 for token in fields[1:])
        elif fields[0] in ("o", "g") and groups[-1]:
            groups.append(set())
    table = np.asarray(vertices, dtype=float).reshape(-1, 3)
    return [table[sorted(group)] for group in groups if group]


def _pybullet() -> ModuleType:
    """pybullet, imported on first use: its import prints a build banner to stderr, kept out of CLI output."""
    if "pybullet" not in sys.modules:
        with _silenced(2):
            importlib.import_module("pybullet")
    return sys.modules["pybullet"]


@contextlib.contextmanager
def _silenced(fd: int) -> Iterator[None]:
    """Send file descriptor ``fd`` (1 stdout, 2 stderr) to /dev/null; a no-op if that is impossible.

    Used around C code that prints (V-HACD's progress, pybullet's banner). The descriptor is process-wide, so
    one lock serialises the swap between threads, and C's stdio buffers are flushed before it comes back.
    """
    stream = sys.stdout if fd == 1 else sys.stderr
    with _FD_LOCK:
        try:
            stream.flush()
            saved = os.dup(fd)
        except (OSError, ValueError, AttributeError):
            yield
            return
        devnull = os.open(os.devnull, os.O_WRONLY)
        try:
            os.dup2(devnull, fd)
            yield
        finally:
            _flush_c_stdio()
            os.dup2(saved, fd)
            os.close(saved)
            os.close(devnull)


def _flush_c_stdio() -> None:
    with contextlib.suppress(OSError, AttributeError, TypeError):
        ctypes.CDLL(None).fflush(None)


def _label(element: ifcopenshell.entity_instance) -> str:
    return f"{element.is_a()} {getattr(element, 'GlobalId', '')} #{element.id()}"
