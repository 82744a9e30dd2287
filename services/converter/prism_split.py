"""Convex parts of a straight extrusion from its tessellated cross-section, decomposed once per section.

Most steel members and many slabs are one ``IfcExtrudedAreaSolid`` of a profile that ``profiles.py`` does
not know: Revit writes its sections (channels, angles, hollow sections, filleted I-sections) as arbitrary
closed profiles of lines and arcs, with voids for the hollow ones. Such a body is a prism, so its convex
decomposition is a 2D one: the mesh is cut at mid-depth (manifold3d ``slice``), giving the section exactly as
IfcOpenShell tessellated it, holes included; the section is split greedily by lines (the same rule as
:mod:`.plane_split` in 3D: cut the piece whose hull exceeds it most, by the line, among the section's own
axes and edge directions at its vertices, that makes the two hulls smallest; keep pieces within
``concavity_tol`` of their hull); each piece's hull is extruded back over the depth.

A 3D cut of a prism along a plane that contains the extrusion direction is exactly this 2D cut, so the
parts are those the 3D search would reach, without its time budget (which cut the search short on these
members and left hollow sections filled in) and at a fraction of the cost: the greedy search runs on a few
dozen 2D vertices instead of a mesh. Members of the same section and different lengths share the 2D
decomposition through :class:`SectionCache`.

Pure: numpy and manifold3d, no files. The caller validates the parts against the mesh.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import manifold3d
import numpy as np

from bimbot.shared.manifest import MAX_COLLISION_PARTS

from .mesh import TriMesh, convex_hull

CONCAVITY_TOL = 0.05  # a piece whose hull is ≤ 5 % larger than itself is convex enough (as plane_split)
MAX_PARTS = MAX_COLLISION_PARTS
OFFSETS_PER_DIRECTION = 24  # cut positions tried per direction (vertex positions, evenly thinned)
EXTRA_DIRECTIONS = 3  # dominant edge directions tried besides the section's own x and y axes
LINE_PREFERENCE = 0.1  # a cut along an edge line wins if its hulls exceed the best cut's by ≤ this × hull
MIN_FAMILY_SHARE = 0.05  # an edge direction is dominant with this share of the perimeter (arcs are not)
PLANE_REL_TOL = 1e-6  # vertices within this × depth of the end planes lie on them
AREA_REL_TOL = 1e-4  # section area × depth must equal the mesh volume to this (it is a prism)
KEY_DIGITS = 7  # section coordinates rounded to 0.1 µm for the cache key

Polygon = np.ndarray  # (k, 2), counter-clockwise, convex


@dataclass
class SectionCache:
    """Convex pieces by section (rounded contours): one decomposition per distinct section."""

    pieces: dict[bytes, list[Polygon]] = field(default_factory=dict)
    hits: int = 0


def extrusion_parts(
    mesh: TriMesh, to_element: np.ndarray, depth_m: float, cache: SectionCache | None = None
) -> list[TriMesh] | None:
    """Convex prisms of ``mesh`` when it is the straight extrusion of a section along +z of the frame
    ``to_element`` (4×4, extrusion frame → element frame, metres) over ``[0, depth_m]``; else None."""
    section = cross_section(mesh, to_element, depth_m)
    if section is None:
        return None
    key = _section_key(section)
    pieces = cache.pieces.get(key) if cache is not None else None
    if pieces is None:
        pieces = convex_pieces(section)
        if cache is not None:
            cache.pieces[key] = pieces
    elif cache is not None:
        cache.hits += 1
    parts = []
    for polygon in pieces:
        base = np.column_stack([polygon, np.zeros(len(polygon))])
        points = np.vstack([base, base + np.array([0.0, 0.0, depth_m])])
        part = convex_hull(points @ to_element[:3, :3].T + to_element[:3, 3])
        if part is None:
            return None
        parts.append(part)
    return parts or None


def cross_section(mesh: TriMesh, to_element: np.ndarray, depth_m: float) -> manifold3d.CrossSection | None:
    """The section of a closed prism mesh at mid-depth, in the extrusion frame; None when the mesh is not a
    closed prism between z = 0 and z = depth (openings, clippings, open shells)."""
    if not depth_m > 0.0 or not mesh.is_volume:
        return None
    inverse = np.linalg.inv(to_element)
    local = mesh.vertices @ inverse[:3, :3].T + inverse[:3, 3]
    z = local[:, 2]
    tolerance = PLANE_REL_TOL * max(depth_m, 1.0)
    if not np.all((np.abs(z) <= tolerance) | (np.abs(z - depth_m) <= tolerance)):
        return None
    solid = manifold3d.Manifold(
        manifold3d.Mesh64(vert_properties=np.ascontiguousarray(local), tri_verts=mesh.faces.astype(np.uint64))
    )
    if solid.status() != manifold3d.Error.NoError or solid.is_empty():
        return None
    section = solid.slice(depth_m / 2.0)
    if section.is_empty() or abs(section.area() * depth_m - mesh.volume) > AREA_REL_TOL * mesh.volume:
        return None
    return section


def convex_pieces(
    section: manifold3d.CrossSection, *, concavity_tol: float = CONCAVITY_TOL, max_parts: int = MAX_PARTS
) -> list[Polygon]:
    """Convex hulls of the pieces of ``section`` after greedy line cuts (see the module docstring)."""
    directions, lines = candidate_directions(section)
    open_pieces = [(_excess(piece), piece) for piece in section.decompose()]
    final: list[manifold3d.CrossSection] = []
    negligible = 1e-9 * section.area()
    while open_pieces and len(final) + len(open_pieces) < max_parts:
        open_pieces.sort(key=lambda item: item[0])
        excess, piece = open_pieces.pop()
        if piece.area() <= negligible:
            continue
        if excess <= concavity_tol * piece.area():
            final.append(piece)
            final.extend(item[1] for item in open_pieces)
            open_pieces = []
            break
        halves = _best_cut(piece, directions, lines)
        if halves is None:
            final.append(piece)
            continue
        for half in halves:
            open_pieces.extend((_excess(part), part) for part in half.decompose())
    final.extend(item[1] for item in open_pieces)
    merged = merge_pieces([piece for piece in final if piece.area() > negligible], concavity_tol)
    return [_hull_polygon(piece) for piece in merged]


def merge_pieces(
    pieces: list[manifold3d.CrossSection], concavity_tol: float = CONCAVITY_TOL
) -> list[manifold3d.CrossSection]:
    """Fewer pieces: greedy cuts leave slivers (a fillet cut off a flange) that a neighbour can take in
    while staying within ``concavity_tol`` of its hull; the pair whose union is closest to its hull is
    merged first, until no pair can be."""
    pieces = list(pieces)
    areas = [piece.area() for piece in pieces]
    while len(pieces) > 1:
        best: tuple[float, int, int] | None = None
        for i in range(len(pieces)):
            for j in range(i + 1, len(pieces)):
                area = areas[i] + areas[j]
                excess = (pieces[i] + pieces[j]).hull().area() - area
                if excess <= concavity_tol * area and (best is None or excess / area < best[0]):
                    best = (excess / area, i, j)
        if best is None:
            break
        _, i, j = best
        pieces[i] = pieces[i] + pieces[j]
        areas[i] += areas[j]
        del pieces[j], areas[j]
    return pieces


def candidate_directions(section: manifold3d.CrossSection) -> tuple[np.ndarray, list[np.ndarray]]:
    """Unit normals of the cutting lines (x, y, then the section's dominant edge directions) and, per
    normal, the offsets of the section's straight edges along it (the lines its own edges lie on)."""
    normals: list[np.ndarray] = []
    offsets: list[np.ndarray] = []
    lengths: list[float] = []
    for contour in section.to_polygons():
        edges = np.roll(contour, -1, axis=0) - contour
        length = np.hypot(edges[:, 0], edges[:, 1])
        keep = length > 0
        normal = np.column_stack([-edges[keep, 1], edges[keep, 0]]) / length[keep, None]
        flip = np.take_along_axis(normal, np.argmax(np.abs(normal), axis=1)[:, None], axis=1)[:, 0] < 0
        normal[flip] *= -1.0  # n and -n: one family of lines
        normals.append(normal)
        offsets.append(np.einsum("ij,ij->i", normal, contour[keep]))
        lengths.extend(length[keep])
    edge_normals, edge_offsets = np.vstack(normals), np.concatenate(offsets)
    edge_lengths = np.asarray(lengths)
    families: dict[tuple[float, float], float] = {}
    for normal, length in zip(np.round(edge_normals, 3), edge_lengths, strict=True):
        key = (float(normal[0]), float(normal[1]))
        families[key] = families.get(key, 0.0) + float(length)
    directions = [np.array([1.0, 0.0]), np.array([0.0, 1.0])]
    perimeter = float(edge_lengths.sum())
    for key, length in sorted(families.items(), key=lambda item: -item[1]):
        if len(directions) >= 2 + EXTRA_DIRECTIONS or length < MIN_FAMILY_SHARE * perimeter:
            break
        direction = np.array(key) / np.hypot(*key)
        if all(abs(float(direction @ known)) < 0.999 for known in directions):
            directions.append(direction)
    lines = [edge_offsets[np.abs(edge_normals @ direction) > 1.0 - 1e-9] for direction in directions]
    return np.array(directions), lines


def _best_cut(
    piece: manifold3d.CrossSection, directions: np.ndarray, lines: list[np.ndarray]
) -> tuple[manifold3d.CrossSection, manifold3d.CrossSection] | None:
    """The two sides of the line cut that makes their hulls smallest, unless every cut makes them larger
    (a cut that does not shrink them is taken when none does: a ring needs two cuts before they shrink)."""
    vertices = np.vstack(piece.to_polygons())
    hull_area = piece.hull().area()
    lower, upper = vertices.min(axis=0), vertices.max(axis=0)
    reach = float(np.linalg.norm(upper - lower)) + 1.0
    centre = (lower + upper) / 2.0
    best: tuple[float, manifold3d.CrossSection, manifold3d.CrossSection] | None = None
    for normal, own_lines in zip(directions, lines, strict=True):
        tangent = np.array([-normal[1], normal[0]])  # (normal, tangent) is right-handed
        offsets = _offsets(vertices @ normal, own_lines)
        # per offset, the half-plane normal · p ≤ offset as a counter-clockwise rectangle around the piece
        feet = centre + (offsets - float(centre @ normal))[:, None] * normal
        behind, side = feet - reach * normal, reach * tangent
        rectangles = np.stack([behind - side, feet - side, feet + side, behind + side], axis=1)
        for rectangle in rectangles:
            half_plane = manifold3d.CrossSection([rectangle])
            below, above = piece ^ half_plane, piece - half_plane
            if below.is_empty() or above.is_empty():
                continue
            cost = below.hull().area() + above.hull().area()
            if best is None or cost < best[0]:
                best = (cost, below, above)
    if best is None or best[0] > hull_area * (1.0 + 1e-9):
        return None
    return best[1], best[2]


def _offsets(projections: np.ndarray, own_lines: np.ndarray) -> np.ndarray:
    """Cut positions strictly inside the piece along a normal: every line an edge of the section lies on
    (first, so they win ties), then vertex positions, evenly thinned, up to ``OFFSETS_PER_DIRECTION``."""
    values = np.unique(np.round(projections, 9))
    span = values[-1] - values[0] if len(values) else 0.0
    if not span:
        return values[:0]
    low, high = values[0] + 1e-6 * span, values[-1] - 1e-6 * span
    lines = np.unique(np.round(own_lines, 9))
    lines = lines[(lines > low) & (lines < high)]
    others = values[(values > low) & (values < high)]
    others = others[~np.isin(others, lines)]
    room = max(0, OFFSETS_PER_DIRECTION - len(lines))
    if len(others) > room:
        others = others[np.linspace(0, len(others) - 1, room).round().astype(int)] if room else others[:0]
    return np.concatenate([lines, others])


def _excess(piece: manifold3d.CrossSection) -> float:
    """How much larger the piece's hull is than the piece (m²)."""
    return piece.hull().area() - piece.area()


def _hull_polygon(piece: manifold3d.CrossSection) -> Polygon:
    contours = piece.hull().to_polygons()
    return np.asarray(max(contours, key=len), dtype=float)


def _section_key(section: manifold3d.CrossSection) -> bytes:
    contours = sorted(
        (np.round(np.asarray(contour, dtype=float), KEY_DIGITS) + 0.0 for contour in section.to_polygons()),
        key=lambda contour: (len(contour), contour.tobytes()),
    )
    return b"|".join(contour.tobytes() for contour in contours)
