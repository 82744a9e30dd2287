"""Attach, carry, place and drop: what happens to components between the yard and the structure.

Every component is in one of seven phases (one more, ``unbuilt``, for a component cast in place or laid
before it is built: :mod:`.in_place_work`):

* ``resting`` — in its yard slot (or where a robot put it down: a lost robot's load, or a load its robot
  could not deliver and asked to drop): static, attachable by any robot.
* ``carried`` — attached to a robot: kinematic, reset every physics step to ``robot frame ∘ carry offset``
  (lying flat on top of the robot, centred over its base frame, ``carry_clearance_m`` above its highest
  collision shape). It rises there from where it lay over ``lift_s`` sim seconds. It takes the robot's
  collision group bit: the carrier neither collides with it nor sees it in its laser; others do. A tower
  crane's load hangs on its hook instead: lifted ``hook_lift_m`` straight up from where it lay, and it
  stays there until placed; the crane's joints follow it (hook above its top, :mod:`.crane`).
* ``assembling`` — a place request was accepted: the component moves from its pose at the request to where
  the placement really puts it (:mod:`.placement_error`: the requested pose carried from the robot's
  believed frame into its true one, plus the robot type's precision) over ``duration_s`` sim seconds
  (linear position, slerp orientation); the carrier holds still. The reply is held back.
* ``settling`` — released into dynamics at the end of the motion (:mod:`.release`): its real mass and
  inertia, its convex parts, friction; it rests on what is under it, or slides, tips or falls (into the
  pit of a foundation not placed yet, :mod:`.pits`). Once at rest (or after the settling bound) the place
  request is answered with the pose it came to rest at, its drift and what it rests on.
* ``placed`` — settled, still dynamic and watched (another placement may knock it), until its agent
  verifies it. Before that a robot may pick it up again, which is how a misplaced component is taken off
  for its retry.
* ``joined`` — its agent declared it constructed (:meth:`Handling.note_constructed`): joined to the
  structure, static where it came to rest (a fixed constraint to what carries it, which is itself joined
  or the ground: the same as fixing it in place), never attached again. Static bodies never touch the
  ground plane or each other, so footings placed below ground stay there.

A placed component collides with its former carrier again only once their bounding boxes no longer
overlap, so a robot standing on a target footprint is never thrown off.

Payload and reach (attach and place), by the carrying robot's own description
(:mod:`bimbot.shared.robot_description`), on the component's footprint (the shared
:func:`bimbot.shared.footprint.posed_footprint`) — its current one for attach, the one at the requested pose
for place: a ground robot refuses a component heavier than its ``payload_kg``, and one whose footprint's
nearest point is farther than its ``reach_m`` from its base frame origin; a crane refuses a footprint whose
nearest point lies inside its smallest hook radius or beyond its reach, and a component heavier than its
load chart allows at the footprint's farthest point. Every refusal says why, naming robot, type,
component and numbers.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from bimbot.shared.construction_methods import ConstructionMethod
from bimbot.shared.manifest import Component
from bimbot.shared.messages import ComponentPoseMsg, PhysicsReply
from bimbot.shared.robot_description import LIFT_CLEARANCE_M
from bimbot.shared.site_plan import Rect

from .client import p
from .connections import ConnectionConfig
from .crane import hook_joints, lift_position, load_top
from .load_rules import carry_refusal, drop_beside, lowered, lying_corners
from .pits import Pits
from .placing import DYNAMIC_PHASES, Phase, Placing, pose_msg
from .release import SettleConfig, Watch
from .robots import Robot
from .scene import (
    ALL_GROUPS,
    DYNAMIC_GROUP,
    STATIC_GROUP,
    STATIC_MASK,
    ComponentBody,
    Frame,
    Quat,
    component_pose,
    compose,
    footprint,
    interpolate,
    invert,
    make_static,
    set_component_pose,
    set_filter,
)
from .temporary_supports import SupportRecord

_log = logging.getLogger(__name__)

BUILT_WHERE_IT_STANDS = (ConstructionMethod.CAST_IN_PLACE, ConstructionMethod.LAID)


@dataclass(frozen=True)
class HandlingConfig:
    lift_s: float = 1.0
    hook_lift_m: float = 1.0  # a crane lifts its load this far above where it lay
    carry_clearance_m: float = 0.02
    max_place_duration_s: float = 900.0  # a tower crane's lift across the site takes minutes


@dataclass
class Item:
    """One component's handling state; ``pose`` is its component frame in the world."""

    component: Component
    body: ComponentBody
    phase: Phase
    pose: Frame
    carrier: str | None = None
    offset: Frame | None = None  # carried: component frame in the carrier's base frame
    motion_from: Frame | None = None
    motion_to: Frame | None = None  # assembling: where the placement really puts it
    meant_quat_xyzw: Quat | None = None  # assembling: the orientation the robot meant (its target's)
    motion_start_s: float = 0.0
    motion_duration_s: float = 0.0
    tag: object = None  # assembling: handed back with the reply
    separating_from: Robot | None = None  # placed, still overlapping its former carrier
    dropped_by: str | None = None  # resting where this robot put it down (a repeated drop request is ok)
    drift_m: float | None = None  # joined: how far it had moved since its release
    supports: tuple[str, ...] = ()  # placed or joined: the components it rests on
    connected_to: tuple[str, ...] = ()  # joined: the components it was connected to as it was set down


def hanging_offset(robot: Robot, frame: Frame, client_id: int) -> Frame:
    """A crane's load held at ``frame`` (world), in the crane's base frame: it stays there while carried."""
    return compose(invert(robot.frame(client_id)), frame)


def carry_offset(component: Component, robot: Robot, clearance_m: float) -> Frame:
    """The component lying flat (longest extent along the robot's x) on top of the robot, centred."""
    rotation, turned = lying_corners(component)
    centre = (turned.min(axis=0) + turned.max(axis=0)) / 2.0
    base_z = robot.top_height_m + clearance_m - turned[:, 2].min()
    quat = Rotation.from_matrix(rotation).as_quat()
    return (float(-centre[0]), float(-centre[1]), float(base_z)), tuple(float(q) for q in quat)  # type: ignore[return-value]


class Handling(Placing):
    """The phases of every component; the simulation calls :meth:`follow` after every physics step and
    :meth:`watch_placed` once per control period (:class:`.placing.Placing`: place, release, join)."""

    def __init__(
        self,
        client_id: int,
        items: dict[str, Item],
        config: HandlingConfig,
        site_bounds: Rect,
        *,
        ground_id: int = -1,
        pits: Pits | None = None,
        settle: SettleConfig | None = None,
        connections: ConnectionConfig | None = None,
        in_place: Mapping[int, str] | None = None,
        joints: Mapping[str, frozenset[str]] | None = None,
        seed: int = 0,
    ) -> None:
        self.client_id = client_id
        self.items = items
        self.config = config
        self.site_bounds = site_bounds
        self.carrying: dict[str, str] = {}  # robot id → GUID (carried or assembling)
        self.changed: set[str] = set()  # GUIDs whose pose changed since the last take_changed()
        self.constructed: set[str] = set()  # declared constructed by their agents: joined for good
        self._moving: set[str] = set()
        self._separating: set[str] = set()  # placed, still overlapping their former carrier
        self.ground_id = ground_id
        self.pits = pits
        self.settle = settle or SettleConfig()
        self.watch: dict[str, Watch] = {}  # settling and placed components
        self.guid_of = {item.body.body_id: guid for guid, item in items.items()}
        self.connections = connections or ConnectionConfig()
        self.supports = SupportRecord()  # connections made and temporary supports (.temporary_supports)
        self.in_place = dict(in_place or {})  # body → GUID of the components in place from the start
        self.joints = dict(joints or {})  # GUID → the GUIDs it is jointed with (.joints): never a clash
        self._seed = seed
        self._rngs: dict[str, np.random.Generator] = {}  # robot id → its hand's precision draws
        self._corners: dict[str, np.ndarray] = {}  # GUID → its bounding box's corners (component frame)

    def note_constructed(self, guid: str, constructed: bool) -> None:
        """What a component's agent says of it (from ``components/<key>/state``): constructed joins it to
        the structure where it rests, once its placement was answered (no agent can have verified a
        placement still settling: such a claim joins nothing). Anything else said of a joined component
        means it was joined on a claim its agent did not make (a forged message on an open bus; the agents'
        constructed is final): it is released again where it lies, so the robots can take it up again."""
        item = self.items.get(guid)
        if constructed:
            self.constructed.add(guid)
            if item is not None and item.phase is Phase.PLACED:
                self.join(guid)
            return
        self.constructed.discard(guid)
        if item is not None and item.phase is Phase.JOINED:
            _log.warning("%s: its agent does not say constructed: released again where it lies", guid)
            item.motion_to, item.separating_from = None, None
            self._release(item, None, now_s=-math.inf, tag=None)
            self.watch[guid].settled = True
            item.phase = Phase.PLACED

    def restore(self, guid: str, frame: Frame, *, fixed: bool, carrier: Robot | None) -> None:
        """Put ``guid`` back as a restarted physics found it in its record: carried by ``carrier`` (at once,
        no lift), placed (released again where it lay, watched as settled; joined once its twin says
        constructed, :meth:`note_constructed`), or resting at ``frame``."""
        item = self.items[guid]
        item.pose, item.tag, item.motion_to = frame, None, None
        item.separating_from, item.dropped_by = None, None
        self.watch.pop(guid, None)
        if carrier is not None:
            item.phase, item.carrier = Phase.CARRIED, carrier.robot_id
            item.offset = (
                hanging_offset(carrier, frame, self.client_id)
                if carrier.lifts_by_hook
                else carry_offset(item.component, carrier, self.config.carry_clearance_m)
            )
            item.motion_from, item.motion_start_s = frame, -math.inf
            self.carrying[carrier.robot_id] = guid
            self._moving.add(guid)
            make_static(self.client_id, item.body)
            set_filter(self.client_id, item.body.body_id, carrier.group, STATIC_MASK ^ carrier.group)
        elif fixed:
            item.carrier, item.offset, item.motion_from = None, None, None
            self._moving.discard(guid)
            set_component_pose(self.client_id, item.body, frame)
            self._release(item, None, now_s=-math.inf, tag=None)
            self.watch[guid].settled = True
            item.phase = Phase.PLACED
            if guid in self.constructed:
                self.join(guid)
        else:
            item.phase = Phase.RESTING
            item.carrier, item.offset, item.motion_from = None, None, None
            self._moving.discard(guid)
            make_static(self.client_id, item.body)
            set_component_pose(self.client_id, item.body, frame)
        self.changed.add(guid)

    # --- requests ------------------------------------------------------------------------------------

    def attach(self, robot: Robot, guid: str, now_s: float) -> PhysicsReply:
        item = self.items.get(guid)
        refusal = self._check_common(robot, guid, item, fixed_ok=guid not in self.constructed)
        if refusal is None and item is not None and item.phase in (Phase.CARRIED, Phase.ASSEMBLING):
            holder = item.carrier
            refusal = (
                f"{guid} is already carried by {holder}"
                if item.phase is Phase.CARRIED
                else f"{guid} is being placed by {holder}"
            )
        if refusal is None and item is not None and item.phase is Phase.SETTLING:
            refusal = f"{guid} was just placed and is settling"
        if refusal is None and robot.robot_id in self.carrying:
            refusal = f"robot {robot.robot_id} already carries {self.carrying[robot.robot_id]}"
        beyond: float | None = None
        if refusal is None and item is not None:
            refusal, beyond = self._cannot_carry(robot, item.component, item.pose, guid)
        if refusal is not None or item is None:
            return PhysicsReply(ok=False, reason=refusal or "", sim_time_s=now_s, distance_m=beyond)
        if item.phase is Phase.PLACED:  # taken off again for its retry: no longer watched, kinematic
            self.watch.pop(guid, None)
            item.pose = component_pose(self.client_id, item.body)
            make_static(self.client_id, item.body)
            support = self.supports.take_up(guid, now_s)  # unbolted, and its props or braces taken away
            if support is not None:
                _log.info(
                    "%s: its %d %s removed as %s takes it up",
                    guid,
                    support.count,
                    support.kind.value,
                    robot.robot_id,
                )
        item.phase = Phase.CARRIED
        item.carrier = robot.robot_id
        item.dropped_by = None
        if robot.lifts_by_hook:  # on the hook, straight up from where it lay
            (x, y, z), quat = item.pose
            item.offset = hanging_offset(robot, ((x, y, z + self.config.hook_lift_m), quat), self.client_id)
        else:
            item.offset = carry_offset(item.component, robot, self.config.carry_clearance_m)
        item.motion_from = item.pose
        item.motion_start_s = now_s
        item.separating_from = None
        self.carrying[robot.robot_id] = guid
        self._moving.add(guid)
        self.changed.add(guid)
        set_filter(self.client_id, item.body.body_id, robot.group, STATIC_MASK ^ robot.group)
        _log.info("%s attached to %s at t=%.2f s", guid, robot.robot_id, now_s)
        return PhysicsReply(ok=True, sim_time_s=now_s, pose=pose_msg(item.pose))

    def _check_common(
        self, robot: Robot | None, guid: str, item: Item | None, *, fixed_ok: bool = False
    ) -> str | None:
        if robot is None:
            return "unknown robot"
        if item is None:
            return f"unknown component {guid}"
        if item.phase is Phase.JOINED:
            return f"{guid} is constructed (joined to the structure)"
        if item.phase is Phase.UNBUILT or item.component.method in BUILT_WHERE_IT_STANDS:
            return f"{guid} is {item.component.method.value}: it is built where it stands, never carried"
        if item.phase in DYNAMIC_PHASES and not fixed_ok:
            return f"{guid} is placed"
        return None

    def _cannot_carry(
        self, robot: Robot, component: Component, frame: Frame, what: str
    ) -> tuple[str | None, float | None]:
        """:func:`.load_rules.carry_refusal` for ``robot`` where it stands now."""
        return carry_refusal(
            robot.description, robot.robot_id, self._robot_xy(robot), component, frame, what=what
        )

    def _robot_xy(self, robot: Robot) -> tuple[float, float]:
        (x, y, _), _ = robot.frame(self.client_id)
        return x, y

    # --- motion --------------------------------------------------------------------------------------

    def follow(self, robots: dict[str, Robot], now_s: float) -> list[tuple[object, PhysicsReply]]:
        """Move carried and assembling components to where they are at ``now_s``; finished placements."""
        finished: list[tuple[object, PhysicsReply]] = []
        for guid in list(self._moving):
            item = self.items[guid]
            carrier = robots.get(item.carrier or "")
            if item.phase is Phase.CARRIED and item.carrier is not None and item.offset is not None:
                target = compose(robots[item.carrier].frame(self.client_id), item.offset)
                lift = (now_s - item.motion_start_s) / self.config.lift_s if self.config.lift_s > 0 else 1.0
                item.pose = (
                    interpolate(item.motion_from, target, lift) if lift < 1.0 and item.motion_from else target
                )
            elif (
                item.phase is Phase.ASSEMBLING and item.motion_to is not None and item.motion_from is not None
            ):
                duration = item.motion_duration_s
                fraction = (now_s - item.motion_start_s) / duration if duration > 0 else 1.0
                item.pose = interpolate(item.motion_from, item.motion_to, fraction)
                if carrier is not None and carrier.rig is not None and fraction < 1.0:  # up, across, down
                    peak_z = max(item.motion_from[0][2], item.motion_to[0][2]) + LIFT_CLEARANCE_M
                    position = lift_position(item.motion_from[0], item.motion_to[0], fraction, peak_z)
                    item.pose = (position, item.pose[1])
                if fraction >= 1.0:
                    if carrier is not None and carrier.rig is not None:  # the hook where it set it down
                        self._hook_over(carrier, item)
                    self._release(item, carrier, now_s, item.tag)
                    continue
            set_component_pose(self.client_id, item.body, item.pose)
            self.changed.add(guid)
        return finished

    def pose_hooks(self, robots: dict[str, Robot]) -> None:
        """Once per control period: every crane's joints with its hook above its load. The joints are what
        the crane shows (its jib and hook do not collide, :mod:`.crane_rig`), so posing them per physics step
        would cost the same again for nothing (scipy per step made a crane lift 3 ms a period)."""
        for robot_id, guid in self.carrying.items():
            crane = robots.get(robot_id)
            if crane is not None and crane.rig is not None:
                self._hook_over(crane, self.items[guid])

    def _hook_over(self, crane: Robot, item: Item) -> None:
        """A crane's joints with its hook above its load's top (:mod:`.crane`)."""
        assert crane.rig is not None
        bbox = item.component.bbox_local
        top = load_top(bbox.min_m, bbox.max_m, item.pose[0], item.pose[1])
        joints = hook_joints(crane.start_xy_yaw, top, crane.rig.spec, crane.rig.jib_height_m)
        crane.rig.set(self.client_id, joints)

    def _settle(self, item: Item) -> None:
        """Clear of its former carrier: it collides with it again."""
        item.separating_from = None
        self._separating.discard(item.component.guid)
        watch = self.watch.get(item.component.guid)
        if item.phase in DYNAMIC_PHASES and not (watch is not None and watch.fixed):
            set_filter(self.client_id, item.body.body_id, DYNAMIC_GROUP, ALL_GROUPS)
        else:
            set_filter(self.client_id, item.body.body_id, STATIC_GROUP, STATIC_MASK)

    def _overlaps(self, item: Item, robot: Robot) -> bool:
        low, high = p.getAABB(item.body.body_id, -1, physicsClientId=self.client_id)
        for link in range(-1, p.getNumJoints(robot.body_id, physicsClientId=self.client_id)):
            r_low, r_high = p.getAABB(robot.body_id, link, physicsClientId=self.client_id)
            if all(low[i] < r_high[i] and r_low[i] < high[i] for i in range(3)):
                return True
        return False

    def settle_separated(self) -> None:
        """Once per control period: placed components collide with their former carrier once clear of it."""
        for guid in list(self._separating):
            item = self.items[guid]
            if item.separating_from is None:  # picked up again meanwhile
                self._separating.discard(guid)
            elif not self._overlaps(item, item.separating_from):
                self._settle(item)

    def busy_robots(self) -> set[str]:
        """Robots whose placement is running, its motion or its settling (they hold still and are not
        waited for in lock-step)."""
        busy = {
            robot_id for robot_id, guid in self.carrying.items() if self.items[guid].phase is Phase.ASSEMBLING
        }
        busy.update(w.releaser for w in self.watch.values() if w.tag is not None and w.releaser is not None)
        return busy

    def drop_request(
        self, robot: Robot | None, guid: str, now_s: float, near_xy_m: tuple[float, float] | None = None
    ) -> PhysicsReply:
        """A carrying robot puts ``guid`` down beside it (it cannot deliver it): ``resting`` there, attachable
        again by any robot. A repeated request for a load already put down is answered ok (at least once
        delivery); a component being placed, fixed or carried by another robot is refused, saying why."""
        item = self.items.get(guid)
        refusal = self._check_common(robot, guid, item)
        if refusal is None and item is not None and robot is not None:
            if item.phase is Phase.RESTING and item.dropped_by == robot.robot_id:
                return PhysicsReply(ok=True, sim_time_s=now_s, pose=pose_msg(item.pose))
            if item.phase is Phase.ASSEMBLING:
                refusal = f"{guid} is being placed by {item.carrier}: it cannot be dropped now"
            elif item.carrier != robot.robot_id:
                holder = f"by {item.carrier}" if item.carrier else "by no robot"
                refusal = f"robot {robot.robot_id} does not carry {guid} (carried {holder})"
        if refusal is not None or item is None or robot is None:
            return PhysicsReply(ok=False, reason=refusal or "", sim_time_s=now_s)
        self.drop(robot, now_s, why="put down on request", near_xy_m=near_xy_m)
        return PhysicsReply(ok=True, sim_time_s=now_s, pose=pose_msg(item.pose))

    def drop(
        self,
        robot: Robot,
        now_s: float,
        why: str = "robot lost",
        near_xy_m: tuple[float, float] | None = None,
    ) -> str | None:
        """A robot's load (if carried, not being placed) laid flat on the ground beside it: a lost robot's,
        or one the robot asked to put down (:meth:`drop_request`)."""
        guid = self.carrying.get(robot.robot_id)
        item = self.items.get(guid or "")
        if guid is None or item is None or item.phase is not Phase.CARRIED:
            return None
        item.pose = self._drop_pose(item, robot, near_xy_m)
        item.phase = Phase.RESTING
        item.carrier = None
        item.offset = None
        item.dropped_by = robot.robot_id
        del self.carrying[robot.robot_id]
        self._moving.discard(guid)
        set_component_pose(self.client_id, item.body, item.pose)
        set_filter(self.client_id, item.body.body_id, STATIC_GROUP, STATIC_MASK)
        self.changed.add(guid)
        _log.warning(
            "robot %s (%s): %s dropped at (%.2f, %.2f), t=%.2f s",
            robot.robot_id,
            why,
            guid,
            *item.pose[0][:2],
            now_s,
        )
        return guid

    def _drop_pose(self, item: Item, robot: Robot, near_xy_m: tuple[float, float] | None = None) -> Frame:
        """Beside a ground robot (:func:`.load_rules.drop_beside`); a crane's load straight down."""
        if robot.lifts_by_hook:
            return lowered(item.component, item.pose)
        others = [footprint(o.component, o.pose) for o in self.items.values() if o is not item]
        frame = robot.frame(self.client_id)
        return drop_beside(
            item.component, frame, robot.half_extents_xy_m, others, self.site_bounds, near_xy_m=near_xy_m
        )

    # --- messages ------------------------------------------------------------------------------------

    def pose_message(self, guid: str, now_s: float) -> ComponentPoseMsg:
        item = self.items[guid]
        watch = self.watch.get(guid)
        drift = watch.drift_m if watch is not None else item.drift_m
        return ComponentPoseMsg(
            guid=guid,
            pose=pose_msg(item.pose),
            sim_time_s=now_s,
            attached_to=item.carrier,
            # built in place (poured, laid) is placed without a watch: it stands where it was built
            fixed=item.phase is Phase.JOINED
            or (watch.settled if watch is not None else item.phase is Phase.PLACED),
            joined=item.phase is Phase.JOINED,
            drift_m=drift,
            supports=list(watch.supports if watch is not None else item.supports),
            open_pits=list(watch.open_pits if watch is not None else ()),
            clash_depth_m=dict(watch.clashes if watch is not None else ()),
            bumped_by=watch.bumped_by if watch is not None else None,
            bumped_at_s=watch.bumped_at_s if watch is not None else None,
            connected_to=list(watch.connected_to if watch is not None else item.connected_to),
            set_against=list(watch.set_against if watch is not None else ()),
            set_against_shift_m=watch.set_against_shift_m
            if watch is not None and watch.set_against
            else None,
            connection_kinds={other: kind.value for other, kind in self.supports.kinds.get(guid, {}).items()},
            temporary_supports=self.supports.count(guid),
        )

    def take_changed(self) -> list[str]:
        changed = sorted(self.changed)
        self.changed.clear()
        return changed
