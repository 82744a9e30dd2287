"""Placing a component: the assembly motion to where the robot really puts it, the release into dynamics,
the watch while it settles, and joining it to the structure once its agent verified it.

Why a module of its own: the phases after ``carried`` (:mod:`.handling` documents all six) are where the
simulation decides whether a placement holds, the heart of the smart components' self-check. This mixin
holds that half of :class:`.handling.Handling`; the state it uses is the handling's own.

* :meth:`Placing.place` accepts a place request: reach and payload checks on where the component really
  goes (:func:`.placement_error.physical_placement`: the robot's localisation error and its type's
  precision), then the assembly motion (``assembling``).
* :meth:`Placing._release` ends the motion: a dynamic body with its real mass, colliding with what is under
  it and with the ground, unless it stands over the open pit of a foundation not placed yet (:mod:`.pits`).
* :meth:`Placing.watch_placed`, once per control period: drift, rest, supports (:mod:`.release`); a settled
  component's place request is answered with the pose it came to rest at.
* :meth:`Placing.join`: constructed — static where it rests, part of the structure for good.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping
from enum import StrEnum
from typing import TYPE_CHECKING

import numpy as np

from bimbot.shared.connection_kinds import SupportWhen
from bimbot.shared.construction_methods import ConstructionMethod
from bimbot.shared.footprint import body_centre_m, posed_footprint
from bimbot.shared.messages import PhysicsReply, PoseMsg
from bimbot.shared.site_plan import Rect

from .client import p
from .connections import fits_its_target, plan_connections, side_neighbours, within_gap
from .pits import DEEPER_M
from .placement_error import guided_yaw_std_rad, physical_placement
from .release import (
    MAX_CLEARED_M,
    Watch,
    box_corners,
    clear_overlap,
    deep_overlaps,
    observe,
    overlap_at_targets,
    supports_of,
    touching_robot,
)
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
from .temporary_supports import SupportRecord, anchored

if TYPE_CHECKING:
    from bimbot.shared.manifest import Component

    from .connections import ConnectionConfig
    from .handling import HandlingConfig, Item
    from .pits import Pits
    from .release import SettleConfig
    from .robots import Robot

_log = logging.getLogger(__name__)


FELL_OFF_M = 5.0  # below the ground or beyond the fence by this much, a released component has fallen off


class Phase(StrEnum):
    UNBUILT = "unbuilt"  # cast in place or laid, not built yet: out of sight (:mod:`.in_place_work`)
    RESTING = "resting"
    CARRIED = "carried"
    ASSEMBLING = "assembling"
    SETTLING = "settling"
    PLACED = "placed"
    JOINED = "joined"


DYNAMIC_PHASES = (Phase.SETTLING, Phase.PLACED)
STANDS_WHERE_BUILT = (ConstructionMethod.CAST_IN_PLACE, ConstructionMethod.LAID)
AT_TARGET_M = 0.1  # a component this close to its target stands where the model puts it (clash or not)


class Placing:
    """Place, release, watch and join (a mixin of :class:`.handling.Handling`)."""

    if TYPE_CHECKING:  # the handling's state
        client_id: int
        items: dict[str, Item]
        config: HandlingConfig
        site_bounds: Rect
        carrying: dict[str, str]
        changed: set[str]
        constructed: set[str]
        ground_id: int
        pits: Pits | None
        settle: SettleConfig
        connections: ConnectionConfig
        supports: SupportRecord
        in_place: dict[int, str]
        joints: dict[str, frozenset[str]]
        watch: dict[str, Watch]
        guid_of: dict[int, str]
        _moving: set[str]
        _separating: set[str]
        _seed: int
        _rngs: dict[str, np.random.Generator]
        _corners: dict[str, np.ndarray]  # GUID → its bounding box's corners (component frame)

        def _check_common(
            self, robot: Robot | None, guid: str, item: Item | None, *, fixed_ok: bool = False
        ) -> str | None: ...

        def _cannot_carry(
            self, robot: Robot, component: Component, frame: Frame, what: str
        ) -> tuple[str | None, float | None]: ...

        def _overlaps(self, item: Item, robot: Robot) -> bool: ...

        def _settle(self, item: Item) -> None: ...

    def place(
        self,
        robot: Robot,
        guid: str,
        target: PoseMsg,
        *,
        duration_s: float,
        now_s: float,
        tag: object,
        believed_xy_yaw: tuple[float, float, float] | None = None,
    ) -> PhysicsReply | None:
        """None when accepted (the reply comes from :meth:`watch_placed` with ``tag`` once the component
        came to rest), else the refusal. ``target`` is where the robot means to put it, in the world as it
        believes it stands at ``believed_xy_yaw`` (None: it knows its pose)."""
        item = self.items.get(guid)
        refusal = self._check_common(robot, guid, item)
        commanded: Frame | None = None
        if refusal is None:
            commanded, refusal = valid_frame(target)
        if refusal is None and not (
            math.isfinite(duration_s) and 0.0 <= duration_s <= self.config.max_place_duration_s
        ):
            refusal = f"duration_s must be within 0..{self.config.max_place_duration_s:g} s, got {duration_s}"
        if refusal is None and item is not None and item.phase is Phase.ASSEMBLING:
            refusal = f"{guid} is already being placed by {item.carrier}"
        if refusal is None and item is not None and item.carrier != robot.robot_id:
            refusal = (
                f"{guid} is carried by {item.carrier}, not {robot.robot_id}"
                if item.carrier
                else f"robot {robot.robot_id} does not carry {guid}"
            )
        frame: Frame | None = None
        if refusal is None and commanded is not None and item is not None:
            frame = self._where_it_goes(robot, commanded, believed_xy_yaw, item.component)
            # the footprint, not the frame's origin: a Revit element may keep an identity placement with its
            # geometry in world coordinates, so its frame lies at (0, 0) while it stands on the site
            centre = posed_footprint(item.component, frame[0], frame[1]).centre_xy_m
            if not inside(self.site_bounds, (float(centre[0]), float(centre[1]))):
                refusal = f"target ({centre[0]:.2f}, {centre[1]:.2f}) of {guid} is outside the site"
        beyond: float | None = None
        if refusal is None and item is not None and frame is not None:
            refusal, beyond = self._cannot_carry(robot, item.component, frame, f"the target of {guid}")
        if refusal is not None or item is None or frame is None or commanded is None:
            return PhysicsReply(ok=False, reason=refusal or "", sim_time_s=now_s, distance_m=beyond)
        item.phase = Phase.ASSEMBLING
        item.motion_from = item.pose
        item.motion_to = frame
        item.meant_quat_xyzw = commanded[1]
        item.motion_start_s = now_s
        item.motion_duration_s = duration_s
        item.tag = tag
        self._moving.add(guid)
        _log.info(
            "%s: %s places it over %.2f s, its centre %.1f mm from where it was asked to",
            guid,
            robot.robot_id,
            duration_s,
            1000.0
            * math.dist(
                *(compose(f, (item.component.com_local_m, IDENTITY[1]))[0] for f in (frame, commanded))
            ),
        )
        return None

    def _where_it_goes(
        self,
        robot: Robot,
        commanded: Frame,
        believed_xy_yaw: tuple[float, float, float] | None,
        component: Component,
    ) -> Frame:
        """Where the robot's placement really puts the component (:mod:`.placement_error`); the hand's
        turn is about the component's centre, and a type that guides a load's ends turns it less."""
        rng = self._rngs.get(robot.robot_id)
        if rng is None:
            rng = self._rngs[robot.robot_id] = np.random.default_rng([self._seed, 7, robot.index])
        description = robot.description
        yaw_std_rad = math.radians(description.placement_precision_yaw_deg)
        if description.placement_guided_ends:
            low, high = component.bbox_world.min_m, component.bbox_world.max_m
            half_span_m = 0.5 * math.hypot(high[0] - low[0], high[1] - low[1])
            yaw_std_rad = guided_yaw_std_rad(yaw_std_rad, description.placement_precision_m, half_span_m)
        return physical_placement(
            commanded,
            believed_xy_yaw if robot.drives else None,
            robot.pose_xy_yaw(self.client_id),
            precision_m=description.placement_precision_m,
            precision_yaw_rad=yaw_std_rad,
            rng=rng,
            centre_local_m=component.com_local_m,
        )

    def _release(self, item: Item, carrier: Robot | None, now_s: float, tag: object) -> None:
        """The assembly motion ended: a dynamic body where it is, watched until it rests."""
        guid = item.component.guid
        cid, body = self.client_id, item.body
        item.pose = item.motion_to or item.pose
        set_component_pose(cid, body, item.pose)
        set_filter(cid, body.body_id, DYNAMIC_GROUP, ALL_GROUPS)  # see what it overlaps, the carrier aside
        partners = self.joints.get(guid, frozenset())
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
                if clash[0] in in_model and self._at_its_target(self.items[clash[0]])
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
        if carrier is not None and carrier.drives and self._overlaps(item, carrier):
            # it collides with its carrier again once clear of it. Until then it keeps the carrier's group, as
            # when carried: a pair collides when either mask admits the other's group (scene.py), and the
            # carrier's mask admits the dynamic group, so that group here let the carrier kick it over
            item.separating_from = carrier
            self._separating.add(guid)
            set_filter(cid, body.body_id, carrier.group, ALL_GROUPS ^ carrier.group)
        else:
            item.separating_from = None
            set_filter(cid, body.body_id, DYNAMIC_GROUP, ALL_GROUPS)
        # Its centre of mass over an open pit: it falls in, onto the pit's floor. Beside one it rests on the
        # ground at the pit's edge (the ground plane has no edge: with it off, a footing set 0.3 m off its
        # own pit tipped off the floor's edge and fell for ever).
        com_xy = p.getBasePositionAndOrientation(body.body_id, physicsClientId=cid)[0][:2]
        pits = self.pits.open_around((com_xy[0], com_xy[1])) if self.pits else []
        (x, y, z), quat = item.pose
        turn = np.asarray(p.getMatrixFromQuaternion(quat)).reshape(3, 3)
        bottom_z = z + float((box_corners(item.component) @ turn.T)[:, 2].min())
        if not pits and self.ground_id >= 0 and bottom_z < 0.0 and not self._built_partners(guid):
            # lowered onto the ground, not into it (a footing off its pit); not a column drawn into its
            # built footing below the ground (a joint: the footing carries it)
            item.pose = ((x, y, z - bottom_z), quat)
            set_component_pose(cid, body, item.pose)
        if self.ground_id >= 0:
            p.setCollisionFilterPair(
                self.ground_id, body.body_id, -1, -1, 0 if pits else 1, physicsClientId=cid
            )
        if pits and self.pits is not None:
            # over the pit but hanging over its edge (or over a shallower pit's floor): it rests on what
            # is under it there, not in the soil, which the contact solver would throw it out of
            lift = self.pits.lift_onto_ground(body.body_id)
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
        connected_to, hold_s = ((), 0.0) if clashes or others else self._connect(item, now_s)
        if carrier is not None:
            self.carrying.pop(carrier.robot_id, None)
        releaser = carrier.robot_id if carrier is not None else None
        item.phase, item.carrier, item.offset, item.tag = Phase.SETTLING, None, None, None
        self._moving.discard(guid)
        self.watch[guid] = Watch(item.pose, now_s, releaser, tag, open_pits=others, clashes=clashes)
        watch = self.watch[guid]
        watch.connected_to = connected_to
        watch.set_against, watch.set_against_shift_m = against, centre_moved_m if against else 0.0
        watch.fixed = bool(connected_to) or guid in self.supports.standing
        if hold_s > 0.0:
            watch.hold_until_s = now_s + hold_s
            kinds = self.supports.kinds.get(guid, {})
            _log.info(
                "%s set down: %s; %s holds it %.0f s%s",
                guid,
                ", ".join(f"{kind.value} to {other}" for other, kind in kinds.items()) or "no connection",
                releaser or "nobody",
                hold_s,
                f" (with {self.supports.count(guid)} temporary supports set)"
                if self.supports.count(guid)
                else "",
            )
        self.changed.add(guid)

    def _connect(self, item: Item, now_s: float) -> tuple[tuple[str, ...], float]:
        """Connect ``item``, just let go, to the built neighbours (:mod:`.connections`) if it lies at its
        target; and set its temporary supports when it needs them and no connection holds it yet
        (:mod:`.temporary_supports`), at its target or off it: the crew props a member wherever the robot
        set it before the robot lets go, so one set off target stands propped until a robot takes it up
        again for its retry. Fixed where it is (static) when a connection or a support holds it. The GUIDs
        it is fixed to, and how long its robot holds it (0: it is let go at once)."""
        config = self.connections
        component = item.component
        guid = component.guid
        if not config.enabled:
            return (), 0.0
        found: tuple[str, ...] = ()
        if fits_its_target(component, item.pose, config.fit):
            found = self._connected_neighbours(item)
        else:
            _log.info("%s set down off its target: no connection is made (the holes miss)", guid)
        links = {link.other_guid: link for link in component.connection_links}
        plan = plan_connections(found, links, self._built_partners(guid), config.hold_s)
        self.supports.connect(guid, plan.kinds, {other: now_s + s for other, s in plan.holds_at_s.items()})
        hold_s = plan.connection_s
        need = component.temporary_support
        if need is not None and (
            need.when is SupportWhen.ALWAYS
            or (need.when is SupportWhen.UNCONNECTED and not plan.holds_at_s)
            or (
                need.when is SupportWhen.UNANCHORED
                and not anchored(guid, self.supports.holds_at_s, self._anchors())
            )
        ):
            self.supports.place(guid, need, now_s)
            hold_s += need.count * need.place_s
            _log.info("%s: %d %s set (%s)", guid, need.count, need.kind.value, need.why)
        if plan.fixed_to or guid in self.supports.standing:
            self._fix(item)
        return plan.fixed_to, hold_s

    def _connected_neighbours(self, item: Item) -> tuple[str, ...]:
        """The built neighbours ``item`` (at its target) is connected to: its jointed partners, the
        neighbours its manifest links name within the gap, and those beside it."""
        config = self.connections
        guid = item.component.guid
        jointed = self._built_partners(guid)
        structure = dict(self.in_place)
        structure.update(
            (other.body.body_id, other_guid)
            for other_guid, other in self.items.items()
            if other.phase is Phase.JOINED
        )
        if not structure:
            return jointed
        partners = self.joints.get(guid, frozenset())
        links = {link.other_guid for link in item.component.connection_links}
        cid, body = self.client_id, item.body
        near = self._nearby_components(item, margin_m=config.gap_m, among=structure)
        beside = side_neighbours(cid, body.body_id, near, config.gap_m)
        linked = within_gap(cid, body.body_id, {b: g for b, g in near.items() if g in links}, config.gap_m)
        return tuple(dict.fromkeys(jointed + linked + tuple(g for g in beside if g not in partners)))

    def _anchors(self) -> set[str]:
        """What stands by itself: in place from the start, or cast or laid where it stands and joined."""
        return set(self.in_place.values()) | {
            guid
            for guid, item in self.items.items()
            if item.phase is Phase.JOINED and item.component.method in STANDS_WHERE_BUILT
        }

    def remove_supports(self, now_s: float) -> None:
        """Take away the temporary supports of every member that now stands without them."""
        if not self.supports.standing:
            return
        for guid in self.supports.removable(now_s, self._anchors()):
            support = self.supports.remove(guid, now_s)
            if support is not None:
                self.changed.add(guid)
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
        other = self.items[other_guid]
        depth_m = overlap_at_targets(
            self.client_id,
            item.body,
            target_frame(item.component),
            other.body,
            target_frame(other.component),
        )
        return depth_m > MAX_CLEARED_M

    def _built_partners(self, guid: str) -> tuple[str, ...]:
        """The components ``guid`` is jointed with that are part of the structure (joined, or in place)."""
        partners = self.joints.get(guid, frozenset())
        if not partners:
            return ()
        in_place = set(self.in_place.values())
        return tuple(
            sorted(
                other
                for other in partners
                if other in in_place or (other in self.items and self.items[other].phase is Phase.JOINED)
            )
        )

    def _fix(self, item: Item) -> None:
        """Static where it is: connected, or joined. It still passes through a former carrier it overlaps
        until they are clear; static bodies never touch the ground (footings below it stay there)."""
        cid = self.client_id
        make_static(cid, item.body)
        set_component_pose(cid, item.body, item.pose)
        carrier = item.separating_from
        if carrier is not None:
            set_filter(cid, item.body.body_id, carrier.group, STATIC_MASK ^ carrier.group)
        if self.ground_id >= 0:
            p.setCollisionFilterPair(self.ground_id, item.body.body_id, -1, -1, 0, physicsClientId=cid)

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
        bodies = self.guid_of if among is None else among
        low, high = p.getAABB(item.body.body_id, -1, physicsClientId=self.client_id)
        found = p.getOverlappingObjects(
            [v - margin_m for v in low], [v + margin_m for v in high], physicsClientId=self.client_id
        )
        return {body: bodies[body] for body, _ in found or () if body in bodies}

    def watch_placed(self, now_s: float, robots: Mapping[str, Robot]) -> list[tuple[object, PhysicsReply]]:
        """Once per control period: every released component's pose, drift and rest, and the first of
        ``robots`` to touch it; the placements that came to rest are answered (``(tag, reply)``)."""
        answered: list[tuple[object, PhysicsReply]] = []
        config = self.settle
        robot_of = {robot.body_id: robot_id for robot_id, robot in robots.items()} if self.watch else {}
        for guid, watch in self.watch.items():
            item = self.items[guid]
            corners = self._corners.get(guid)
            if corners is None:
                corners = self._corners[guid] = box_corners(item.component)
            was_settled, drift_before_m = watch.settled, watch.drift_m
            item.pose = observe(self.client_id, item.body, corners, watch, now_s=now_s, config=config)
            if not watch.stopped and self._fell_off(item):  # settled or not: it may still tip off later
                watch.settled = watch.stopped = True
            if watch.placed_on is None:  # what it was set down on, before it could slide or tip away
                watch.placed_on = supports_of(self.client_id, item.body.body_id, self.guid_of)
            # a robot that touches it where it lay at the start of this period pushed it; one it fell onto
            # (a beam tipping off its column onto the carrier beside it) did not
            if watch.bumped_by is None and robot_of and drift_before_m <= config.report_drift_m:
                bumper = touching_robot(self.client_id, item.body.body_id, robot_of)
                if bumper is not None:
                    watch.bumped_by, watch.bumped_at_s = bumper, now_s
                    self.changed.add(guid)
                    _log.info(
                        "%s touched by robot %s at t=%.2f s, %.1f mm from where it was released",
                        guid,
                        bumper,
                        now_s,
                        1000.0 * watch.drift_m,
                    )
            if not watch.settled or abs(watch.drift_m - watch.published_drift_m) >= config.publish_drift_m:
                watch.published_drift_m = watch.drift_m
                self.changed.add(guid)
            if watch.settled and not was_settled:
                item.phase = Phase.PLACED
                # a connected component is static: Bullet makes no contacts between static bodies
                rests_on = supports_of(self.client_id, item.body.body_id, self.guid_of)
                watch.supports = tuple(dict.fromkeys(rests_on + watch.connected_to))
                self.changed.add(guid)
            if watch.settled and watch.tag is not None and now_s >= watch.hold_until_s:
                answered.append(
                    (watch.tag, PhysicsReply(ok=True, sim_time_s=now_s, pose=pose_msg(item.pose)))
                )
                watch.tag, watch.releaser = None, None
                _log.info(
                    "%s at rest at t=%.2f s, %.1f mm from where it was released, on %s",
                    guid,
                    now_s,
                    1000.0 * watch.drift_m,
                    ", ".join(watch.supports) or "the ground",
                )
            if watch.drift_m > config.report_drift_m and not watch.reported:
                watch.reported = True
                _log.warning(
                    "%s moved %.3f m since it was released at t=%.2f s (unstable); it was set down on %s%s%s",
                    guid,
                    watch.drift_m,
                    watch.start_s,
                    ", ".join(watch.placed_on or ()) or "the ground (or nothing)",
                    f", over the open pit of {', '.join(watch.open_pits)}" if watch.open_pits else "",
                    f"; robot {watch.bumped_by} touched it at t={watch.bumped_at_s:.2f} s"
                    if watch.bumped_by
                    else "",
                )
        self.remove_supports(now_s)
        return answered

    def _fell_off(self, item: Item) -> bool:
        """A released component far below the ground or off the site (it slid off a pit's floor, or was
        thrown) would fall for ever: it is stopped where it is, static, and reported as it is (its drift says
        it did not hold). Poses on the bus stay bounded. Judged by its centre of mass, not its frame's origin:
        an element placed by an identity placement (common in Revit exports) has its origin at the model's
        origin, far from its geometry and possibly off the site."""
        (x, y, z), _ = p.getBasePositionAndOrientation(item.body.body_id, physicsClientId=self.client_id)
        (x0, y0), (x1, y1) = self.site_bounds.min_xy, self.site_bounds.max_xy
        margin = FELL_OFF_M
        if z > -margin and x0 - margin < x < x1 + margin and y0 - margin < y < y1 + margin:
            return False
        make_static(self.client_id, item.body)
        _log.warning(
            "%s fell off the site at (%.1f, %.1f, %.1f): stopped there, static", item.component.guid, x, y, z
        )
        return True

    def set_down(self, guid: str, now_s: float, tag: object = None) -> None:
        """Put ``guid`` at its BIM pose and release it there, without a robot (the stability replay,
        :mod:`.stability`); ``tag`` comes back with the reply once it rests."""
        item = self.items[guid]
        item.motion_to = target_frame(item.component)
        item.meant_quat_xyzw = item.motion_to[1]
        self._release(item, None, now_s, tag)

    def join(self, guid: str) -> None:
        """Its agent verified it: static where it rests, joined to the structure for good."""
        item = self.items[guid]
        watch = self.watch.pop(guid, None)
        cid = self.client_id
        item.pose = component_pose(cid, item.body)
        if watch is not None:
            item.drift_m = watch.drift_m
            item.supports = watch.supports or supports_of(cid, item.body.body_id, self.guid_of)
            item.connected_to = watch.connected_to
        self._fix(item)
        item.phase = Phase.JOINED
        self.changed.add(guid)
        _log.info(
            "%s joined to the structure (%s), %.1f mm from where it was released",
            guid,
            ", ".join(item.supports) or "on the ground",
            1000.0 * (item.drift_m or 0.0),
        )


def target_frame(component: Component) -> Frame:
    """The component frame at its BIM target pose."""
    target = component.target_pose_world
    position, quat = target.position_m, target.quat_xyzw
    return ((position[0], position[1], position[2]), (quat[0], quat[1], quat[2], quat[3]))


def pose_msg(frame: Frame) -> PoseMsg:
    return PoseMsg(position_m=frame[0], quat_xyzw=frame[1])


def valid_frame(pose: PoseMsg) -> tuple[Frame | None, str | None]:
    values = [*pose.position_m, *pose.quat_xyzw]
    if not all(math.isfinite(v) for v in values):
        return None, "invalid pose: not finite"
    norm = math.sqrt(sum(q * q for q in pose.quat_xyzw))
    if not 0.5 < norm < 1.5:
        return None, f"invalid pose: quat_xyzw norm {norm:.3g} is not a rotation"
    quat = tuple(q / norm for q in pose.quat_xyzw)
    return (tuple(pose.position_m), quat), None  # type: ignore[return-value]


def inside(rect: Rect, xy: tuple[float, float]) -> bool:
    return rect.min_xy[0] <= xy[0] <= rect.max_xy[0] and rect.min_xy[1] <= xy[1] <= rect.max_xy[1]
