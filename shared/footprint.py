"""Plane geometry of footprints (a component's posed bounding box seen from above), in metres."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def footprint_distance_m(polygon_xy_m: ArrayLike, points_xy_m: ArrayLike) -> NDArray[np.float64]:
    """Horizontal distance from points ``(n, 2)`` to a convex polygon ``(k, 2)`` (0 inside), metres."""
    pts = np.asarray(points_xy_m, float).reshape(-1, 2)
    poly = np.asarray(polygon_xy_m, float).reshape(-1, 2)
    if len(poly) == 1:
        return np.hypot(*(pts - poly[0]).T)
    a, b = poly, np.roll(poly, -1, axis=0)
    ab = b - a
    len2 = np.maximum((ab**2).sum(axis=1), 1e-12)
    t = np.clip(((pts[:, None, :] - a[None]) * ab[None]).sum(-1) / len2, 0.0, 1.0)
    nearest = a[None] + t[..., None] * ab[None]
    distance = np.sqrt(((pts[:, None, :] - nearest) ** 2).sum(-1)).min(axis=1)
    if len(poly) >= 3:
        cross = ab[None, :, 0] * (pts[:, None, 1] - a[None, :, 1]) - ab[None, :, 1] * (
            pts[:, None, 0] - a[None, :, 0]
        )
        inside = (cross >= -1e-12).all(axis=1) | (cross <= 1e-12).all(axis=1)
        distance[inside] = 0.0
    return distance
