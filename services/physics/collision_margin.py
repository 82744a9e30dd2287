"""Component collision parts inset by Bullet's collision margin, so that their contact surface is the
component's own geometry.

Why: Bullet gives every convex hull a collision margin (pybullet: 1 mm) *outside* its vertices, while a box
(the pit floors) keeps its margin inside its extents. A footing released exactly at its BIM pose on its pit
floor therefore overlapped the floor by 1 mm and was pushed up 1 mm; a column on it overlapped by 2 mm more
and was pushed up 3 mm in all: every placement "drifted" 1–3 mm before anything happened, most of the
5 mm the agents allow a placed component to move (and a tall column following a slightly tilted footing
crossed it: a compose build failed a column three times as unstable). ``changeDynamics(collisionMargin=…)``
does not reach the parts of a compound shape, so each part is scaled about its own centre, per axis of the
component frame, by twice the margin less than its extent: for the converter's parts (boxes of a profile
decomposition, one hull for pads, both in component axes) each face comes in by exactly the margin, and
the margin puts it back where the geometry has it. A part thinner than four margins along an axis is left
as it is along that axis (a sheet keeps its thickness).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

BULLET_HULL_MARGIN_M = 0.001  # pybullet's default collision margin of a mesh's convex hull


def obj_vertices(path: Path) -> np.ndarray:
    """The vertices ``(n, 3)`` of a Wavefront OBJ file."""
    rows = [line.split()[1:4] for line in path.read_text().splitlines() if line.startswith("v ")]
    if not rows:
        raise ValueError(f"{path}: no vertices")
    return np.asarray(rows, dtype=float)


def inset_by_margin(
    low: np.ndarray, high: np.ndarray, margin_m: float = BULLET_HULL_MARGIN_M
) -> tuple[list[float], list[float]]:
    """``(mesh scale, frame position)`` for pybullet that shrink a part with bounds ``low``–``high`` about
    its centre by ``margin_m`` on every side (vertex → scale · vertex + position)."""
    extent = high - low
    centre = (high + low) / 2.0
    scale = np.where(extent > 4.0 * margin_m, (extent - 2.0 * margin_m) / np.maximum(extent, 1e-12), 1.0)
    return scale.tolist(), (centre * (1.0 - scale)).tolist()


def inset_parts(parts: list[np.ndarray]) -> tuple[list[list[float]], list[list[float]]]:
    """Mesh scales and frame positions of every collision part, given by its vertices (see
    :func:`inset_by_margin`)."""
    scales: list[list[float]] = []
    positions: list[list[float]] = []
    for vertices in parts:
        scale, position = inset_by_margin(vertices.min(axis=0), vertices.max(axis=0))
        scales.append(scale)
        positions.append(position)
    return scales, positions
