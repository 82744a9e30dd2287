"""A member fitted to the structure as it was built: where a site's erector puts it.

Every built member stands within its tolerance of its BIM target, not on it. A beam framed into a channel
that stands 9 mm towards it cannot go to its own target: aimed there, it runs into the channel, is stopped
at the contact and ends 25 mm off its target at every attempt (tolerance stack-up), and no retry mends what
the standing steel fixes. On a site the member is drawn up to the steel as it stands, bolted to the holes
where they are and laid on the seats and tops of what carries it; its erection tolerance is relative to
those supports.

So the release (:mod:`.releasing`) moves a robot's placement by its member's *fit*, the member's target as
the built structure leaves room for it:

* on its seats: its BIM target raised or lowered by the mean vertical displacement of the built members its
  manifest connects it to (``connection_links``), each taken where it meets the member (the member's centre
  brought into the support's box). A grouted panel is shimmed to its level on its bed: a grouted link does
  not count;
* drawn up to what stands in its way: where that aim runs into built members standing off their own
  targets, the member follows one of them, as bolted to it (its target moved by the rigid displacement that
  member has from its own target; never a covering's board: :func:`is_board`), or is shifted, not turned,
  as far as that member's face beside it moved (:func:`shifted`), or goes halfway to either, or stays:
  whichever leaves the least to clear (:func:`fit_score`: an overlap with a part it is not framed to, or a
  framed end overlapped beyond its erection clearance), then the most clearance at its framed ends for the
  robot's own error. A mullion between two transom ends, one set 10 mm towards it, goes halfway: 5 mm into
  each end's clearance;
* what overlap is left is cleared (:func:`.release.clear_overlap`, as for any placement).

A fit moves the member's centre at most the position tolerance and turns it at most the angle tolerance
(:func:`bounded`), so no member ends further than twice the tolerance from its BIM target however its
supports stand. Its agent, its connections and the run's as-built audit judge it against its fitted target.
A component in place from the start, or cast or laid where it stands, is a support with no displacement.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from bimbot.shared.connection_kinds import ConnectionKind
from bimbot.shared.manifest import Component
from bimbot.shared.verification import Tolerances, angle_error_rad
from bimbot.shared.work_methods import BUILT_IN_PLACE

from .handling_state import HandlingState, Item, Phase, target_frame
from .joints import is_board
from .release import clear_overlap, deep_overlaps, intrusions
from .scene import Frame, compose, invert, rotate, set_component_pose

NEGLIGIBLE_M = 1e-4  # a fit that moves the centre less than this (and does not turn it) is none


@dataclass(frozen=True)
class BuiltSupport:
    """A built member another is connected to: how, where its model puts it, where it stands."""

    kind: ConnectionKind
    component: Component | None  # None: in place from the start (it stands where the model puts it)
    as_built: Frame | None  # None: it stands at its target (in place, cast or laid where it stands)


def built_supports(state: HandlingState, component: Component) -> list[BuiltSupport]:
    """The built members ``component``'s manifest connects it to, where they stand."""
    in_place = set(state.in_place.values())
    supports: list[BuiltSupport] = []
    for link in component.connection_links:
        other = state.items.get(link.other_guid)
        if other is not None and other.phase is Phase.JOINED:
            where_built = None if other.component.method in BUILT_IN_PLACE else other.pose
            supports.append(BuiltSupport(link.kind, other.component, where_built))
        elif link.other_guid in in_place:
            supports.append(BuiltSupport(link.kind, None, None))
    return supports


def displacement_at_m(support: BuiltSupport, point_m: np.ndarray) -> np.ndarray:
    """How far ``support``, as built, moved its point nearest ``point_m`` (world, at its target)."""
    if support.as_built is None or support.component is None:
        return np.zeros(3)
    box = support.component.bbox_world
    at = np.clip(point_m, np.asarray(box.min_m), np.asarray(box.max_m))
    target = support.component.target_pose_world
    local = Rotation.from_quat(target.quat_xyzw).inv().apply(at - np.asarray(target.position_m))
    built_position, built_quat = support.as_built
    return Rotation.from_quat(built_quat).apply(local) + np.asarray(built_position) - at


def centre_m(frame: Frame, centre_local_m: tuple[float, float, float]) -> np.ndarray:
    """The world position of the point ``centre_local_m`` (component frame) at ``frame``."""
    return np.asarray(frame[0]) + np.asarray(rotate(frame[1], centre_local_m))


def on_its_seats(member: Component, target: Frame, supports: Iterable[BuiltSupport]) -> Frame:
    """``target`` raised or lowered by the mean vertical displacement of ``supports`` where they meet
    ``member`` (grouted links aside; none: ``target`` itself)."""
    centre = centre_m(target, member.com_local_m)
    rises = [
        float(displacement_at_m(support, centre)[2])
        for support in supports
        if support.kind is not ConnectionKind.GROUTED
    ]
    if not rises:
        return target
    (x, y, z), quat = target
    return (x, y, z + sum(rises) / len(rises)), quat


def following(target: Frame, support_target: Frame, support_as_built: Frame) -> Frame:
    """``target`` moved by the rigid displacement that takes ``support_target`` to ``support_as_built``:
    the member goes where a member it is bolted to went."""
    return compose(compose(support_as_built, invert(support_target)), target)


def shifted(member: Component, target: Frame, other: Component, other_as_built: Frame) -> Frame:
    """``target`` moved, not turned, as far as ``other`` as built moved its point nearest ``member``'s
    centre: a finish panel notched round a partition is drawn up to where the partition stands, not swung
    with it (a partition turned 0.4° about its own origin swings a 3.7 m floor panel 26 mm at its far
    end, beyond every tolerance, where the partition's face beside it moved 7 mm)."""
    support = BuiltSupport(ConnectionKind.FASTENED, other, other_as_built)
    (x, y, z), quat = target
    dx, dy, dz = displacement_at_m(support, centre_m(target, member.com_local_m))
    return (x + float(dx), y + float(dy), z + float(dz)), quat


def deepest_m(overlaps: Iterable[tuple[str, float]]) -> float:
    """The deepest of ``overlaps`` (GUID, metres; 0 when none)."""
    return max((depth for _, depth in overlaps), default=0.0)


def halfway(a: Frame, b: Frame) -> Frame:
    """The frame halfway between ``a`` and ``b`` (positions averaged, orientations slerped)."""
    quat = Slerp([0.0, 1.0], Rotation.from_quat([a[1], b[1]]))(0.5).as_quat()
    x, y, z = ((u + v) / 2.0 for u, v in zip(a[0], b[0], strict=True))
    return (x, y, z), (float(quat[0]), float(quat[1]), float(quat[2]), float(quat[3]))


def fit_score(
    clash_m: float, framed_m: Mapping[str, float], allowed_m: Mapping[str, float]
) -> tuple[int, float]:
    """How well an aim fits, lower better: first what its release would clear, in whole millimetres (the
    deepest overlap ``clash_m`` with a part it is not framed to, or how far a framed partner's overlap
    ``framed_m`` goes beyond what its joint allows, ``allowed_m``); then the deepest framed overlap, the
    clearance the robot's own error eats into. A mullion between two transom ends, one of them set 10 mm
    towards it, fits best halfway: 5 mm into each end, not 10 mm into one."""
    beyond = max((depth - allowed_m[guid] for guid, depth in framed_m.items()), default=0.0)
    return round(1000.0 * max(clash_m, beyond, 0.0)), max(framed_m.values(), default=0.0)


def bounded(member: Component, target: Frame, fitted: Frame, tolerances: Tolerances) -> Frame | None:
    """``fitted`` within the tolerances of ``target``: turned back to ``target``'s orientation if it turns
    further than the angle tolerance, its centre brought back to at most the position tolerance from
    ``target``'s; None when it is ``target`` itself (to within :data:`NEGLIGIBLE_M`)."""
    quat = fitted[1]
    turned = angle_error_rad(quat, target[1])
    if turned > tolerances.angle_rad:
        quat, turned = target[1], 0.0
    wanted = centre_m(fitted, member.com_local_m) - centre_m(target, member.com_local_m)
    length = float(np.linalg.norm(wanted))
    if not math.isfinite(length) or (length < NEGLIGIBLE_M and turned < 1e-6):
        return None
    if length > tolerances.position_m:
        wanted *= tolerances.position_m / length
    # the frame whose centre lies ``wanted`` from the target's centre, at orientation ``quat``
    centre = centre_m(target, member.com_local_m) + wanted
    origin = centre - np.asarray(rotate(quat, member.com_local_m))
    return (float(origin[0]), float(origin[1]), float(origin[2])), quat


def moved_with(placed: Frame, target: Frame, fitted: Frame) -> Frame:
    """A placement ``placed`` made against ``target``, made against ``fitted`` instead: the same error."""
    return compose(fitted, compose(invert(target), placed))


def describe(member: Component, fitted: Frame) -> str:
    """How far ``fitted`` moves and turns ``member`` from its BIM target, for the log."""
    at_target = target_frame(member)
    moved = centre_m(fitted, member.com_local_m) - centre_m(at_target, member.com_local_m)
    return (
        f"its target moved {1000.0 * float(np.linalg.norm(moved)):.1f} mm "
        f"({', '.join(f'{1000.0 * float(c):+.1f}' for c in moved)} mm), "
        f"turned {math.degrees(angle_error_rad(fitted[1], at_target[1])):.3f}°"
    )


def fit(
    state: HandlingState,
    item: Item,
    around: Mapping[int, str],
    model_clash: Callable[[str], bool],
    *,
    max_cleared_m: float,
) -> Frame | None:
    """``item``'s target as the structure built so far leaves room for it (see the module); None: its BIM
    target. ``around``: body → GUID of the components near it; ``model_clash``: whether the model itself
    draws it into a component (an overlap kept, not cleared)."""
    cid, body, component = state.client_id, item.body, item.component
    target = target_frame(component)
    aim = on_its_seats(component, target, built_supports(state, component))
    allowed = {
        guid: m
        for guid, m in state.framed.get(component.guid, {}).items()
        if (other := state.items.get(guid)) is not None and other.phase is Phase.JOINED
    }
    joints = state.joints.get(component.guid, frozenset())
    nearby = {b: g for b, g in around.items() if g not in joints and g not in allowed}
    framed = {b: g for b, g in around.items() if g not in joints and g in allowed}
    before = item.pose
    try:
        set_component_pose(cid, body, aim)
        kept = frozenset(other for other, _ in deep_overlaps(cid, body, aim, nearby) if model_clash(other))

        # every overlap the release would clear counts, up to its bound: one deeper than a clash's depth
        # is not invisible (a sill rammed 17 mm into the mullion it is framed to scored as no overlap)
        def framed_m(frame: Frame) -> dict[str, float]:
            return dict(intrusions(cid, body, frame, framed, frozenset(), max_cleared_m=max_cleared_m))

        def score(frame: Frame) -> tuple[int, float]:
            clash_m = deepest_m(intrusions(cid, body, frame, nearby, kept, max_cleared_m=max_cleared_m))
            return fit_score(clash_m, framed_m(frame), allowed)

        # where it fits best: its seats, following one of the built members in its way, or halfway between
        in_its_way = intrusions(cid, body, aim, nearby, kept) + intrusions(cid, body, aim, framed, kept)
        built = [
            other
            for other in (state.items.get(guid) for guid, _ in in_its_way)
            if other is not None and other.phase is Phase.JOINED
        ]
        follows = (
            []
            if is_board(component)
            else [following(target, target_frame(o.component), o.pose) for o in built]
        )
        follows += [shifted(component, target, other.component, other.pose) for other in built]
        tolerances = state.connections.fit

        def usable(frame: Frame) -> Frame:  # as far as a fit may move it: the frame that is scored is used
            return bounded(component, target, frame, tolerances) or target

        candidates = [aim, *follows, *(halfway(aim, follow) for follow in follows)]
        aim = min((usable(frame) for frame in candidates), key=score)
        # a framed partner overlapped no deeper than its joint allows is no overlap to clear
        depths_m = framed_m(aim)
        beyond = {b: g for b, g in framed.items() if depths_m.get(g, 0.0) > allowed[g]}
        cleared = clear_overlap(cid, body, aim, nearby | beyond, max_cleared_m=max_cleared_m, kept=kept)
    finally:
        set_component_pose(cid, body, before)
    return bounded(component, target, cleared.frame, tolerances)
