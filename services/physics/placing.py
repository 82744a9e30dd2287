"""Placing a component: a place request accepted or refused, and the assembly motion to where the robot
really puts it; or a component set down at its BIM pose without a robot (the stability replay).

Why a part of its own: where a placement really goes, not where it was asked to go, is what the components'
agents judge. :meth:`Placing.place` checks the request (the robot carries it, a valid pose within the site, a
duration within bounds), then reach and payload on where the component really goes
(:func:`.placement_error.physical_placement`: the robot's localisation error and its type's precision,
drawn for that component and attempt), and starts the assembly motion (``assembling``, moved by
:mod:`.transport`). The motion ends in the release (:mod:`.releasing`), and the watch (:mod:`.watching`)
answers the request once the component rests. It works on the shared :class:`.handling_state.HandlingState`.

The precision draw of a placement is keyed by the seed, the component and its attempt, not taken from a
stream per robot in the order of its placements: two runs that build in another order, or with another
fleet, draw the same standard errors for the same component (common random numbers, scaled by the precision
of the type that places it). From one robot's stream a scenario study could not tell a fleet's effect from
re-rolled errors: on the Janesville restaurant, robots that slept through their drives were assigned
other tasks, every later draw changed, a mullion's neighbours stood up to 10 mm elsewhere, and it missed
its holes three times.
"""

from __future__ import annotations

import logging
import math
import zlib

import numpy as np

from bimbot.shared.footprint import posed_footprint
from bimbot.shared.manifest import Component
from bimbot.shared.messages import PhysicsReply, PoseMsg
from bimbot.shared.site_plan import Rect

from .handling_state import HandlingState, Phase, handling_refusal, target_frame
from .placement_error import guided_yaw_std_rad, physical_placement
from .releasing import Releasing
from .robots import Robot
from .scene import IDENTITY, Frame, compose

_log = logging.getLogger(__name__)


class Placing:
    """Accepts place requests and sets components down without a robot (see the module doc)."""

    def __init__(self, state: HandlingState, releasing: Releasing, seed: int) -> None:
        self._state = state
        self._releasing = releasing
        self._seed = seed
        self._attempts: dict[str, int] = {}  # component → placements drawn for it so far

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
        """None when accepted (the reply comes from :meth:`.watching.Watching.watch_placed` with ``tag``
        once the component came to rest), else the refusal. ``target`` is where the robot means to put it,
        in the world as it believes it stands at ``believed_xy_yaw`` (None: it knows its pose)."""
        state = self._state
        item = state.items.get(guid)
        refusal = handling_refusal(robot, guid, item)
        commanded: Frame | None = None
        if refusal is None:
            commanded, refusal = valid_frame(target)
        if refusal is None and not (
            math.isfinite(duration_s) and 0.0 <= duration_s <= state.config.max_place_duration_s
        ):
            refusal = (
                f"duration_s must be within 0..{state.config.max_place_duration_s:g} s, got {duration_s}"
            )
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
            if not inside(state.site_bounds, (float(centre[0]), float(centre[1]))):
                refusal = f"target ({centre[0]:.2f}, {centre[1]:.2f}) of {guid} is outside the site"
        beyond: float | None = None
        if refusal is None and item is not None and frame is not None:
            refusal, beyond = state.cannot_carry(robot, item.component, frame, f"the target of {guid}")
        if refusal is not None or item is None or frame is None or commanded is None:
            return PhysicsReply(ok=False, reason=refusal or "", sim_time_s=now_s, distance_m=beyond)
        item.phase = Phase.ASSEMBLING
        item.motion_from = item.pose
        item.motion_to = frame
        item.meant_quat_xyzw = commanded[1]
        item.motion_start_s = now_s
        item.motion_duration_s = duration_s
        item.tag = tag
        state.moving.add(guid)
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
        attempt = self._attempts[component.guid] = self._attempts.get(component.guid, 0) + 1
        rng = np.random.default_rng([self._seed, 7, zlib.crc32(component.guid.encode()), attempt])
        description = robot.description
        yaw_std_rad = math.radians(description.placement_precision_yaw_deg)
        if description.placement_guided_ends:
            low, high = component.bbox_world.min_m, component.bbox_world.max_m
            half_span_m = 0.5 * math.hypot(high[0] - low[0], high[1] - low[1])
            yaw_std_rad = guided_yaw_std_rad(yaw_std_rad, description.placement_precision_m, half_span_m)
        return physical_placement(
            commanded,
            believed_xy_yaw if robot.drives else None,
            robot.pose_xy_yaw(self._state.client_id),
            precision_m=description.placement_precision_m,
            precision_yaw_rad=yaw_std_rad,
            rng=rng,
            centre_local_m=component.com_local_m,
        )

    def set_down(self, guid: str, now_s: float, tag: object = None) -> None:
        """Put ``guid`` at its BIM pose and release it there, without a robot (the stability replay,
        :mod:`.stability`); ``tag`` comes back with the reply once it rests."""
        item = self._state.items[guid]
        item.motion_to = target_frame(item.component)
        item.meant_quat_xyzw = item.motion_to[1]
        self._releasing.release(item, None, now_s, tag)


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
