"""Attach, carry, place and drop: what happens to components between the yard and the structure.

Every component is in one of four phases:

* ``resting`` — in its yard slot (or where a robot put it down: a lost robot's load, or a load its robot
  could not deliver and asked to drop): static, attachable by any robot.
* ``carried`` — attached to a robot: kinematic, reset every physics step to ``robot frame ∘ carry offset``
  (lying flat on top of the robot, centred over its base frame, ``carry_clearance_m`` above its highest
  collision shape). It rises there from where it lay over ``lift_s`` sim seconds. It takes the robot's
  collision group bit: the carrier neither collides with it nor sees it in its laser; others do. A tower
  crane's load hangs on its hook instead: lifted ``hook_lift_m`` straight up from where it lay, and it
  stays there until placed; the crane's joints follow it (hook above its top, :mod:`.crane`).
* ``assembling`` — a place request was accepted: the component moves from its pose at the request to the
  requested pose over ``duration_s`` sim seconds (linear position, slerp orientation); the carrier holds
  still. The request's reply is held back until the motion ends.
* ``fixed`` — placed: static exactly at the requested pose. Attach refuses it once its agent has declared it
  constructed (:meth:`Handling.note_constructed`); before that a robot may pick it up again, which is how a
  misplaced component is taken off for its retry. It collides with
  its former carrier again only once their bounding boxes no longer overlap, so a robot standing on a
  target footprint is never thrown off. Static bodies never touch the ground plane or each other, so
  footings placed below ground stay there.

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
from dataclasses import dataclass
from enum import StrEnum

from scipy.spatial.transform import Rotation

from bimbot.shared.footprint import posed_footprint
from bimbot.shared.manifest import Component
from bimbot.shared.messages import ComponentPoseMsg, PhysicsReply, PoseMsg
from bimbot.shared.robot_description import LIFT_CLEARANCE_M
from bimbot.shared.site_plan import Rect

from .client import p
from .crane import hook_joints, lift_position, load_top
from .load_rules import carry_refusal, drop_beside, lowered, lying_corners
from .robots import Robot
from .scene import (
    STATIC_GROUP,
    STATIC_MASK,
    ComponentBody,
    Frame,
    compose,
    footprint,
    interpolate,
    invert,
    set_component_pose,
    set_filter,
)

_log = logging.getLogger(__name__)


class Phase(StrEnum):
    RESTING = "resting"
    CARRIED = "carried"
    ASSEMBLING = "assembling"
    FIXED = "fixed"


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
    motion_to: Frame | None = None  # assembling: the requested pose
    motion_start_s: float = 0.0
    motion_duration_s: float = 0.0
    tag: object = None  # assembling: handed back with the reply
    separating_from: Robot | None = None  # fixed, still overlapping its former carrier
    dropped_by: str | None = None  # resting where this robot put it down (a repeated drop request is ok)


def pose_msg(frame: Frame) -> PoseMsg:
    return PoseMsg(position_m=frame[0], quat_xyzw=frame[1])


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


class Handling:
    """The phases of every component; the simulation calls :meth:`follow` after every physics step."""

    def __init__(
        self,
        client_id: int,
        items: dict[str, Item],
        config: HandlingConfig,
        site_bounds: Rect,
    ) -> None:
        self.client_id = client_id
        self.items = items
        self.config = config
        self.site_bounds = site_bounds
        self.carrying: dict[str, str] = {}  # robot id → GUID (carried or assembling)
        self.changed: set[str] = set()  # GUIDs whose pose changed since the last take_changed()
        self.constructed: set[str] = set()  # declared constructed by their agents: fixed for good
        self._moving: set[str] = set()
        self._separating: set[str] = set()  # fixed, still overlapping their former carrier

    def note_constructed(self, guid: str, constructed: bool) -> None:
        """What a component's agent says of it (from ``components/<key>/state``)."""
        if constructed:
            self.constructed.add(guid)
        else:
            self.constructed.discard(guid)

    def restore(self, guid: str, frame: Frame, *, fixed: bool, carrier: Robot | None) -> None:
        """Put ``guid`` back as a restarted physics found it in its record: carried by ``carrier`` (at once,
        no lift), fixed to the structure, or resting at ``frame``."""
        item = self.items[guid]
        item.pose, item.tag, item.motion_to = frame, None, None
        item.separating_from, item.dropped_by = None, None
        if carrier is not None:
            item.phase, item.carrier = Phase.CARRIED, carrier.robot_id
            item.offset = (
                hanging_offset(carrier, frame, self.client_id)
                if carrier.is_crane
                else carry_offset(item.component, carrier, self.config.carry_clearance_m)
            )
            item.motion_from, item.motion_start_s = frame, -math.inf
            self.carrying[carrier.robot_id] = guid
            self._moving.add(guid)
            set_filter(self.client_id, item.body.body_id, carrier.group, STATIC_MASK ^ carrier.group)
        else:
            item.phase = Phase.FIXED if fixed else Phase.RESTING
            item.carrier, item.offset, item.motion_from = None, None, None
            self._moving.discard(guid)
            set_component_pose(self.client_id, item.body, frame)
            set_filter(self.client_id, item.body.body_id, STATIC_GROUP, STATIC_MASK)
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
        if refusal is None and robot.robot_id in self.carrying:
            refusal = f"robot {robot.robot_id} already carries {self.carrying[robot.robot_id]}"
        beyond: float | None = None
        if refusal is None and item is not None:
            refusal, beyond = self._cannot_carry(robot, item.component, item.pose, guid)
        if refusal is not None or item is None:
            return PhysicsReply(ok=False, reason=refusal or "", sim_time_s=now_s, distance_m=beyond)
        item.phase = Phase.CARRIED
        item.carrier = robot.robot_id
        item.dropped_by = None
        if robot.is_crane:  # on the hook, straight up from where it lay
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

    def place(
        self, robot: Robot, guid: str, target: PoseMsg, *, duration_s: float, now_s: float, tag: object
    ) -> PhysicsReply | None:
        """None when accepted (the reply comes from :meth:`follow` with ``tag``), else the refusal."""
        item = self.items.get(guid)
        refusal = self._check_common(robot, guid, item)
        frame: Frame | None = None
        if refusal is None:
            frame, refusal = _valid_frame(target)
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
        if refusal is None and frame is not None and item is not None:
            # the footprint, not the frame's origin: a Revit element may keep an identity placement with its
            # geometry in world coordinates, so its frame lies at (0, 0) while it stands on the site
            centre = posed_footprint(item.component, frame[0], frame[1]).centre_xy_m
            if not _inside(self.site_bounds, (float(centre[0]), float(centre[1]), 0.0)):
                refusal = f"target ({centre[0]:.2f}, {centre[1]:.2f}) of {guid} is outside the site"
        beyond: float | None = None
        if refusal is None and item is not None and frame is not None:
            refusal, beyond = self._cannot_carry(robot, item.component, frame, f"the target of {guid}")
        if refusal is not None or item is None or frame is None:
            return PhysicsReply(ok=False, reason=refusal or "", sim_time_s=now_s, distance_m=beyond)
        item.phase = Phase.ASSEMBLING
        item.motion_from = item.pose
        item.motion_to = frame
        item.motion_start_s = now_s
        item.motion_duration_s = duration_s
        item.tag = tag
        self._moving.add(guid)
        _log.info("%s: %s places it over %.2f s", guid, robot.robot_id, duration_s)
        return None

    def _check_common(
        self, robot: Robot | None, guid: str, item: Item | None, *, fixed_ok: bool = False
    ) -> str | None:
        if robot is None:
            return "unknown robot"
        if item is None:
            return f"unknown component {guid}"
        if item.phase is Phase.FIXED and not fixed_ok:
            if guid in self.constructed:
                return f"{guid} is constructed (fixed to the structure)"
            return f"{guid} is fixed to the structure"
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
                    finished.append((item.tag, self._fix(item, carrier, now_s)))
                    if carrier is not None and carrier.rig is not None:  # the hook where it set it down
                        self._hook_over(carrier, item)
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

    def _fix(self, item: Item, carrier: Robot | None, now_s: float) -> PhysicsReply:
        item.pose = item.motion_to  # type: ignore[assignment]
        item.phase = Phase.FIXED
        self.carrying.pop(item.carrier or "", None)
        item.carrier = None
        item.tag = None
        self._moving.discard(item.component.guid)
        item.separating_from = carrier
        self._separating.add(item.component.guid)
        if carrier is None or carrier.is_crane or not self._overlaps(item, carrier):  # a hook is no body
            self._settle(item)
        _log.info("%s fixed to the structure at t=%.2f s", item.component.guid, now_s)
        return PhysicsReply(ok=True, sim_time_s=now_s, pose=pose_msg(item.pose))

    def _settle(self, item: Item) -> None:
        item.separating_from = None
        self._separating.discard(item.component.guid)
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
        """Robots whose placement is running (they hold still and are not waited for in lock-step)."""
        return {
            robot_id for robot_id, guid in self.carrying.items() if self.items[guid].phase is Phase.ASSEMBLING
        }

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
        if robot.is_crane:
            return lowered(item.component, item.pose)
        others = [footprint(o.component, o.pose) for o in self.items.values() if o is not item]
        frame = robot.frame(self.client_id)
        return drop_beside(
            item.component, frame, robot.half_extents_xy_m, others, self.site_bounds, near_xy_m=near_xy_m
        )

    # --- messages ------------------------------------------------------------------------------------

    def pose_message(self, guid: str, now_s: float) -> ComponentPoseMsg:
        item = self.items[guid]
        return ComponentPoseMsg(
            guid=guid,
            pose=pose_msg(item.pose),
            sim_time_s=now_s,
            attached_to=item.carrier,
            fixed=item.phase is Phase.FIXED,
        )

    def take_changed(self) -> list[str]:
        changed = sorted(self.changed)
        self.changed.clear()
        return changed


def _valid_frame(pose: PoseMsg) -> tuple[Frame | None, str | None]:
    values = [*pose.position_m, *pose.quat_xyzw]
    if not all(math.isfinite(v) for v in values):
        return None, "invalid pose: not finite"
    norm = math.sqrt(sum(q * q for q in pose.quat_xyzw))
    if not 0.5 < norm < 1.5:
        return None, f"invalid pose: quat_xyzw norm {norm:.3g} is not a rotation"
    quat = tuple(q / norm for q in pose.quat_xyzw)
    return (tuple(pose.position_m), quat), None  # type: ignore[return-value]


def _inside(rect: Rect, position: tuple[float, float, float]) -> bool:
    return rect.min_xy[0] <= position[0] <= rect.max_xy[0] and rect.min_xy[1] <= position[1] <= rect.max_xy[1]
