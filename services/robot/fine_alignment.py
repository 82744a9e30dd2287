"""Fine alignment before a placement: the robot's pose matched to the exact outlines its laser sees.

Why: the particle filter (:mod:`.localisation`) keeps a robot on its path to a few centimetres, but a
placement is commanded from the robot's belief of where it stands (physics carries that belief's error into
the component's pose, :mod:`bimbot.services.physics.placement_error`), and a component must land within
10 mm of its BIM pose. So, standing at the target, the robot aligns its estimate to what its laser sees, as
a construction robot does before it sets a member down: point-to-line ICP (Gauss–Newton, Huber-weighted)
of the scan's hits against the exact edges of the site map's laser-visible outlines (the fence and every
component at the laser's height, :meth:`.site_map.SiteMap.laser_segments`), not against a grid, so the
match is not limited by a cell size. What remains is the laser's own error and the map's (a member's
bounding box against its real section): the localisation share of the placement error.

Only the edges that face the robot are matched (each segment carries its outside on its right,
:func:`outline_edges`): a laser never sees the far face of a member, and matched against both faces a scan
of a beam's near face fits its far face just as well, a section's depth away. An estimate 15 cm off towards
a 160 mm beam lying in the yard was "aligned" on to that far face with a 0.3 mm fit, trusted, and a column
was placed 161 mm off three times running (the same with the 100 mm columns and the fence's 0.2 m thickness).

A correction larger than ``max_shift_m``, too few matched hits or a poor fit is not trusted: the filter's
estimate stands (and the placement error shows it). Pure: arrays in, a pose out (metres, radians, world).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True)
class AlignConfig:
    window_m: float = 15.0  # edges farther than this from the robot are not matched (the laser's range)
    # hits farther than this from every edge are something the map lacks; the gate narrows as the
    # estimate improves (the filter's estimate may be some centimetres and a degree off)
    gates_m: tuple[float, ...] = (0.4, 0.15, 0.05)
    huber_m: float = 0.01
    iterations: int = 10  # per gate
    min_hits: int = 20
    max_shift_m: float = 0.3  # a larger correction is not trusted
    max_turn_rad: float = math.radians(5.0)
    max_rms_m: float = 0.02  # a worse fit is not trusted


@dataclass(frozen=True)
class Alignment:
    pose_xy_yaw: NDArray[np.float64]  # the aligned pose, or the estimate it started from when not trusted
    trusted: bool
    hits: int  # scan hits matched to an edge
    rms_m: float  # their residual distance after the alignment
    shift_m: float  # how far the alignment moved the estimate
    disagrees_m: float = 0.0  # set by the navigator: how far a fit lay from the positioning sensor's fixes
    fixes: int = 0  # set by the navigator: the positioning sensor's fixes the pose was taken from instead


def outline_edges(outlines: Sequence[NDArray[np.float64]]) -> NDArray[np.float64]:
    """The edges ``(m, 2, 2)`` of closed outlines (each ``(k, 2)``, either winding), each running
    counter-clockwise round its outline: the outside lies on the edge's right."""
    edges = []
    for polygon in outlines:
        if len(polygon) < 2:
            continue
        x, y = polygon[:, 0], polygon[:, 1]
        twice_area = float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
        ccw = polygon if twice_area >= 0.0 else polygon[::-1]
        edges.append(np.stack([ccw, np.roll(ccw, -1, axis=0)], axis=1))
    return np.concatenate(edges) if edges else np.empty((0, 2, 2))


def facing(segments: NDArray[np.float64], point_xy: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Which segments (outside on the right) ``point_xy`` sees from outside: the faces a laser there can
    hit. Edge-on ones are left out too."""
    a, b = segments[:, 0], segments[:, 1]
    ab, ap = b - a, point_xy[None, :2] - a
    return (ab[:, 0] * ap[:, 1] - ab[:, 1] * ap[:, 0]) < 0.0


def nearest_on_segments(
    points: NDArray[np.float64], segments: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """For points ``(n, 2)`` and segments ``(m, 2, 2)``: each point's nearest point on any segment ``(n, 2)``
    and its distance ``(n,)``."""
    a, b = segments[:, 0], segments[:, 1]
    ab = b - a
    length2 = np.maximum((ab**2).sum(axis=1), 1e-12)
    t = np.clip(((points[:, None, :] - a[None]) * ab[None]).sum(axis=-1) / length2, 0.0, 1.0)
    near = a[None] + t[..., None] * ab[None]
    distance = np.linalg.norm(points[:, None, :] - near, axis=-1)
    best = distance.argmin(axis=1)
    rows = np.arange(len(points))
    return near[rows, best], distance[rows, best]


def _segment_distances(point: NDArray[np.float64], segments: NDArray[np.float64]) -> NDArray[np.float64]:
    """Distance from one point to each segment ``(m,)`` (a long fence wall passes near though its ends
    lie far away)."""
    a, b = segments[:, 0], segments[:, 1]
    ab = b - a
    t = np.clip(((point - a) * ab).sum(axis=1) / np.maximum((ab**2).sum(axis=1), 1e-12), 0.0, 1.0)
    return np.linalg.norm(a + t[:, None] * ab - point, axis=1)


def _to_world(pose: NDArray[np.float64], local: NDArray[np.float64]) -> NDArray[np.float64]:
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return np.column_stack(
        [pose[0] + c * local[:, 0] - s * local[:, 1], pose[1] + s * local[:, 0] + c * local[:, 1]]
    )


def align(
    estimate_xy_yaw: NDArray[np.float64],
    hits_robot_m: NDArray[np.float64],
    segments_m: NDArray[np.float64],
    config: AlignConfig = AlignConfig(),
) -> Alignment:
    """Align ``estimate_xy_yaw`` so that the scan's hits (robot frame, ``(n, 2)``) lie on the faces of
    ``segments_m`` (world, ``(m, 2, 2)``, outside on the right) that face the robot."""
    start = np.asarray(estimate_xy_yaw, dtype=float)
    untrusted = Alignment(start, False, 0, math.inf, 0.0)
    if len(hits_robot_m) < config.min_hits or len(segments_m) == 0:
        return untrusted
    near_robot = _segment_distances(start[:2], segments_m) <= config.window_m
    segments = segments_m[near_robot]
    local = np.asarray(hits_robot_m, dtype=float)
    local = local[np.linalg.norm(local, axis=1) <= config.window_m]
    if len(segments) == 0 or len(local) < config.min_hits:
        return untrusted
    pose = start.copy()
    for gate_m in config.gates_m:
        stepped = _gauss_newton(pose, local, segments, gate_m, config)
        if stepped is None:
            return untrusted
        pose = stepped
    world = _to_world(pose, local)
    _, distance = nearest_on_segments(world, segments[facing(segments, pose)])
    inlier = distance <= config.gates_m[-1]
    used = int(inlier.sum())
    rms = float(np.sqrt(np.mean(distance[inlier] ** 2))) if used else math.inf
    shift = float(np.hypot(*(pose[:2] - start[:2])))
    turned = abs(math.remainder(float(pose[2] - start[2]), 2.0 * math.pi))
    trusted = (
        used >= config.min_hits
        and rms <= config.max_rms_m
        and shift <= config.max_shift_m
        and turned <= config.max_turn_rad
    )
    pose[2] = math.remainder(float(pose[2]), 2.0 * math.pi)
    return Alignment(pose if trusted else start, trusted, used, rms, shift)


def _gauss_newton(
    pose: NDArray[np.float64],
    local: NDArray[np.float64],
    segments: NDArray[np.float64],
    gate_m: float,
    config: AlignConfig,
) -> NDArray[np.float64] | None:
    """Point-to-line Gauss–Newton steps with hits within ``gate_m`` of an edge; None: too few of them."""
    pose = pose.copy()
    for _ in range(config.iterations):
        seen = segments[facing(segments, pose)]
        if len(seen) == 0:
            return None
        world = _to_world(pose, local)
        near, distance = nearest_on_segments(world, seen)
        inlier = distance <= gate_m
        if int(inlier.sum()) < config.min_hits:
            return None
        offset = world[inlier] - near[inlier]
        d = distance[inlier]
        normal = offset / np.maximum(d, 1e-9)[:, None]
        c, s = math.cos(pose[2]), math.sin(pose[2])
        p = local[inlier]
        turn = np.column_stack([-s * p[:, 0] - c * p[:, 1], c * p[:, 0] - s * p[:, 1]])  # d(world)/d(yaw)
        jacobian = np.column_stack([normal, (normal * turn).sum(axis=1)])
        weight = np.where(d <= config.huber_m, 1.0, config.huber_m / np.maximum(d, 1e-12))
        lhs = jacobian.T @ (jacobian * weight[:, None]) + 1e-9 * np.eye(3)
        step = -np.linalg.solve(lhs, jacobian.T @ (weight * d))
        pose = pose + step
        if np.abs(step[:2]).max() < 1e-5 and abs(step[2]) < 1e-6:
            break
    return pose
