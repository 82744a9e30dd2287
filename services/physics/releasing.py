"""The release into dynamics: a component let go at the end of its assembly motion (or set down where the
model puts it, without a robot), fastened to its built neighbours, propped where it needs it.

Why a part of its own: the release decides where a placement really comes to rest before the watch
(:mod:`.watching`) sees it move: seated against what stands there or kept in a clash the model itself
makes (:mod:`.release`), lowered onto the ground or into the open pit of a foundation not placed yet
(:mod:`.pits`), connected to its built neighbours and fixed (:mod:`.connections`), propped by temporary
supports (:mod:`.temporary_supports`). It works on the shared :class:`.handling_state.HandlingState`.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping

import numpy as np

from bimbot.shared.connection_hold import plan_connections, sets_supports, supports_s
from bimbot.shared.footprint import body_centre_m
from bimbot.shared.work_methods import BUILT_IN_PLACE

from .client import p
from .connections import fits_its_target, side_neighbours, within_gap
from .handling_state import HandlingState, Item, Phase, target_frame
from .pits import DEEPER_M
from .release import (
    MAX_CLEARED_M,
    Watch,
    box_corners,
    clear_overlap,
    deep_overlaps,
    overlap_at_targets,
)
from .robots import Robot
from .scene import (
    ALL_GROUPS,
    DYNAMIC_GROUP,
    IDENTITY,
    STATIC_MASK,
    Frame,
    component_pose,
    compose,
    make_dynamic,
    make_static,
    set_component_pose,
    set_filter,
)
from .support_fit import describe, fit, moved_with
from .temporary_supports import anchored

_log = logging.getLogger(__name__)

AT_TARGET_M = 0.1  # a component this close to its target stands where the model puts it (clash or not)


class Releasing:
    """Release, connect, support and fix components (see the module doc); no state of its own."""

    def __init__(self, state: HandlingState) -> None:
        self._state = state

    def release(self, item: Item, carrier: Robot | None, now_s: float, tag: object) -> None:
        """The assembly motion ended: a dynamic body where it is, watched until it rests."""
        state = self._state
        guid = item.component.guid
        cid, body = state.client_id, item.body
        item.pose = item.motion_to or item.pose
        set_component_pose(cid, body, item.pose)
        if state.ground_id >= 0:  # off the ground until it is known whether the ground carries it (below)
            p.setCollisionFilterPair(state.ground_id, body.body_id, -1, -1, 0, physicsClientId=cid)
        set_filter(cid, body.body_id, DYNAMIC_GROUP, ALL_GROUPS)  # see what it overlaps, the carrier aside
        # a robot's placement at its target fitted to the structure as it stands (.support_fit); a set-down
        # without one (the stability replay) goes to the BIM target
        at_target = carrier is not None and self._at_its_target(item, released=True)
        item.fitted_target = self._fit_to_structure(item) if at_target else None
        if item.fitted_target is not None:
            item.pose = moved_with(item.pose, target_frame(item.component), item.fitted_target)
            set_component_pose(cid, body, item.pose)
            _log.info(
                "%s fitted to the structure as built: %s", guid, describe(item.component, item.fitted_target)
            )
        partners = state.joints.get(guid, frozenset()) | self._framed_within_clearance(item)
        nearby = {other: g for other, g in self._nearby_components(item).items() if g not in partners}
        # a joint partner is no overlap to clear; one the model itself puts it into is kept (a clash in
        # the IFC); one a placement's error put it into is cleared: the robot stops at the contact
        in_model = frozenset(
            other
            for other, _ in deep_overlaps(cid, body, item.pose, nearby)
            if self._model_clash(item, other)
        )
        cleared = clear_overlap(
            cid,
            body,
            item.pose,
            nearby,
            max_cleared_m=AT_TARGET_M,
            kept=in_model,
            meant_quat_xyzw=item.meant_quat_xyzw,
            centre_local_m=item.component.com_local_m,
        )
        centre_moved_m = math.dist(
            *(compose(f, (item.component.com_local_m, IDENTITY[1]))[0] for f in (cleared.frame, item.pose))
        )
        if centre_moved_m > 0.001 or cleared.frame[1] != item.pose[1]:
            _log.info(
                "%s set down against what stands there: %s, its centre moved %.1f mm",
                guid,
                "seated flush" if cleared.frame[1] != item.pose[1] else "stopped at the contact",
                1000.0 * centre_moved_m,
            )
        item.pose = cleared.frame
        against = cleared.against if centre_moved_m > 0.001 else ()
        # a clash in the IFC only where both stand where the model puts them: a mullion a robot dropped
        # beside a panel's target, or a component set down 2 m off, is no fault of the model
        clashes = (
            tuple(
                clash
                for clash in cleared.clashes
                if clash[0] in in_model and self._at_its_target(state.items[clash[0]])
            )
            if self._at_its_target(item, released=True)
            else ()
        )
        set_component_pose(cid, body, item.pose)
        if clashes:
            _log.info(
                "%s released into %s: the model puts them in one place (a clash in the IFC)",
                guid,
                ", ".join(f"{other} ({1000.0 * depth:.0f} mm deep)" for other, depth in clashes),
            )
        make_dynamic(cid, body)
        p.resetBaseVelocity(body.body_id, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], physicsClientId=cid)
        if carrier is not None and carrier.drives and state.overlaps(item, carrier):
            # it collides with its carrier again once clear of it. Until then it keeps the carrier's group, as
            # when carried: a pair collides when either mask admits the other's group (scene.py), and the
            # carrier's mask admits the dynamic group, so that group here let the carrier kick it over
            item.separating_from = carrier
            state.separating.add(guid)
            set_filter(cid, body.body_id, carrier.group, ALL_GROUPS ^ carrier.group)
        else:
            item.separating_from = None
            set_filter(cid, body.body_id, DYNAMIC_GROUP, ALL_GROUPS)
        # Its centre of mass over an open pit: it falls in, onto the pit's floor. Beside one it rests on the
        # ground at the pit's edge (the ground plane has no edge: with it off, a footing set 0.3 m off its
        # own pit tipped off the floor's edge and fell for ever).
        com_xy = p.getBasePositionAndOrientation(body.body_id, physicsClientId=cid)[0][:2]
        pits = state.pits.open_around((com_xy[0], com_xy[1])) if state.pits else []
        (x, y, z), quat = item.pose
        turn = np.asarray(p.getMatrixFromQuaternion(quat)).reshape(3, 3)
        bottom_z = z + float((box_corners(item.component) @ turn.T)[:, 2].min())
        # at its target, a foundation goes into its own excavation even where its centre of mass is over none
        # of its pit's parts (a ring of strip footings)
        in_own_pit = self._in_own_excavation(item)
        if (
            not pits
            and not in_own_pit
            and state.ground_id >= 0
            and bottom_z < 0.0
            and not self._built_partners(guid)
        ):
            # lowered onto the ground, not into it (a footing off its pit); not a column drawn into its
            # built footing below the ground (a joint: the footing carries it)
            item.pose = ((x, y, z - bottom_z), quat)
            set_component_pose(cid, body, item.pose)
        if state.ground_id >= 0:
            p.setCollisionFilterPair(
                state.ground_id, body.body_id, -1, -1, 0 if pits or in_own_pit else 1, physicsClientId=cid
            )
        if pits and state.pits is not None:
            # over the pit but hanging over its edge (or over a shallower pit's floor): it rests on what
            # is under it there, not in the soil, which the contact solver would throw it out of
            lift = state.pits.lift_onto_ground(body.body_id)
            if lift > 0.0:
                item.pose = component_pose(cid, body)
                _log.info(
                    "%s set down on the edge of its excavation, %.0f mm above where it was released",
                    guid,
                    1000.0 * lift,
                )
        # its own pit is where it goes; a foundation of several parts has a pit a part; a pit whose floor
        # lies above its bottom cannot take it (the hub's 0.56 m footing under the 125 mm ground slab was
        # said to be "over the open pit" of the slab that rests on it, and --check-stability advised
        # placing the slab first)
        others = tuple(
            dict.fromkeys(
                pit.owner for pit in pits if pit.owner != guid and pit.floor_z_m < bottom_z - DEEPER_M
            )
        )
        if others:
            _log.info("%s released over the open pit of %s", guid, ", ".join(others))
        # over an open pit it is connected to what stands (a handrail bolted to a standing wall stands over
        # an excavation), but no crew props it there: what would rest on the pit's foundation falls in
        connected_to, hold_s = ((), 0.0) if clashes else self._connect(item, now_s, supports=not others)
        if carrier is not None:
            state.carrying.pop(carrier.robot_id, None)
        releaser = carrier.robot_id if carrier is not None else None
        item.phase, item.carrier, item.offset, item.tag = Phase.SETTLING, None, None, None
        state.moving.discard(guid)
        state.watch[guid] = Watch(item.pose, now_s, releaser, tag, open_pits=others, clashes=clashes)
        watch = state.watch[guid]
        watch.connected_to = connected_to
        watch.set_against, watch.set_against_shift_m = against, centre_moved_m if against else 0.0
        watch.fixed = bool(connected_to) or guid in state.supports.standing
        if hold_s > 0.0:
            watch.hold_until_s = now_s + hold_s
            kinds = state.supports.kinds.get(guid, {})
            _log.info(
                "%s set down: %s; %s holds it %.0f s%s",
                guid,
                ", ".join(f"{kind.value} to {other}" for other, kind in kinds.items()) or "no connection",
                releaser or "nobody",
                hold_s,
                f" (with {state.supports.count(guid)} temporary supports set)"
                if state.supports.count(guid)
                else "",
            )
        state.changed.add(guid)

    def _fit_to_structure(self, item: Item) -> Frame | None:
        """``item``'s target as the structure built so far leaves room for it (:func:`.support_fit.fit`);
        None: its BIM target."""
        return fit(
            self._state,
            item,
            self._nearby_components(item),
            lambda other: self._model_clash(item, other),
            max_cleared_m=AT_TARGET_M,
        )

    def _framed_within_clearance(self, item: Item) -> frozenset[str]:
        """The parts ``item`` is framed to at an end (:func:`.joints.framed_ends`) that it overlaps, as let
        go, no deeper than the model draws plus the erection clearance: it is not moved out of those. A
        member framed into the web of a beam set a few mm off stays on its target: the gap takes the error."""
        state = self._state
        allowed = state.framed.get(item.component.guid)
        if not allowed:
            return frozenset()
        within: set[str] = set()
        for other_guid, depth_m in allowed.items():
            other = state.items.get(other_guid)
            if other is None or other.phase is not Phase.JOINED:
                continue
            points = p.getClosestPoints(
                item.body.body_id, other.body.body_id, 0.0, physicsClientId=state.client_id
            )
            if max((-float(point[8]) for point in points or ()), default=0.0) <= depth_m:
                within.add(other_guid)
        return frozenset(within)

    def _connect(self, item: Item, now_s: float, *, supports: bool = True) -> tuple[tuple[str, ...], float]:
        """Connect ``item``, just let go, to the built neighbours (:mod:`.connections`) if it lies at its
        target; and set its temporary supports when it needs them and no connection holds it yet
        (:mod:`.temporary_supports`), at its target or off it: the crew props a member wherever the robot
        set it before the robot lets go, so one set off target stands propped until a robot takes it up
        again for its retry. Fixed where it is (static) when a connection or a support holds it. The GUIDs
        it is fixed to, and how long its robot holds it (0: it is let go at once)."""
        state = self._state
        config = state.connections
        component = item.component
        guid = component.guid
        if not config.enabled:
            return (), 0.0
        found: tuple[str, ...] = ()
        if fits_its_target(component, item.pose, config.fit, item.fitted_target):
            found = self._connected_neighbours(item)
        else:
            _log.info("%s set down off its target: no connection is made (the holes miss)", guid)
        links = {link.other_guid: link for link in component.connection_links}
        plan = plan_connections(found, links, self._built_partners(guid), config.hold_s)
        state.supports.connect(guid, plan.kinds, {other: now_s + s for other, s in plan.holds_at_s.items()})
        hold_s = plan.connection_s
        need = component.temporary_support if supports else None
        if need is not None and sets_supports(
            need, plan, anchored=lambda: anchored(guid, state.supports.holds_at_s, self._anchors())
        ):
            state.supports.place(guid, need, now_s)
            hold_s += supports_s(need)
            _log.info("%s: %d %s set (%s)", guid, need.count, need.kind.value, need.why)
        if plan.fixed_to or guid in state.supports.standing:
            self.fix(item)
        return plan.fixed_to, hold_s

    def _connected_neighbours(self, item: Item) -> tuple[str, ...]:
        """The built neighbours ``item`` (at its target) is connected to: its jointed partners, the
        neighbours its manifest links name within the gap, and those beside it."""
        state = self._state
        config = state.connections
        guid = item.component.guid
        jointed = self._built_partners(guid)
        structure = dict(state.in_place)
        structure.update(
            (other.body.body_id, other_guid)
            for other_guid, other in state.items.items()
            if other.phase is Phase.JOINED
        )
        if not structure:
            return jointed
        partners = state.joints.get(guid, frozenset())
        links = {link.other_guid for link in item.component.connection_links}
        cid, body = state.client_id, item.body
        near = self._nearby_components(item, margin_m=config.gap_m, among=structure)
        beside = side_neighbours(cid, body.body_id, near, config.gap_m)
        linked = within_gap(cid, body.body_id, {b: g for b, g in near.items() if g in links}, config.gap_m)
        return tuple(dict.fromkeys(jointed + linked + tuple(g for g in beside if g not in partners)))

    def _anchors(self) -> set[str]:
        """What stands by itself: in place from the start, or cast or laid where it stands and joined."""
        return set(self._state.in_place.values()) | {
            guid
            for guid, item in self._state.items.items()
            if item.phase is Phase.JOINED and item.component.method in BUILT_IN_PLACE
        }

    def remove_supports(self, now_s: float) -> None:
        """Take away the temporary supports of every member that now stands without them."""
        state = self._state
        if not state.supports.standing:
            return
        for guid in state.supports.removable(now_s, self._anchors()):
            support = state.supports.remove(guid, now_s)
            if support is not None:
                state.changed.add(guid)
                _log.info(
                    "%s: its %d %s removed at t=%.0f s, after %.0f s (its connections hold it)",
                    guid,
                    support.count,
                    support.kind.value,
                    now_s,
                    now_s - support.placed_s,
                )

    def _model_clash(self, item: Item, other_guid: str) -> bool:
        """Whether the model itself puts ``item`` and ``other_guid`` into each other deeper than a contact
        (at their BIM targets), rather than a placement a few millimetres off."""
        other = self._state.items[other_guid]
        depth_m = overlap_at_targets(
            self._state.client_id,
            item.body,
            target_frame(item.component),
            other.body,
            target_frame(other.component),
        )
        return depth_m > MAX_CLEARED_M

    def _built_partners(self, guid: str) -> tuple[str, ...]:
        """The components ``guid`` is jointed with that are part of the structure (joined, or in place)."""
        state = self._state
        partners = state.joints.get(guid, frozenset())
        if not partners:
            return ()
        in_place = set(state.in_place.values())
        return tuple(
            sorted(
                other
                for other in partners
                if other in in_place or (other in state.items and state.items[other].phase is Phase.JOINED)
            )
        )

    def fix(self, item: Item) -> None:
        """Static where it is: connected, or joined. It still passes through a former carrier it overlaps
        until they are clear; static bodies never touch the ground (footings below it stay there)."""
        state = self._state
        cid = state.client_id
        make_static(cid, item.body)
        set_component_pose(cid, item.body, item.pose)
        carrier = item.separating_from
        if carrier is not None:
            set_filter(cid, item.body.body_id, carrier.group, STATIC_MASK ^ carrier.group)
        if state.ground_id >= 0:
            p.setCollisionFilterPair(state.ground_id, item.body.body_id, -1, -1, 0, physicsClientId=cid)

    def _in_own_excavation(self, item: Item) -> bool:
        """Released at its target with a pit of its own: its excavation (pit floors and rims) carries it."""
        pits = self._state.pits
        guid = item.component.guid
        if pits is None or not any(pit.owner == guid for pit in pits.pits):
            return False
        return self._at_its_target(item, released=True)

    def _at_its_target(self, item: Item, *, released: bool = False) -> bool:
        """Whether ``item`` lies where the model puts it (its box's centre within ``AT_TARGET_M`` of its
        target's): the one being released, or one placed, not one lying where a robot dropped it."""
        if not released and item.phase not in (Phase.SETTLING, Phase.PLACED, Phase.JOINED):
            return False
        component = item.component
        target = component.target_pose_world
        here = body_centre_m(component, *item.pose)
        return math.dist(here, body_centre_m(component, target.position_m, target.quat_xyzw)) <= AT_TARGET_M

    def _nearby_components(
        self, item: Item, *, margin_m: float = 0.01, among: Mapping[int, str] | None = None
    ) -> dict[int, str]:
        """Body → GUID of the components (of ``among``, body → GUID; default every one physics moves) whose
        boxes come within ``margin_m`` of ``item``'s now (what it may be set into, or connected to)."""
        state = self._state
        bodies = state.guid_of if among is None else among
        low, high = p.getAABB(item.body.body_id, -1, physicsClientId=state.client_id)
        found = p.getOverlappingObjects(
            [v - margin_m for v in low], [v + margin_m for v in high], physicsClientId=state.client_id
        )
        return {body: bodies[body] for body, _ in found or () if body in bodies}
