"""Carrying components: attached to a robot, moved with it after every physics step, put down beside it.

Why a part of its own: it is the handling's per-step work (:meth:`Transport.follow` runs after every
physics step while anything is carried): a carried load rises from where it lay onto its robot (a crane's
hangs on its hook) and follows it; an assembling one moves to where its placement really goes (a crane's
up, across and down) and is released (:mod:`.releasing`) when the motion ends. Per control period the
cranes' joints follow their loads, and placed components collide with their former carrier again once
clear of it. A load a robot cannot deliver, or a lost robot's, is put down beside it (:mod:`.load_rules`).
It works on the shared :class:`.handling_state.HandlingState`.
"""

from __future__ import annotations

import logging

from scipy.spatial.transform import Rotation

from bimbot.shared.manifest import Component
from bimbot.shared.messages import PhysicsReply
from bimbot.shared.robot_description import LIFT_CLEARANCE_M

from .crane import hook_joints, lift_position, load_top
from .handling_state import DYNAMIC_PHASES, HandlingState, Item, Phase, handling_refusal, pose_msg
from .load_rules import drop_beside, lowered, lying_corners
from .releasing import Releasing
from .robots import Robot
from .scene import (
    ALL_GROUPS,
    DYNAMIC_GROUP,
    STATIC_GROUP,
    STATIC_MASK,
    Frame,
    component_pose,
    compose,
    footprint,
    interpolate,
    invert,
    make_static,
    set_component_pose,
    set_filter,
)

_log = logging.getLogger(__name__)


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


class Transport:
    """Attach, follow, hooks, separation and drop (see the module doc)."""

    def __init__(self, state: HandlingState, releasing: Releasing) -> None:
        self._state = state
        self._releasing = releasing

    def attach(self, robot: Robot, guid: str, now_s: float) -> PhysicsReply:
        state = self._state
        item = state.items.get(guid)
        refusal = handling_refusal(robot, guid, item, fixed_ok=guid not in state.constructed)
        if refusal is None and item is not None and item.phase in (Phase.CARRIED, Phase.ASSEMBLING):
            holder = item.carrier
            refusal = (
                f"{guid} is already carried by {holder}"
                if item.phase is Phase.CARRIED
                else f"{guid} is being placed by {holder}"
            )
        if refusal is None and item is not None and item.phase is Phase.SETTLING:
            refusal = f"{guid} was just placed and is settling"
        if refusal is None and robot.robot_id in state.carrying:
            refusal = f"robot {robot.robot_id} already carries {state.carrying[robot.robot_id]}"
        beyond: float | None = None
        if refusal is None and item is not None:
            refusal, beyond = state.cannot_carry(robot, item.component, item.pose, guid)
        if refusal is not None or item is None:
            return PhysicsReply(ok=False, reason=refusal or "", sim_time_s=now_s, distance_m=beyond)
        if item.phase is Phase.PLACED:  # taken off again for its retry: no longer watched, kinematic
            state.watch.pop(guid, None)
            item.pose = component_pose(state.client_id, item.body)
            make_static(state.client_id, item.body)
            support = state.supports.take_up(guid, now_s)  # unbolted, and its props or braces taken away
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
        item.dropped_by, item.fitted_target = None, None
        if robot.lifts_by_hook:  # on the hook, straight up from where it lay
            (x, y, z), quat = item.pose
            item.offset = hanging_offset(robot, ((x, y, z + state.config.hook_lift_m), quat), state.client_id)
        else:
            item.offset = carry_offset(item.component, robot, state.config.carry_clearance_m)
        item.motion_from = item.pose
        item.motion_start_s = now_s
        item.separating_from = None
        state.carrying[robot.robot_id] = guid
        state.moving.add(guid)
        state.changed.add(guid)
        set_filter(state.client_id, item.body.body_id, robot.group, STATIC_MASK ^ robot.group)
        _log.info("%s attached to %s at t=%.2f s", guid, robot.robot_id, now_s)
        return PhysicsReply(ok=True, sim_time_s=now_s, pose=pose_msg(item.pose))

    def follow(self, robots: dict[str, Robot], now_s: float) -> list[tuple[object, PhysicsReply]]:
        """Move carried and assembling components to where they are at ``now_s``; finished placements."""
        state = self._state
        finished: list[tuple[object, PhysicsReply]] = []
        for guid in list(state.moving):
            item = state.items[guid]
            carrier = robots.get(item.carrier or "")
            if item.phase is Phase.CARRIED and item.carrier is not None and item.offset is not None:
                target = compose(robots[item.carrier].frame(state.client_id), item.offset)
                lift = (now_s - item.motion_start_s) / state.config.lift_s if state.config.lift_s > 0 else 1.0
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
                    self._releasing.release(item, carrier, now_s, item.tag)
                    continue
            set_component_pose(state.client_id, item.body, item.pose)
            state.changed.add(guid)
        return finished

    def pose_hooks(self, robots: dict[str, Robot]) -> None:
        """Once per control period: every crane's joints with its hook above its load. The joints are what
        the crane shows (its jib and hook do not collide, :mod:`.crane_rig`), so posing them per physics step
        would cost the same again for nothing (scipy per step made a crane lift 3 ms a period)."""
        for robot_id, guid in self._state.carrying.items():
            crane = robots.get(robot_id)
            if crane is not None and crane.rig is not None:
                self._hook_over(crane, self._state.items[guid])

    def _hook_over(self, crane: Robot, item: Item) -> None:
        """A crane's joints with its hook above its load's top (:mod:`.crane`)."""
        assert crane.rig is not None
        bbox = item.component.bbox_local
        top = load_top(bbox.min_m, bbox.max_m, item.pose[0], item.pose[1])
        joints = hook_joints(crane.start_xy_yaw, top, crane.rig.spec, crane.rig.jib_height_m)
        crane.rig.set(self._state.client_id, joints)

    def _settle(self, item: Item) -> None:
        """Clear of its former carrier: it collides with it again."""
        state = self._state
        item.separating_from = None
        state.separating.discard(item.component.guid)
        watch = state.watch.get(item.component.guid)
        if item.phase in DYNAMIC_PHASES and not (watch is not None and watch.fixed):
            set_filter(state.client_id, item.body.body_id, DYNAMIC_GROUP, ALL_GROUPS)
        else:
            set_filter(state.client_id, item.body.body_id, STATIC_GROUP, STATIC_MASK)

    def settle_separated(self) -> None:
        """Once per control period: placed components collide with their former carrier once clear of it."""
        state = self._state
        for guid in list(state.separating):
            item = state.items[guid]
            if item.separating_from is None:  # picked up again meanwhile
                state.separating.discard(guid)
            elif not state.overlaps(item, item.separating_from):
                self._settle(item)

    def drop_request(
        self, robot: Robot | None, guid: str, now_s: float, near_xy_m: tuple[float, float] | None = None
    ) -> PhysicsReply:
        """A carrying robot puts ``guid`` down beside it (it cannot deliver it): ``resting`` there, attachable
        again by any robot. A repeated request for a load already put down is answered ok (at least once
        delivery); a component being placed, fixed or carried by another robot is refused, saying why."""
        item = self._state.items.get(guid)
        refusal = handling_refusal(robot, guid, item)
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
        state = self._state
        guid = state.carrying.get(robot.robot_id)
        item = state.items.get(guid or "")
        if guid is None or item is None or item.phase is not Phase.CARRIED:
            return None
        item.pose = self._drop_pose(item, robot, near_xy_m)
        item.phase = Phase.RESTING
        item.carrier = None
        item.offset = None
        item.dropped_by = robot.robot_id
        del state.carrying[robot.robot_id]
        state.moving.discard(guid)
        set_component_pose(state.client_id, item.body, item.pose)
        set_filter(state.client_id, item.body.body_id, STATIC_GROUP, STATIC_MASK)
        state.changed.add(guid)
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
        state = self._state
        if robot.lifts_by_hook:
            return lowered(item.component, item.pose)
        others = [footprint(o.component, o.pose) for o in state.items.values() if o is not item]
        frame = robot.frame(state.client_id)
        return drop_beside(
            item.component, frame, robot.half_extents_xy_m, others, state.site_bounds, near_xy_m=near_xy_m
        )
