"""The watch over what was released: once per control period every settling or placed component's pose,
drift and rest, what it rests on and which robot touched it (:mod:`.release`); a placement that came to
rest is answered with the pose it came to rest at. And the end of the watch: joined to the structure once
its agent verified it.

Why a part of its own: the simulation calls it once per control period, not per physics step, and what it
answers is what the components' agents judge a placement by. It works on the shared
:class:`.handling_state.HandlingState`; supports that are no longer needed are taken away through
:class:`.releasing.Releasing`, which also fixes a joined component where it rests.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping

import numpy as np

from bimbot.shared.messages import PhysicsReply

from .client import p
from .handling_state import HandlingState, Item, Phase, pose_msg
from .release import box_corners, observe, supports_of, touching_robot
from .releasing import Releasing
from .robots import Robot
from .scene import component_pose, make_static

_log = logging.getLogger(__name__)

FELL_OFF_M = 5.0  # below the ground or beyond the fence by this much, a released component has fallen off


class Watching:
    """Watches released components and joins verified ones (see the module doc)."""

    def __init__(self, state: HandlingState, releasing: Releasing) -> None:
        self._state = state
        self._releasing = releasing
        self._corners: dict[str, np.ndarray] = {}  # GUID → its bounding box's corners (component frame)

    def watch_placed(self, now_s: float, robots: Mapping[str, Robot]) -> list[tuple[object, PhysicsReply]]:
        """Once per control period: every released component's pose, drift and rest, and the first of
        ``robots`` to touch it; the placements that came to rest are answered (``(tag, reply)``)."""
        state = self._state
        answered: list[tuple[object, PhysicsReply]] = []
        config = state.settle
        robot_of = {robot.body_id: robot_id for robot_id, robot in robots.items()} if state.watch else {}
        for guid, watch in state.watch.items():
            item = state.items[guid]
            corners = self._corners.get(guid)
            if corners is None:
                corners = self._corners[guid] = box_corners(item.component)
            was_settled, drift_before_m = watch.settled, watch.drift_m
            item.pose = observe(state.client_id, item.body, corners, watch, now_s=now_s, config=config)
            if not watch.stopped and self.fell_off(item):  # settled or not: it may still tip off later
                watch.settled = watch.stopped = True
            if watch.placed_on is None:  # what it was set down on, before it could slide or tip away
                watch.placed_on = supports_of(state.client_id, item.body.body_id, state.guid_of)
            # a robot that touches it where it lay at the start of this period pushed it; one it fell onto
            # (a beam tipping off its column onto the carrier beside it) did not
            if watch.bumped_by is None and robot_of and drift_before_m <= config.report_drift_m:
                bumper = touching_robot(state.client_id, item.body.body_id, robot_of)
                if bumper is not None:
                    watch.bumped_by, watch.bumped_at_s = bumper, now_s
                    state.changed.add(guid)
                    _log.info(
                        "%s touched by robot %s at t=%.2f s, %.1f mm from where it was released",
                        guid,
                        bumper,
                        now_s,
                        1000.0 * watch.drift_m,
                    )
            if not watch.settled or abs(watch.drift_m - watch.published_drift_m) >= config.publish_drift_m:
                watch.published_drift_m = watch.drift_m
                state.changed.add(guid)
            if watch.settled and not was_settled:
                item.phase = Phase.PLACED
                # a connected component is static: Bullet makes no contacts between static bodies
                rests_on = supports_of(state.client_id, item.body.body_id, state.guid_of)
                watch.supports = tuple(dict.fromkeys(rests_on + watch.connected_to))
                state.changed.add(guid)
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
        self._releasing.remove_supports(now_s)
        return answered

    def fell_off(self, item: Item) -> bool:
        """A released component far below the ground or off the site (it slid off a pit's floor, or was
        thrown) would fall for ever: it is stopped where it is, static, and reported as it is (its drift says
        it did not hold). Poses on the bus stay bounded. Judged by its centre of mass, not its frame's origin:
        an element placed by an identity placement (common in Revit exports) has its origin at the model's
        origin, far from its geometry and possibly off the site."""
        state = self._state
        (x, y, z), _ = p.getBasePositionAndOrientation(item.body.body_id, physicsClientId=state.client_id)
        (x0, y0), (x1, y1) = state.site_bounds.min_xy, state.site_bounds.max_xy
        margin = FELL_OFF_M
        if z > -margin and x0 - margin < x < x1 + margin and y0 - margin < y < y1 + margin:
            return False
        make_static(state.client_id, item.body)
        _log.warning(
            "%s fell off the site at (%.1f, %.1f, %.1f): stopped there, static", item.component.guid, x, y, z
        )
        return True

    def join(self, guid: str) -> None:
        """Its agent verified it: static where it rests, joined to the structure for good."""
        state = self._state
        item = state.items[guid]
        watch = state.watch.pop(guid, None)
        cid = state.client_id
        item.pose = component_pose(cid, item.body)
        if watch is not None:
            item.drift_m = watch.drift_m
            item.supports = watch.supports or supports_of(cid, item.body.body_id, state.guid_of)
            item.connected_to = watch.connected_to
        self._releasing.fix(item)
        item.phase = Phase.JOINED
        state.changed.add(guid)
        _log.info(
            "%s joined to the structure (%s), %.1f mm from where it was released",
            guid,
            ", ".join(item.supports) or "on the ground",
            1000.0 * (item.drift_m or 0.0),
        )
