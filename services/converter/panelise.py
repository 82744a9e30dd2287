"""Split an element too heavy or too large to lift or transport whole into precast panels: pure geometry.

Where a precaster cuts:

* a **wall** (``IfcWall`` and its subtypes; a curtain wall is not one) into storey-high panels side by side:
  vertical cuts across its length axis, equal widths where the openings allow, and horizontal cuts at the
  storey levels it spans (when given; else its height is kept);
* a **slab** (``IfcSlab``, a roof's slabs, ``IfcRoof`` with a body of its own, a concrete ``IfcPlate``, a
  ceiling or floor covering) into planks 1.2–2.4 m wide running along its span: cuts parallel to the span.
  The span is taken as the slab's shorter horizontal extent (its supports are not looked up), so the planks
  are as long as the slab is wide; a span longer than a truck's load is cut across into equal rows that fit
  one (the planks of a row bear on a support line at each end, which the cut assumes);
* a **cladding** (an ``IfcCovering`` of that type) as a wall.

The axes come from the mesh: vertical is the world's (the element's rotation is given), the length axis is
the long side of the smallest rectangle around the mesh's plan (its 2D oriented bounding box). Openings are
kept: a cut goes only where the element's section is whole, found on the mesh itself (a section through a
window falls apart into the parts below and above it, one through a door does not reach the floor, one
through a slab's shaft falls in two along the span), so a cut meant for an opening moves into the nearest
pier, at least ``JAMB_MARGIN_M`` from the jamb where the pier allows. The number of panels grows from the
fewest the limits allow until every panel is within the lift capacity and fits a truck; when none does
(a 1.2 m plank still too heavy), :class:`PanelisationError` says so with the numbers.

Meshes are cut by manifold3d (``Manifold.split_by_plane``, closed and exact; the converter's mesh library,
see :mod:`.mesh`), not by hand. Frames: input and output meshes are in the element's own frame, metres.
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass
from enum import StrEnum

import manifold3d
import numpy as np

from .mesh import MeshLike, TriMesh, as_trimesh_lite

PLANK_WIDTH_M = (1.2, 2.4)  # hollow-core and solid planks
# the joint between two panels or planks side by side (grouted or sealed on site; 10-20 mm is usual): each
# panel is made that much short of the cut, so a neighbour set within its tolerance does not push it
PANEL_JOINT_M = 0.015
MIN_WALL_PANEL_M = 0.6  # narrower wall panels are not made
MIN_PLANK_M = 0.6  # a narrower closure plank beside an opening is not made either
JAMB_MARGIN_M = 0.1  # a cut stays this far from an opening where the pier is wide enough
MIN_ROW_M = 0.5  # a storey level closer than this to the wall's top or bottom is no cut
BREAK_DIGITS = 3  # section breakpoints closer than 1 mm are one
COVER_TOL_M = 0.005  # gaps in a section smaller than this are no opening
_CONCRETE = re.compile(r"concrete|b[eé]ton|hormig[oó]n|calcestruzzo|precast|\bc\d{2}/\d{2}\b", re.I)
# maps (x, y, z) to (y, z, x): a section across x becomes manifold3d's slice at height x
_X_TO_Z = np.array([[0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [1.0, 0.0, 0.0, 0.0]])
# maps (x, y, z) to (x, -z, y), a rotation: a section across y becomes manifold3d's slice at height y, x kept
_Y_TO_Z = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, -1.0, 0.0], [0.0, 1.0, 0.0, 0.0]])


SLAB_COVERINGS = frozenset({"CEILING", "FLOORING", "ROOFING"})  # IfcCovering types cut as slabs
WALL_COVERINGS = frozenset({"CLADDING"})  # and as walls


class PanelKind(StrEnum):
    WALL = "wall"
    SLAB = "slab"


class PanelisationError(ValueError):
    """No cutting keeps every panel within the limits; the message gives the numbers."""


@dataclass(frozen=True)
class PanelLimits:
    """What one panel may be: its mass (the fleet's lift capacity) and the load a truck carries."""

    max_mass_kg: float
    transport_m: tuple[float, float, float]  # length, width, height of the load, metres
    lifted_by: str = ""  # who lifts that, when the notes should say (a crane at a radius)

    def fits(self, extents_m: Sequence[float] | np.ndarray) -> bool:
        """Whether a box of ``extents_m`` fits the truck's load in some orientation (axes kept parallel)."""
        need = sorted((float(value) for value in extents_m), reverse=True)
        have = sorted(self.transport_m, reverse=True)
        return all(a <= b + 1e-9 for a, b in zip(need, have, strict=True))

    def describe(self) -> str:
        length, width, height = self.transport_m
        return f"{self.max_mass_kg:,.0f} kg and {length:g} × {width:g} × {height:g} m"


@dataclass(frozen=True)
class PanelJointSpec:
    """A joint between panels ``first`` and ``second`` (indices into :attr:`Panelisation.panels`)."""

    first: int
    second: int
    length_m: float
    kind: str  # vertical (wall panels side by side), horizontal (stacked at a storey), longitudinal (planks)


@dataclass(frozen=True)
class Panelisation:
    """The panels (element frame), their volumes and masses (the element's mass split by volume)."""

    panels: tuple[TriMesh, ...]
    volumes_m3: tuple[float, ...]
    masses_kg: tuple[float, ...]
    joints: tuple[PanelJointSpec, ...]
    why: str


def panel_kind(
    ifc_class: str, material: str | None = None, predefined_type: str | None = None
) -> PanelKind | None:
    """How an element of ``ifc_class`` (and material label, predefined type) is panelised; None: it is not
    cut."""
    if ifc_class.startswith("IfcCovering"):
        covering = (predefined_type or "").upper()
        return (
            PanelKind.SLAB
            if covering in SLAB_COVERINGS
            else PanelKind.WALL
            if covering in WALL_COVERINGS
            else None
        )
    if ifc_class.startswith("IfcWall"):
        return PanelKind.WALL
    if ifc_class.startswith(("IfcSlab", "IfcRoof")):
        return PanelKind.SLAB
    if ifc_class.startswith("IfcPlate") and material and _CONCRETE.search(material):
        return PanelKind.SLAB
    return None


def panelise(
    mesh: MeshLike,
    kind: PanelKind,
    mass_kg: float,
    limits: PanelLimits,
    *,
    rotation: np.ndarray | None = None,
    levels_m: Sequence[float] = (),
    reason: str = "",
) -> Panelisation:
    """Cut ``mesh`` (closed, element frame, metres) of an element of ``mass_kg`` into panels within
    ``limits``. ``rotation``: element frame → world axes (vertical is world z); ``levels_m``: storey levels as
    heights above the element's origin along world z (walls only); ``reason``: why it is split when the
    limits alone do not ask for it (a decision's note)."""
    rotation = np.eye(3) if rotation is None else np.asarray(rotation, dtype=float)
    local = as_trimesh_lite(mesh)
    frame = cut_frame(local.vertices, rotation)
    vertices = local.vertices @ frame.T  # x: length (walls) or across the span (slabs), z: up
    solid = closed_solid(vertices, local.faces, "panels")
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    size = high - low
    fits_whole = mass_kg <= limits.max_mass_kg and limits.fits(size)
    why = _why_split(mass_kg, size, limits, reason, fits_whole)
    planner = _CutPlanner(solid, vertices, kind, low, high)
    rows = (
        planner.row_levels(levels_m) if kind is PanelKind.WALL else planner.span_rows(max(limits.transport_m))
    )
    row_volumes = [piece.volume() for piece in split_by_planes(solid, planner.row_normal, rows)]
    heaviest_row_kg = mass_kg * max(row_volumes) / sum(row_volumes)
    counts = _panel_counts(kind, float(size[0]), heaviest_row_kg, limits)
    best: tuple[float, str] | None = None
    for count in counts:
        cuts = planner.cuts(count)
        if cuts is None:
            continue
        grid = _cut_grid(solid, cuts, rows, planner.row_normal)
        volumes = [piece.volume() for row in grid for piece in row]
        total = solid.volume()  # each panel its own share of the element's: the joints' grout is no panel's
        masses = [mass_kg * volume / total for volume in volumes]
        extents = [_extents(piece) for row in grid for piece in row if not piece.is_empty()]
        worst_mass = max(masses)
        too_big = [e for e in extents if not limits.fits(e)]
        if worst_mass <= limits.max_mass_kg and not too_big:
            return _result(grid, cuts=cuts, rows=rows, masses=masses, frame=frame, planner=planner, why=why)
        problem = (
            f"{len(extents)} panels: the heaviest {worst_mass:,.0f} kg"
            if worst_mass > limits.max_mass_kg
            else f"{len(extents)} panels: one is {' × '.join(f'{v:.2f}' for v in too_big[0])} m"
        )
        best = (worst_mass, problem)
    raise PanelisationError(_no_cut(kind, size=size, mass_kg=mass_kg, limits=limits, best=best))


def _panel_counts(kind: PanelKind, length_m: float, row_mass_kg: float, limits: PanelLimits) -> range:
    """The counts of panels side by side to try, fewest first (``row_mass_kg``: the heaviest row's mass)."""
    by_mass = math.ceil(row_mass_kg / limits.max_mass_kg - 1e-9)
    if kind is PanelKind.SLAB:
        low = max(1, math.ceil(length_m / PLANK_WIDTH_M[1] - 1e-9), by_mass)
        return range(low, max(1, math.floor(length_m / PLANK_WIDTH_M[0] + 1e-9)) + 1)
    low = max(1, math.ceil(length_m / max(limits.transport_m) - 1e-9), by_mass)
    return range(low, max(1, math.floor(length_m / MIN_WALL_PANEL_M + 1e-9)) + 1)


def _why_split(mass_kg: float, size: np.ndarray, limits: PanelLimits, reason: str, fits_whole: bool) -> str:
    reasons = []
    if mass_kg > limits.max_mass_kg:
        who = f" ({limits.lifted_by})" if limits.lifted_by else ""
        reasons.append(f"{mass_kg:,.0f} kg, over the {limits.max_mass_kg:,.0f} kg lift capacity{who}")
    if not limits.fits(size):
        length, width, height = limits.transport_m
        reasons.append(
            f"{size[0]:.2f} × {size[1]:.2f} × {size[2]:.2f} m, larger than the {length:g} × {width:g} × "
            f"{height:g} m a truck carries"
        )
    if fits_whole:
        reasons.append(f"{mass_kg:,.0f} kg, {size[0]:.2f} m long; {reason or 'split as decided'}")
    return " and ".join(reasons)


def _no_cut(
    kind: PanelKind,
    *,
    size: np.ndarray,
    mass_kg: float,
    limits: PanelLimits,
    best: tuple[float, str] | None,
) -> str:
    length_m, span_m = float(size[0]), float(size[1])
    what = f"{mass_kg:,.0f} kg, {length_m:.2f} × {span_m:.2f} m in plan"
    if kind is PanelKind.SLAB and length_m >= PLANK_WIDTH_M[0]:
        narrowest = mass_kg * PLANK_WIDTH_M[0] / length_m
        if narrowest > limits.max_mass_kg:
            who = f" ({limits.lifted_by})" if limits.lifted_by else ""
            return (
                f"{what}: a {PLANK_WIDTH_M[0]:g} m plank would weigh {narrowest:,.0f} kg, over the "
                f"{limits.max_mass_kg:,.0f} kg lift capacity{who}"
            )
    tried = f" (best try: {best[1]})" if best else " (no cut avoids its openings)"
    return f"{what}: no cutting into {kind.value} panels keeps each within {limits.describe()}{tried}"


def closed_solid(vertices: np.ndarray, faces: np.ndarray, what: str) -> manifold3d.Manifold:
    """The mesh as a manifold3d solid, its holes filled first when it has some (:func:`holes_filled`);
    PanelisationError when it is not closed even so (``what``: it is cut into)."""
    solid = _manifold(vertices, faces)
    if not _solid(solid):
        repaired = holes_filled(vertices, faces)
        solid = _manifold(*repaired) if repaired is not None else solid
    if not _solid(solid):
        raise PanelisationError(f"its mesh is not a closed solid, so it cannot be cut into {what}")
    return solid


def holes_filled(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """The mesh with its holes filled by trimesh (each boundary loop closed by a fan of triangles) when that
    makes it a closed solid of positive volume, else None. The WBDG clinic's Revit roofs ("Standing Seam
    Metal Roof", 6-19 t) tessellate with 84 open edges and were lifted whole or not at all; filled, their
    volume is the one the converter measured."""
    import trimesh  # only for the rare open mesh: the converter imports it lazily

    mesh = trimesh.Trimesh(vertices=vertices, faces=faces, process=True)
    trimesh.repair.fill_holes(mesh)
    trimesh.repair.fix_normals(mesh)
    if not mesh.is_volume or not mesh.volume > 0:
        return None
    return np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int64)


def _manifold(vertices: np.ndarray, faces: np.ndarray) -> manifold3d.Manifold:
    return manifold3d.Manifold(
        manifold3d.Mesh64(vert_properties=np.ascontiguousarray(vertices), tri_verts=faces.astype(np.uint64))
    )


def _solid(solid: manifold3d.Manifold) -> bool:
    return solid.status() == manifold3d.Error.NoError and not solid.is_empty() and solid.volume() > 0


def cut_frame(vertices_local: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """Rotation element frame → cut frame: z world up, x along the long side of the plan's smallest
    enclosing rectangle (2D oriented bounding box over the plan's convex hull edges)."""
    plan = (vertices_local @ rotation.T)[:, :2]
    hull = manifold3d.CrossSection.hull_points(np.ascontiguousarray(plan)).to_polygons()
    points = np.concatenate(hull) if hull else plan
    edges = np.roll(points, -1, axis=0) - points
    angles = np.unique(np.round(np.mod(np.arctan2(edges[:, 1], edges[:, 0]), np.pi / 2), 9))
    best: tuple[float, float, float] | None = None  # (area, angle, x extent - y extent)
    for angle in angles if len(angles) else np.zeros(1):
        c, s = math.cos(angle), math.sin(angle)
        turned = points @ np.array([[c, -s], [s, c]])  # coordinates along (c, s) and (-s, c)
        span = np.ptp(turned, axis=0)
        area = float(span[0] * span[1])
        if best is None or area < best[0] - 1e-9:
            best = (area, float(angle), float(span[0] - span[1]))
    assert best is not None
    angle = best[1] + (math.pi / 2 if best[2] < 0 else 0.0)
    c, s = math.cos(angle), math.sin(angle)
    yaw = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])  # world → cut frame
    return yaw @ rotation


class _CutPlanner:
    """Where cuts may go: across x where the section is whole, and at storey levels (cut frame)."""

    def __init__(
        self,
        solid: manifold3d.Manifold,
        vertices: np.ndarray,
        kind: PanelKind,
        low: np.ndarray,
        high: np.ndarray,
    ) -> None:
        self.solid = solid
        self.kind = kind
        self.low, self.high = low, high
        self.across = solid.transform(_X_TO_Z)  # slice(x) gives the section across x in (y, z)
        self.cover_axis = 1 if kind is PanelKind.WALL else 0  # walls: whole height; slabs: whole span
        self.allowed = self._allowed(np.unique(np.round(vertices[:, 0], BREAK_DIGITS)))
        # rows: a wall's at storey levels (cut across z), a slab's across its span (cut across y)
        self.row_axis = 2 if kind is PanelKind.WALL else 1
        self.row_normal = (0.0, 0.0, 1.0) if kind is PanelKind.WALL else (0.0, 1.0, 0.0)
        self.along_rows = solid if kind is PanelKind.WALL else solid.transform(_Y_TO_Z)

    def coverage(self, x: float) -> list[tuple[float, float]]:
        """The section across x, as covered intervals along the wall's height or the slab's span."""
        return _covered(self.across.slice(x), self.cover_axis)

    def _whole(self, x: float) -> bool:
        covered = self.coverage(x)
        if len(covered) != 1:
            return False
        return self.kind is PanelKind.SLAB or covered[0][0] <= self.low[2] + COVER_TOL_M

    def _allowed(self, breaks: np.ndarray) -> list[tuple[float, float]]:
        """Intervals of x where a cut keeps the openings whole, kept off their jambs."""
        runs: list[list[float]] = []
        for a, b in itertools.pairwise(breaks):
            if not self._whole(0.5 * (a + b)):
                continue
            if runs and abs(runs[-1][1] - a) < 1e-9:
                runs[-1][1] = float(b)
            else:
                runs.append([float(a), float(b)])
        ends = (float(self.low[0]), float(self.high[0]))
        allowed = []
        for a, b in runs:
            margin = min(JAMB_MARGIN_M, 0.5 * (b - a))
            a2 = a if abs(a - ends[0]) < 1e-6 else a + margin
            b2 = b if abs(b - ends[1]) < 1e-6 else b - margin
            allowed.append((a2, b2))
        return allowed

    def cuts(self, count: int) -> list[float] | None:
        """``count - 1`` cut positions, equal widths moved to the nearest allowed place; None if two of
        them fall together or a panel would be too narrow."""
        start, end = float(self.low[0]), float(self.high[0])
        narrowest = MIN_PLANK_M if self.kind is PanelKind.SLAB else MIN_WALL_PANEL_M
        cuts = []
        for index in range(1, count):
            ideal = start + (end - start) * index / count
            options = [(abs(min(max(ideal, a), b) - ideal), min(max(ideal, a), b)) for a, b in self.allowed]
            if not options:
                return None
            cuts.append(min(options)[1])
        edges = [start, *cuts, end]
        if any(b - a < narrowest for a, b in itertools.pairwise(edges)):
            return None
        return cuts

    def row_coverage(self, at: float) -> list[tuple[float, float]]:
        """The section at a row boundary (a wall's height, a slab's place along its span) as covered
        intervals along x."""
        return _covered(self.along_rows.slice(at), 0)

    def span_rows(self, length_m: float) -> list[float]:
        """Cuts across a slab's span (y) into the fewest equal rows no longer than ``length_m``."""
        span = float(self.high[1] - self.low[1])
        count = max(1, math.ceil(span / length_m - 1e-9))
        return [float(self.low[1]) + span * index / count for index in range(1, count)]

    def row_levels(self, levels_m: Sequence[float]) -> list[float]:
        """Storey levels inside the wall's height where its plan section is whole."""
        rows = []
        for level in sorted(set(float(value) for value in levels_m)):
            if not self.low[2] + MIN_ROW_M < level < self.high[2] - MIN_ROW_M:
                continue
            if len(_covered(self.solid.slice(level), 0)) == 1:
                rows.append(level)
        return rows


def _covered(section: manifold3d.CrossSection, axis: int) -> list[tuple[float, float]]:
    """The union of the section's parts' extents along ``axis`` (0: its x, 1: its y)."""
    spans = sorted(
        (bounds[axis], bounds[axis + 2]) for bounds in (part.bounds() for part in section.decompose())
    )
    merged: list[list[float]] = []
    for a, b in spans:
        if merged and a <= merged[-1][1] + COVER_TOL_M:
            merged[-1][1] = max(merged[-1][1], b)
        else:
            merged.append([a, b])
    return [(a, b) for a, b in merged]


def split_by_planes(solid: manifold3d.Manifold, normal: Sequence[float], cuts: Sequence[float]) -> list:
    """The pieces of ``solid`` between consecutive planes ``normal · p = cut``, in order."""
    pieces = []
    rest = solid
    for cut in cuts:
        above, below = rest.split_by_plane(list(normal), float(cut))
        pieces.append(below)
        rest = above
    pieces.append(rest)
    return pieces


def _cut_grid(
    solid: manifold3d.Manifold, cuts: Sequence[float], rows: Sequence[float], row_normal: Sequence[float]
) -> list[list]:
    """Rows (cut at ``rows`` across ``row_normal``: a wall's bottom up, a slab's along its span) of pieces
    (along x, cut at ``cuts``), each side-by-side cut a joint ``PANEL_JOINT_M`` wide (the sliver between
    two panels is dropped)."""
    planes = [position for cut in cuts for position in (cut - PANEL_JOINT_M / 2.0, cut + PANEL_JOINT_M / 2.0)]
    return [
        split_by_planes(row, (1.0, 0.0, 0.0), planes)[::2] for row in split_by_planes(solid, row_normal, rows)
    ]


def _extents(piece: manifold3d.Manifold) -> tuple[float, float, float]:
    x0, y0, z0, x1, y1, z1 = piece.bounding_box()
    return (x1 - x0, y1 - y0, z1 - z0)


def _result(
    grid: list[list],
    *,
    cuts: Sequence[float],
    rows: Sequence[float],
    masses: Sequence[float],
    frame: np.ndarray,
    planner: _CutPlanner,
    why: str,
) -> Panelisation:
    """The panels back in the element frame, empty grid cells dropped, and the joints between them."""
    kind = planner.kind
    index: dict[tuple[int, int], int] = {}
    panels: list[TriMesh] = []
    volumes: list[float] = []
    kept_masses: list[float] = []
    flat = [(r, c, piece) for r, row in enumerate(grid) for c, piece in enumerate(row)]
    for (r, c, piece), mass in zip(flat, masses, strict=True):
        if piece.is_empty() or not piece.volume() > 0:
            continue
        mesh = piece.to_mesh64()
        vertices = np.asarray(mesh.vert_properties, dtype=np.float64)[:, :3] @ frame  # back to element frame
        index[(r, c)] = len(panels)
        panels.append(TriMesh(np.ascontiguousarray(vertices), np.asarray(mesh.tri_verts, dtype=np.int64)))
        volumes.append(float(piece.volume()))
        kept_masses.append(float(mass))
    axis = planner.row_axis
    bounds = [planner.low[axis], *rows, planner.high[axis]]  # of the rows, along the row axis
    sides = [planner.low[0], *cuts, planner.high[0]]
    joints = []
    side_kind, row_kind = (
        ("vertical", "horizontal") if kind is PanelKind.WALL else ("longitudinal", "transverse")
    )
    for c, x in enumerate(cuts):
        covered = planner.coverage(x)
        for r in range(len(grid)):
            if (r, c) in index and (r, c + 1) in index:
                length = _clipped(covered, bounds[r], bounds[r + 1])
                joints.append(PanelJointSpec(index[(r, c)], index[(r, c + 1)], round(length, 3), side_kind))
    for r, at in enumerate(rows):
        covered = planner.row_coverage(at)
        for c in range(len(cuts) + 1):
            if (r, c) in index and (r + 1, c) in index:
                length = _clipped(covered, sides[c], sides[c + 1])
                joints.append(PanelJointSpec(index[(r, c)], index[(r + 1, c)], round(length, 3), row_kind))
    widths = np.diff(sides)
    count = f"{len(panels)} storey-high panel{'s' if len(panels) > 1 else ''}"
    if kind is PanelKind.SLAB:
        span_m = planner.high[1] - planner.low[1]
        count = f"{len(panels)} plank{'s' if len(panels) > 1 else ''} along the {span_m:.2f} m span"
        if rows:
            count += f" in {len(rows) + 1} rows of {span_m / (len(rows) + 1):.2f} m"
    wide = f"{widths[0]:.2f} m" if np.ptp(widths) < 0.01 else f"{widths.min():.2f}–{widths.max():.2f} m"
    sentence = f"{why}: cut into {count}, {wide} wide, {max(kept_masses):,.0f} kg at most"
    return Panelisation(tuple(panels), tuple(volumes), tuple(kept_masses), tuple(joints), sentence)


def _clipped(covered: Sequence[tuple[float, float]], low: float, high: float) -> float:
    return float(sum(max(0.0, min(b, high) - max(a, low)) for a, b in covered))
