"""How a component lies in the yard: flat, its shortest extent vertical and its longest along world y, on
the ground. Both the yard's rows (:mod:`.site_layout`) and a crane's lay-down (:mod:`.site_laydown`) lay
components down this way; physics sets a component down in the yard by the same rotation."""

from __future__ import annotations

from collections.abc import Sequence
from functools import lru_cache

import numpy as np
from scipy.spatial.transform import Rotation

from .manifest import Component
from .site_plan import Rect, YardSlot

GROUND_CLEARANCE_M = 0.001  # yard components rest this far above the ground plane


def lying_rotation(extents_local_m: Sequence[float]) -> np.ndarray:
    """A proper rotation that lays a box flat: longest local extent along world x, shortest along z."""
    order = np.argsort(-np.asarray(extents_local_m, dtype=float), kind="stable")  # longest first
    matrix = np.zeros((3, 3))
    for world_axis, local_axis in enumerate(order):
        matrix[world_axis, local_axis] = 1.0
    if np.linalg.det(matrix) < 0:
        matrix[1] *= -1.0  # flip the middle axis: still flat, now right-handed
    return matrix


_QUARTER_TURN_Z = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])


def yard_rotation(extents_local_m: Sequence[float]) -> np.ndarray:
    """How a component lies in the yard: flat (shortest extent vertical), longest extent along world y."""
    return _QUARTER_TURN_Z @ lying_rotation(extents_local_m)


def laid_slot(component: Component, min_x: float, min_y: float) -> YardSlot:
    """``component`` lying as in the yard with its footprint's corner at (min_x, min_y), on the ground."""
    low = np.array(component.bbox_local.min_m)
    high = np.array(component.bbox_local.max_m)
    rotation = yard_rotation(high - low)
    corners = np.array(
        [[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])]
    )
    turned = corners @ rotation.T
    t_min = turned.min(axis=0)
    size = turned.max(axis=0) - t_min
    translation = np.array([min_x, min_y, GROUND_CLEARANCE_M]) - t_min
    return YardSlot(
        guid=component.guid,
        position_m=(float(translation[0]), float(translation[1]), float(translation[2])),
        quat_xyzw=_quat_xyzw(tuple(rotation.ravel().tolist())),
        footprint=Rect((min_x, min_y), (min_x + float(size[0]), min_y + float(size[1]))),
        height_m=float(size[2]),
    )


@lru_cache(maxsize=64)
def _quat_xyzw(matrix: tuple[float, ...]) -> tuple[float, float, float, float]:
    """The quaternion of a yard rotation (one of 24 signed permutations: cached)."""
    quat = Rotation.from_matrix(np.array(matrix).reshape(3, 3)).as_quat()
    return (float(quat[0]), float(quat[1]), float(quat[2]), float(quat[3]))
