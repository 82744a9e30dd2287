"""A placed component released into dynamics: how far it moved, whether it came to rest, what carries it.

Why: a placement is only a placement if the component stays where it was put. Once a robot's assembly
motion ends, :mod:`.releasing` releases the component as a dynamic body (its real mass and inertia, its
convex collision parts, friction) onto what is under it, and watches it here every control period:

* **drift** — how far it moved since its release: the largest displacement of its bounding box's corners
  (a beam tipping off a column moves its free end metres while its centre moves less);
* **settled** — at rest (speed below ``quiet_speed_mps`` and turn rate below ``quiet_turn_radps``) for
  ``quiet_s``, or still moving after ``max_settle_s`` (it is falling or sliding: the drift says so); the
  place request is answered then, with the pose it came to rest at;
* **supports** — the components it touches once settled (the ground and pit floors have no GUID);
* **bumped by** — the first robot that touched it while it still lay where it was put at the start of
  that control period (a robot driving past a placed component pushes it; its releaser does not collide
  with it until they are clear; a component that tipped and fell onto a robot was not pushed by it), so a
  drift a robot caused is not taken for a component that could not stand.

The component's agent judges the placement from that pose and drift (a drift beyond its bound is
``unstable``); physics logs every drift beyond ``report_drift_m`` with the supports. Pure bookkeeping over
pybullet reads: no state machine here (that is :mod:`.handling`'s, :mod:`.watching` calls it).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from bimbot.shared.joints import CLASH_DEPTH_M
from bimbot.shared.manifest import Component

from .client import p
from .scene import ComponentBody, Frame, component_pose, set_component_pose, turned_about

PENETRATION_SLOP_M = 0.003  # overlaps shallower than this (collision margins) are the contact solver's
MAX_CLEARED_M = CLASH_DEPTH_M  # a deeper overlap is no contact to stop at: released as it is (a clash)


@dataclass(frozen=True)
class SettleConfig:
    quiet_speed_mps: float = 0.005
    quiet_turn_radps: float = 0.02
    quiet_s: float = 0.6  # at rest this long (sim s): settled
    max_settle_s: float = 8.0  # still moving after this long (sim s): answered as it is
    report_drift_m: float = 0.005  # a placed component that moved farther is logged, with its supports
    publish_drift_m: float = 0.0005  # a settled component's pose goes out again once it moved this much


@dataclass
class Watch:
    """One released component: where it was let go, and what it has done since."""

    released: Frame
    start_s: float
    releaser: str | None  # the robot that placed it (busy until the placement is answered)
    tag: object = None  # the place request to answer once settled (None: answered)
    quiet_since_s: float | None = None
    settled: bool = False
    drift_m: float = 0.0
    published_drift_m: float = -1.0
    supports: tuple[str, ...] = ()  # what it rests on once settled
    placed_on: tuple[str, ...] | None = None  # what it touched a control period after its release
    open_pits: tuple[str, ...] = ()  # foundations not placed yet whose open pit it was released over
    # components it was released into deeper than a contact (GUID, metres): a clash in the model itself
    clashes: tuple[tuple[str, float], ...] = ()
    reported: bool = False  # its drift beyond report_drift_m was logged
    stopped: bool = False  # it fell off the site and was stopped there, static
    bumped_by: str | None = None  # the first robot that touched it since its release (traffic past it)
    bumped_at_s: float | None = None  # when (sim s)
    # joined components it was connected to as it was set down (connections.py): fixed where it was put
    connected_to: tuple[str, ...] = ()
    # the components it was set into, which the release moved it out of (a robot stops at the contact),
    # and how far that moved its centre from where its robot set it (m)
    set_against: tuple[str, ...] = ()
    set_against_shift_m: float = 0.0
    hold_until_s: float = -math.inf  # its robot holds it until the connection is made (sim s)
    fixed: bool = False  # held where it was put (connected, or on temporary supports): static


def box_corners(component: Component) -> np.ndarray:
    """The eight corners ``(8, 3)`` of the component's local bounding box (component frame)."""
    low, high = component.bbox_local.min_m, component.bbox_local.max_m
    return np.array(
        [[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])]
    )


def corner_drift_m(corners: np.ndarray, a: Frame, b: Frame) -> float:
    """The largest distance a corner of the box moved from frame ``a`` to frame ``b``."""
    at_a = Rotation.from_quat(a[1]).apply(corners) + np.asarray(a[0])
    at_b = Rotation.from_quat(b[1]).apply(corners) + np.asarray(b[0])
    return float(np.linalg.norm(at_b - at_a, axis=1).max())


def at_rest(client_id: int, body_id: int, config: SettleConfig) -> bool:
    linear, angular = p.getBaseVelocity(body_id, physicsClientId=client_id)
    return bool(
        np.linalg.norm(linear) < config.quiet_speed_mps and np.linalg.norm(angular) < config.quiet_turn_radps
    )


def supports_of(client_id: int, body_id: int, guid_of: Mapping[int, str]) -> tuple[str, ...]:
    """The GUIDs of the components ``body_id`` touches now, sorted (the ground and pit floors left out)."""
    touching = {contact[2] for contact in p.getContactPoints(bodyA=body_id, physicsClientId=client_id)}
    return tuple(sorted(guid_of[body] for body in touching if body in guid_of))


@dataclass(frozen=True)
class Cleared:
    """Where :func:`clear_overlap` left a body, and what it overlaps there too deeply to clear."""

    frame: Frame
    # the components it overlaps deeper than ``MAX_CLEARED_M`` (GUID, metres), deepest first: no contact
    # to stop at, the model puts the two in one place (a clash in the IFC)
    clashes: tuple[tuple[str, float], ...] = ()
    against: tuple[str, ...] = ()  # the components it was set into and moved out of (GUIDs, sorted)


def clear_overlap(
    client_id: int,
    body: ComponentBody,
    frame: Frame,
    others: Mapping[int, str],
    *,
    tries: int = 4,
    max_cleared_m: float = MAX_CLEARED_M,
    kept: frozenset[str] = frozenset(),
    meant_quat_xyzw: tuple[float, float, float, float] | None = None,
    centre_local_m: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> Cleared:
    """``frame`` moved out of what the body would penetrate there (other components; the ground and pit
    floors are left to the contact solver): a robot setting a member down against its neighbour stops at
    the contact, it does not ram it in (Bullet would throw it out, centimetres, and call it unstable).
    Each try moves it out of the deepest overlap, along that contact's normal; overlaps of a few
    millimetres (collision margins) are the solver's, and one deeper than ``max_cleared_m``, or with one of
    ``kept`` (GUIDs: the model itself puts it there), is a collision, released as it is and reported with
    the frame (``Cleared.clashes``: every overlap left deeper than ``MAX_CLEARED_M``).

    ``meant_quat_xyzw``: the orientation the robot meant. A member set down turned against its neighbour
    seats flush first (the contact turns it about its centre, ``centre_local_m``, as a robot's compliant
    wrist or a crew's bar does): only what is left is cleared by moving it. Moved instead, a 7 m wall
    turned 0.2° into the wall it abuts was shoved 12 mm off its target."""
    points = _penetrations(client_id, body, frame, others)
    clearable = _clearable(points, kept, max_cleared_m)
    against = tuple(sorted({g for point, g in points if _clearable([(point, g)], kept, max_cleared_m)}))
    if meant_quat_xyzw is not None and clearable:
        flush = turned_about(frame, meant_quat_xyzw, centre_local_m)
        flush_points = _penetrations(client_id, body, flush, others)
        if _deepest_m(_clearable(flush_points, kept, max_cleared_m)) < _deepest_m(clearable):
            frame, points = flush, flush_points
            clearable = _clearable(points, kept, max_cleared_m)
    for _ in range(tries):
        if not clearable:
            return Cleared(frame, clashes_among(points), against)
        deepest = min(clearable, key=lambda point: point[8])
        normal = np.asarray(deepest[7])  # on B, pointing from B to A: out of the other body
        shift = -deepest[8] * normal
        frame = ((frame[0][0] + shift[0], frame[0][1] + shift[1], frame[0][2] + shift[2]), frame[1])
        points = _penetrations(client_id, body, frame, others)
        clearable = _clearable(points, kept, max_cleared_m)
    return Cleared(frame, clashes_among(points), against)


def intrusions(
    client_id: int,
    body: ComponentBody,
    frame: Frame,
    others: Mapping[int, str],
    kept: frozenset[str],
    *,
    max_cleared_m: float = MAX_CLEARED_M,
) -> tuple[tuple[str, float], ...]:
    """The ``others`` (body → GUID; ``kept`` aside) that ``body`` at ``frame`` overlaps deeper than the
    solver's slop, up to ``max_cleared_m`` (GUID, metres), deepest first: what a release would clear."""
    points = _penetrations(client_id, body, frame, others)
    return _deepest_each([(p, g) for p, g in points if _clearable([(p, g)], kept, max_cleared_m)])


def _clearable(
    points: list[tuple[tuple[Any, ...], str]], kept: frozenset[str], max_cleared_m: float
) -> list[tuple[Any, ...]]:
    """The contact points a release clears: deeper than the solver's slop, up to ``max_cleared_m``, with
    a component not ``kept``."""
    return [
        point
        for point, guid in points
        if guid not in kept and PENETRATION_SLOP_M < -point[8] <= max_cleared_m
    ]


def _deepest_m(points: list[tuple[Any, ...]]) -> float:
    """The deepest of clearable contact points (m; 0 when none)."""
    return max((-point[8] for point in points), default=0.0)


def clashes_among(points: list[tuple[tuple[Any, ...], str]]) -> tuple[tuple[str, float], ...]:
    """Of contact points with other components (point, GUID), the components overlapped deeper than
    ``MAX_CLEARED_M`` (GUID, metres), deepest first."""
    return _deepest_each([(point, guid) for point, guid in points if -point[8] > MAX_CLEARED_M])


def _deepest_each(points: list[tuple[tuple[Any, ...], str]]) -> tuple[tuple[str, float], ...]:
    """Of contact points (point, GUID), each GUID's deepest overlap (m), deepest first."""
    deepest: dict[str, float] = {}
    for point, guid in points:
        deepest[guid] = max(-point[8], deepest.get(guid, 0.0))
    return tuple(sorted(deepest.items(), key=lambda item: -item[1]))


def deep_overlaps(
    client_id: int, body: ComponentBody, frame: Frame, others: Mapping[int, str]
) -> tuple[tuple[str, float], ...]:
    """The ``others`` (body → GUID) that ``body`` at ``frame`` overlaps deeper than ``MAX_CLEARED_M``
    (GUID, metres), deepest first."""
    return clashes_among(_penetrations(client_id, body, frame, others))


def overlap_at_targets(
    client_id: int, a: ComponentBody, target_a: Frame, b: ComponentBody, target_b: Frame
) -> float:
    """How deep ``a`` and ``b`` overlap (m) when each stands at its BIM target: what the model itself draws,
    whatever a placement's error adds. Both bodies are put back where they were."""
    before_a, before_b = component_pose(client_id, a), component_pose(client_id, b)
    try:
        set_component_pose(client_id, a, target_a)
        set_component_pose(client_id, b, target_b)
        points = p.getClosestPoints(a.body_id, b.body_id, 0.0, physicsClientId=client_id) or ()
        return max((-float(point[8]) for point in points), default=0.0)
    finally:
        set_component_pose(client_id, a, before_a)
        set_component_pose(client_id, b, before_b)


def _penetrations(
    client_id: int, body: ComponentBody, frame: Frame, others: Mapping[int, str]
) -> list[tuple[tuple[Any, ...], str]]:
    """The contact points of ``body`` at ``frame`` with ``others`` (body → GUID), overlapping or touching."""
    set_component_pose(client_id, body, frame)
    p.performCollisionDetection(physicsClientId=client_id)
    return [
        (point, guid)
        for other, guid in others.items()
        if other != body.body_id
        for point in p.getClosestPoints(body.body_id, other, 0.0, physicsClientId=client_id)
    ]


def observe(
    client_id: int,
    body: ComponentBody,
    corners: np.ndarray,
    watch: Watch,
    *,
    now_s: float,
    config: SettleConfig,
) -> Frame:
    """Update ``watch`` from the body as it is now; its component frame in the world."""
    frame = component_pose(client_id, body)
    watch.drift_m = corner_drift_m(corners, watch.released, frame)
    if not watch.settled:
        if at_rest(client_id, body.body_id, config):
            if watch.quiet_since_s is None:
                watch.quiet_since_s = now_s
        else:
            watch.quiet_since_s = None
        quiet = watch.quiet_since_s is not None and now_s - watch.quiet_since_s >= config.quiet_s
        watch.settled = quiet or now_s - watch.start_s >= config.max_settle_s
    return frame


def touching_robot(client_id: int, body_id: int, robot_of: Mapping[int, str]) -> str | None:
    """The robot (id) whose body touches ``body_id`` now, if any (``robot_of``: robot body → robot id)."""
    for contact in p.getContactPoints(bodyA=body_id, physicsClientId=client_id) or ():
        robot_id = robot_of.get(contact[2])
        if robot_id is not None:
            return robot_id
    return None
