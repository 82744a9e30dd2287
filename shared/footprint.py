"""Footprints: where a component stands, seen from above (the xy outline of its posed bounding box and
its z range), and the plane geometry on them. Metres, world frame (Z up). Shared by physics (reach checks),
the robots (site map, approach poses) and the planner (access checks)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from .manifest import Component


@dataclass(frozen=True)
class Footprint:
    """Where a component stands: the xy outline of its posed bounding box and its z range; for a component
    of several collision parts, each part's own footprint too (what occupies a height band)."""

    polygon_xy_m: NDArray[np.float64]  # (k, 2), convex, counter-clockwise
    z_min_m: float
    z_max_m: float
    parts: tuple[Footprint, ...] = ()

    def meets(self, z_low_m: float, z_high_m: float) -> bool:
        """Whether it reaches into the heights ``z_low_m``..``z_high_m``."""
        return self.z_max_m >= z_low_m and self.z_min_m <= z_high_m

    def outlines_meeting(self, z_low_m: float, z_high_m: float) -> list[NDArray[np.float64]]:
        """The outlines of what occupies the heights ``z_low_m``..``z_high_m``: the parts that reach into
        them (a wall's piers, not the lintel over its door: the opening under it is free), or its whole
        outline when it has no parts."""
        pieces = self.parts or (self,)
        return [
            piece.polygon_xy_m
            for piece in pieces
            if piece.meets(z_low_m, z_high_m) and len(piece.polygon_xy_m) >= 3
        ]

    @property
    def centre_xy_m(self) -> NDArray[np.float64]:
        return self.polygon_xy_m.mean(axis=0)

    def distance_m(self, points_xy_m: ArrayLike) -> NDArray[np.float64]:
        """Horizontal distance from points ``(n, 2)`` to this footprint (0 inside)."""
        return footprint_distance_m(self.polygon_xy_m, points_xy_m)


def convex_hull_xy(points_xy: ArrayLike) -> NDArray[np.float64]:
    """Convex hull (Andrew's monotone chain), counter-clockwise, without repeated points."""
    pts = sorted({(round(float(x), 9), round(float(y), 9)) for x, y in np.asarray(points_xy, float)})
    if len(pts) <= 2:
        return np.array(pts, dtype=float)

    def half(points: list[tuple[float, float]]) -> list[tuple[float, float]]:
        chain: list[tuple[float, float]] = []
        for p in points:
            while len(chain) >= 2:
                (ax, ay), (bx, by) = chain[-2], chain[-1]
                if (bx - ax) * (p[1] - ay) - (by - ay) * (p[0] - ax) > 1e-12:
                    break
                chain.pop()
            chain.append(p)
        return chain

    lower, upper = half(pts), half(pts[::-1])
    return np.array(lower[:-1] + upper[:-1], dtype=float)


def posed_footprint(
    component: Component, position_m: Sequence[float], quat_xyzw: Sequence[float]
) -> Footprint:
    """The footprint of ``component``'s local bounding box placed at a pose (component frame, world), with
    its collision parts' boxes placed the same way (:attr:`Footprint.parts`)."""
    rotation = Rotation.from_quat(np.asarray(quat_xyzw, float))
    position = np.asarray(position_m, float)
    whole = _box_footprint(component.bbox_local.min_m, component.bbox_local.max_m, rotation, position)
    if not component.part_boxes_local:
        return whole
    parts = tuple(
        _box_footprint(box.min_m, box.max_m, rotation, position) for box in component.part_boxes_local
    )
    return Footprint(whole.polygon_xy_m, whole.z_min_m, whole.z_max_m, parts)


def _box_footprint(
    low: Sequence[float], high: Sequence[float], rotation: Rotation, position: NDArray[np.float64]
) -> Footprint:
    corners = np.array(
        [[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])]
    )
    world = rotation.apply(corners) + position
    return Footprint(convex_hull_xy(world[:, :2]), float(world[:, 2].min()), float(world[:, 2].max()))


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


def body_centre_m(
    component: Component, position_m: Sequence[float], quat_xyzw: Sequence[float]
) -> tuple[float, float, float]:
    """Where ``component``'s body is: the centre of its local bounding box at a pose (world, m). Not the
    pose's position: a Revit element may keep an identity placement with its geometry in world
    coordinates, so its frame's origin lies at the project origin, 100 m from the body. Plain arithmetic
    (a pose message each period per carried component): the quaternion's rotation of the centre."""
    low, high = component.bbox_local.min_m, component.bbox_local.max_m
    cx, cy, cz = ((low[i] + high[i]) / 2.0 for i in range(3))
    qx, qy, qz, qw = (float(value) for value in quat_xyzw)
    # v + 2w (q × v) + 2 q × (q × v), q the vector part
    tx, ty, tz = 2.0 * (qy * cz - qz * cy), 2.0 * (qz * cx - qx * cz), 2.0 * (qx * cy - qy * cx)
    x = cx + qw * tx + (qy * tz - qz * ty)
    y = cy + qw * ty + (qz * tx - qx * tz)
    z = cz + qw * tz + (qx * ty - qy * tx)
    return float(position_m[0]) + x, float(position_m[1]) + y, float(position_m[2]) + z


def body_centre_xy(
    component: Component, position_m: Sequence[float], quat_xyzw: Sequence[float]
) -> tuple[float, float]:
    """Where ``component`` lies, seen from above (:func:`body_centre_m`)."""
    x, y, _ = body_centre_m(component, position_m, quat_xyzw)
    return x, y
