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

The handling is built of parts that share one :class:`.handling_state.HandlingState` (the items and the
site's records), each receiving it when it is built: :mod:`.transport` (attach, carry, drop),
:mod:`.placing` (place requests), :mod:`.releasing` (the release into dynamics, connections, supports) and
:mod:`.watching` (settling, placed, joined). :class:`Handling` builds them and is what the simulation calls.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping

from bimbot.shared.messages import ComponentPoseMsg
from bimbot.shared.site_plan import Rect

from .connections import ConnectionConfig
from .handling_state import HandlingConfig, HandlingState, Item, Phase, pose_msg
from .pits import Pits
from .placing import Placing
from .release import SettleConfig, Watch
from .releasing import Releasing
from .robots import Robot
from .scene import STATIC_MASK, Frame, make_static, set_component_pose, set_filter
from .temporary_supports import SupportRecord
from .transport import Transport, carry_offset, hanging_offset
from .watching import Watching

_log = logging.getLogger(__name__)


class Handling:
    """The phases of every component: the simulation's requests go to the part that answers them; it calls
    :meth:`follow` after every physics step and :meth:`watch_placed` once per control period."""

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
        framed: Mapping[str, dict[str, float]] | None = None,
        seed: int = 0,
    ) -> None:
        self.state = HandlingState(
            client_id=client_id,
            items=items,
            config=config,
            site_bounds=site_bounds,
            ground_id=ground_id,
            pits=pits,
            settle=settle or SettleConfig(),
            connections=connections or ConnectionConfig(),
            in_place=dict(in_place or {}),
            joints=dict(joints or {}),
            framed=dict(framed or {}),
            guid_of={item.body.body_id: guid for guid, item in items.items()},
        )
        self.releasing = Releasing(self.state)
        self.watching = Watching(self.state, self.releasing)
        self.placing = Placing(self.state, self.releasing, seed)
        self.transport = Transport(self.state, self.releasing)
        # requests and steps, answered by the parts' own methods (one signature each)
        self.attach, self.drop_request, self.drop = (
            self.transport.attach,
            self.transport.drop_request,
            self.transport.drop,
        )
        self.follow, self.pose_hooks = self.transport.follow, self.transport.pose_hooks
        self.settle_separated = self.transport.settle_separated
        self.place, self.set_down = self.placing.place, self.placing.set_down
        self.watch_placed = self.watching.watch_placed

    # --- the shared records, for the simulation and its adapters -----------------------------------

    @property
    def items(self) -> dict[str, Item]:
        return self.state.items

    @property
    def carrying(self) -> dict[str, str]:
        return self.state.carrying

    @property
    def watch(self) -> dict[str, Watch]:
        return self.state.watch

    @property
    def changed(self) -> set[str]:
        return self.state.changed

    @property
    def constructed(self) -> set[str]:
        return self.state.constructed

    @property
    def supports(self) -> SupportRecord:
        return self.state.supports

    @property
    def connections(self) -> ConnectionConfig:
        return self.state.connections

    @property
    def joints(self) -> dict[str, frozenset[str]]:
        return self.state.joints

    @property
    def settle(self) -> SettleConfig:
        return self.state.settle

    # --- what the agents say, a restart, messages ----------------------------------------------------

    def note_constructed(self, guid: str, constructed: bool) -> None:
        """What a component's agent says of it (from ``components/<key>/state``): constructed joins it to
        the structure where it rests, once its placement was answered (no agent can have verified a
        placement still settling: such a claim joins nothing). Anything else said of a joined component
        means it was joined on a claim its agent did not make (a forged message on an open bus; the agents'
        constructed is final): it is released again where it lies, so the robots can take it up again."""
        state = self.state
        item = state.items.get(guid)
        if constructed:
            state.constructed.add(guid)
            if item is not None and item.phase is Phase.PLACED:
                self.watching.join(guid)
            return
        state.constructed.discard(guid)
        if item is not None and item.phase is Phase.JOINED:
            _log.warning("%s: its agent does not say constructed: released again where it lies", guid)
            item.motion_to, item.separating_from = None, None
            self.releasing.release(item, None, now_s=-math.inf, tag=None)
            state.watch[guid].settled = True
            item.phase = Phase.PLACED

    def restore(
        self,
        guid: str,
        frame: Frame,
        *,
        fixed: bool,
        carrier: Robot | None,
        fitted_target: Frame | None = None,
    ) -> None:
        """Put ``guid`` back as a restarted physics found it in its record: carried by ``carrier`` (at once,
        no lift), placed (released again where it lay, watched as settled; joined once its twin says
        constructed, :meth:`note_constructed`), or resting at ``frame``; ``fitted_target``: its recorded
        target fitted to the structure (:mod:`.support_fit`)."""
        state = self.state
        item = state.items[guid]
        item.pose, item.tag, item.motion_to = frame, None, None
        item.fitted_target = fitted_target if carrier is None else None
        item.separating_from, item.dropped_by = None, None
        state.watch.pop(guid, None)
        if carrier is not None:
            item.phase, item.carrier = Phase.CARRIED, carrier.robot_id
            item.offset = (
                hanging_offset(carrier, frame, state.client_id)
                if carrier.lifts_by_hook
                else carry_offset(item.component, carrier, state.config.carry_clearance_m)
            )
            item.motion_from, item.motion_start_s = frame, -math.inf
            state.carrying[carrier.robot_id] = guid
            state.moving.add(guid)
            make_static(state.client_id, item.body)
            set_filter(state.client_id, item.body.body_id, carrier.group, STATIC_MASK ^ carrier.group)
        elif fixed:
            item.carrier, item.offset, item.motion_from = None, None, None
            state.moving.discard(guid)
            set_component_pose(state.client_id, item.body, frame)
            self.releasing.release(item, None, now_s=-math.inf, tag=None)
            state.watch[guid].settled = True
            item.phase = Phase.PLACED
            if guid in state.constructed:
                self.watching.join(guid)
        else:
            item.phase = Phase.RESTING
            item.carrier, item.offset, item.motion_from = None, None, None
            state.moving.discard(guid)
            make_static(state.client_id, item.body)
            set_component_pose(state.client_id, item.body, frame)
        state.changed.add(guid)

    def busy_robots(self) -> set[str]:
        """Robots whose placement is running, its motion or its settling (they hold still and are not
        waited for in lock-step)."""
        state = self.state
        busy = {
            robot_id
            for robot_id, guid in state.carrying.items()
            if state.items[guid].phase is Phase.ASSEMBLING
        }
        busy.update(w.releaser for w in state.watch.values() if w.tag is not None and w.releaser is not None)
        return busy

    def pose_message(self, guid: str, now_s: float) -> ComponentPoseMsg:
        state = self.state
        item = state.items[guid]
        watch = state.watch.get(guid)
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
            connection_kinds={
                other: kind.value for other, kind in state.supports.kinds.get(guid, {}).items()
            },
            temporary_supports=state.supports.count(guid),
            fitted_target=pose_msg(item.fitted_target)
            if item.fitted_target is not None and item.carrier is None
            else None,
        )

    def take_changed(self) -> list[str]:
        changed = sorted(self.state.changed)
        self.state.changed.clear()
        return changed
