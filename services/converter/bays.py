"""Split a cast-in-place element too large for one day's pour into bays: pure geometry.

A site pours a large slab in bays separated by construction joints (a stop-end form, the reinforcement
running through), each bay what the crew and its pump place in one working day. The bays here are a grid
in plan, cut by vertical planes along and across the long side of the plan's smallest enclosing rectangle
(the cut frame of :mod:`.panelise`): as few bays as keep each within ``max_volume_m3`` with bays no
longer than 1.5 times their width (up to twice as many bays as the volume needs; else the fewest bays),
and of the grids with that many, the one whose bays are the most nearly square. A grid cell the element
does not reach is dropped; one it fills in separate pieces (a slab with a notch) gives a bay for each
piece. The joints are the cuts between neighbouring bays, with their lengths in plan.

A laid wall longer than a block layer lays from one set-up is cut the same way into stretches
(:func:`split_into_stretches`): equal lengths along its plan's long side, each its whole thickness.

Meshes are cut by manifold3d. Frames: input and output meshes are in the element's own frame, metres.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import manifold3d
import numpy as np

from .mesh import MeshLike, TriMesh, as_trimesh_lite
from .panelise import (
    Panelisation,
    PanelisationError,
    PanelJointSpec,
    closed_solid,
    cut_frame,
    split_by_planes,
)

MAX_BAYS = 400  # more bays than this is no day's pour plan: an error says so
JOINT_KIND = "construction"  # a construction joint between two bays poured on different days
TOUCH_M = 1e-4  # two bays whose boxes meet within this at a cut share a joint
# a bay's long side at most 1.5 times its short side where a few more bays allow it ("as nearly square as
# practical; never make the long side more than 1-1/2 times as long as the short side", a contractor's
# rule for a slab's joint layout after ACI: overlandconcrete.com, "Planning and preparation")
MAX_ASPECT = 1.5
PARTS = ("poured", "bays")  # how the notes name a pour's parts


def split_into_bays(
    mesh: MeshLike, mass_kg: float, max_volume_m3: float, *, rotation: np.ndarray | None = None
) -> Panelisation:
    """Cut ``mesh`` (closed, element frame, metres) of an element of ``mass_kg`` into bays of at most
    ``max_volume_m3`` each (see the module); ``rotation``: element frame → world axes. Its ``why`` says how
    (the caller says why). PanelisationError when no grid of up to :data:`MAX_BAYS` bays does it."""
    rotation = np.eye(3) if rotation is None else np.asarray(rotation, dtype=float)
    local = as_trimesh_lite(mesh)
    frame = cut_frame(local.vertices, rotation)
    vertices = local.vertices @ frame.T  # x: along the plan's long side, y: across it, z: up
    solid = closed_solid(vertices, local.faces, "bays")
    total_m3 = float(solid.volume())
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    size = high - low
    need = max(1, math.ceil(total_m3 / max_volume_m3 - 1e-9))
    largest_m3 = total_m3
    for nx, ny in _grids(float(size[0]), float(size[1]), need):
        bays = _bays(solid, low, high, nx, ny)
        largest_m3 = max(volume for _, _, volume in bays)
        if largest_m3 <= max_volume_m3 * (1.0 + 1e-6):
            return _result(
                bays, nx=nx, ny=ny, size=size, mass_kg=mass_kg, total_m3=total_m3, frame=frame, parts=PARTS
            )
    raise PanelisationError(
        f"{total_m3:,.1f} m³: no grid of up to {MAX_BAYS} bays keeps each within {max_volume_m3:,.1f} m³ "
        f"(the largest of the last try: {largest_m3:,.1f} m³)"
    )


def split_into_stretches(
    mesh: MeshLike, mass_kg: float, count: int, *, rotation: np.ndarray | None = None
) -> Panelisation:
    """Cut ``mesh`` (as :func:`split_into_bays`) into ``count`` stretches of equal length along the long side
    of its plan, each its whole thickness and height: a laid wall, one stretch from each set-up of the block
    layer (their volumes differ where its openings do)."""
    rotation = np.eye(3) if rotation is None else np.asarray(rotation, dtype=float)
    local = as_trimesh_lite(mesh)
    frame = cut_frame(local.vertices, rotation)
    vertices = local.vertices @ frame.T
    solid = closed_solid(vertices, local.faces, "stretches")
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    stretches = _bays(solid, low, high, count, 1)
    return _result(
        stretches,
        nx=count,
        ny=1,
        size=high - low,
        mass_kg=mass_kg,
        total_m3=float(solid.volume()),
        frame=frame,
        parts=("laid", "stretches"),
    )


def _grids(length_m: float, width_m: float, need: int) -> Iterator[tuple[int, int]]:
    """(bays along x, bays along y) to try: first the grids of ``need`` to twice as many bays whose bays are
    no longer than :data:`MAX_ASPECT` times their width, fewest first; then any grid, fewest bays and the
    squarest first."""

    def by_count(count: int) -> list[tuple[int, int]]:
        pairs = [(nx, count // nx) for nx in range(1, count + 1) if count % nx == 0]
        return sorted(pairs, key=lambda pair: (_aspect(length_m / pair[0], width_m / pair[1]), pair))

    for count in range(need, min(2 * need, MAX_BAYS) + 1):
        for nx, ny in by_count(count):
            if _aspect(length_m / nx, width_m / ny) <= math.log(MAX_ASPECT) + 1e-9:
                yield nx, ny
    for count in range(need, MAX_BAYS + 1):
        yield from by_count(count)


def _aspect(a_m: float, b_m: float) -> float:
    """How far a bay of ``a_m`` × ``b_m`` is from square (0 for a square)."""
    return abs(math.log(max(a_m, 1e-9) / max(b_m, 1e-9)))


def _bays(
    solid: manifold3d.Manifold, low: np.ndarray, high: np.ndarray, nx: int, ny: int
) -> list[tuple[tuple[int, int], manifold3d.Manifold, float]]:
    """The non-empty pieces of an ``nx`` × ``ny`` grid of equal cells: ((column, row), piece, volume)."""
    xs = [float(low[0] + (high[0] - low[0]) * i / nx) for i in range(1, nx)]
    ys = [float(low[1] + (high[1] - low[1]) * j / ny) for j in range(1, ny)]
    found = []
    for row, strip in enumerate(split_by_planes(solid, (0.0, 1.0, 0.0), ys)):
        for column, cell in enumerate(split_by_planes(strip, (1.0, 0.0, 0.0), xs)):
            if cell.is_empty():
                continue
            for piece in cell.decompose():
                volume = float(piece.volume())
                if volume > 1e-9:
                    found.append(((column, row), piece, volume))
    return found


def _result(
    bays: list[tuple[tuple[int, int], manifold3d.Manifold, float]],
    *,
    nx: int,
    ny: int,
    size: np.ndarray,
    mass_kg: float,
    total_m3: float,
    frame: np.ndarray,
    parts: tuple[str, str],
) -> Panelisation:
    """``parts``: how the words name them (a pour's bays, a laid wall's stretches)."""
    """The bays back in the element frame, their masses by volume and the joints between neighbours."""
    meshes = []
    boxes = []
    for _, piece, _ in bays:
        mesh = piece.to_mesh64()
        vertices = np.asarray(mesh.vert_properties, dtype=np.float64)[:, :3]
        boxes.append(np.array([vertices.min(axis=0), vertices.max(axis=0)]))
        meshes.append(TriMesh(np.ascontiguousarray(vertices @ frame), np.asarray(mesh.tri_verts, np.int64)))
    volumes = tuple(volume for _, _, volume in bays)
    joints = []
    for i, ((ci, ri), _, _) in enumerate(bays):
        for j in range(i + 1, len(bays)):
            (cj, rj) = bays[j][0]
            if abs(ci - cj) + abs(ri - rj) != 1:
                continue
            across = 0 if ci != cj else 1  # the cut's normal: x between columns, y between rows
            along = 1 - across
            first, second = (boxes[i], boxes[j]) if (ci, ri) < (cj, rj) else (boxes[j], boxes[i])
            if abs(first[1][across] - second[0][across]) > TOUCH_M:
                continue
            length = min(first[1][along], second[1][along]) - max(first[0][along], second[0][along])
            if length > TOUCH_M:
                joints.append(PanelJointSpec(i, j, round(float(length), 3), JOINT_KIND))
    largest = max(volumes)
    how = (
        f"{parts[0]} in {len(bays)} {parts[1]} ({nx} × {ny} in plan, "
        f"{size[0] / nx:.1f} × {size[1] / ny:.1f} m), "
        f"{largest:,.1f} m³ at most, with {len(joints)} construction joints"
    )
    return Panelisation(
        panels=tuple(meshes),
        volumes_m3=volumes,
        masses_kg=tuple(mass_kg * volume / total_m3 for volume in volumes),
        joints=tuple(joints),
        why=how,
    )
