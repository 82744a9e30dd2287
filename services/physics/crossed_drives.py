"""Which sleeping drivers a part that came to rest stands in the way of (plan fidelity; pure bookkeeping).

Why: a kinematic robot sleeps through its drive (:mod:`.sleepers`): it hears the site again only at its
drive's end or at the next task message. A part set down across its way meanwhile was driven through, and
noticed, if at all, only ahead of where the robot woke. On a site the driver sees the part come to rest
(its laser, its map) and goes round it; in the physics fidelity it does so too. Physics knows both the
drive (the timed path it moves the robot along) and where each part came to rest, so it wakes that one
driver, and no other, as soon as the driver can know of the part: its robot then finds its path covered
and plans again (``plan_executor.watch``).

Reckoned by step numbers only, so the same seed gives the same wakes:

* a part came to rest at step ``r`` (its fixed pose went out with clock ``r``); a robot takes it at step
  ``r + DELAY_STEPS`` (what is stamped up to clock ``k − DELAY_STEPS`` is taken at ``k``);
* a robot said at step ``j`` that it sleeps through its drive; physics knows that for certain when it
  publishes step ``j + DELAY_STEPS`` (it has heard every answer to that step by then);
* the robot wakes at the first step ``k ≥ j + DELAY_STEPS`` at which a part that came to rest at a step
  ``r`` with ``j − DELAY_STEPS < r ≤ k − DELAY_STEPS`` covers what is left of its way at ``k`` (parts that
  came to rest by ``j − DELAY_STEPS`` it had taken before it slept, and planned round).

"Covers" is the robots' own test, loosely: a point of the rest of the path within the robot's radius, the
margin its map inflates by and one cell of an outline of the part in the robots' height band. A wake too
many costs a period or two (the robot finds its path free and sleeps on); a wake too few is a robot that
drives through a part.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from bimbot.shared.footprint import footprint_distance_m
from bimbot.shared.plan_motion import Trajectory
from bimbot.shared.step_gate import DELAY_STEPS

INFLATION_MARGIN_M = 0.15  # as the robots' site map inflates beyond a robot's radius
CELL_M = 0.1  # the robots' map resolution: a point within a cell of the inflation is covered there
SAMPLE_M = 0.1  # the rest of a path is tested at points this far apart


@dataclass(frozen=True)
class Rest:
    """A part that came to rest at clock ``step``: its outlines in the robots' height band (xy, m)."""

    step: int
    guid: str
    outlines: tuple[NDArray[np.float64], ...]


@dataclass
class CrossedDrives:
    """The rests still to be tested against the sleeping drivers, and how far each sleep was tested."""

    rests: list[Rest] = field(default_factory=list)
    # robot → (the step it fell asleep after, the last rest step its drive was tested against)
    _tested: dict[str, tuple[int, int]] = field(default_factory=dict)

    def came_to_rest(self, step: int, guid: str, outlines: Sequence[NDArray[np.float64]]) -> None:
        """A part came to rest at ``step``; ``outlines``: what of it meets the robots' height band."""
        if outlines:
            self.rests.append(Rest(step, guid, tuple(np.asarray(o, float) for o in outlines)))

    def to_wake(
        self,
        step: int,
        now_s: float,
        asleep_driving: Mapping[str, int],
        motions: Mapping[str, Trajectory],
        radius_m: Mapping[str, float],
    ) -> list[str]:
        """The drivers asleep (robot → the step it fell asleep after) to wake at clock ``step`` (at
        ``now_s``): a part they have not taken covers the rest of their way (see the module doc)."""
        woken: list[str] = []
        visible_to = step - DELAY_STEPS
        for robot_id, since in sorted(asleep_driving.items()):
            if since > visible_to or robot_id not in motions:
                continue  # not known for certain yet: tested from step since + DELAY_STEPS
            tested_since, tested_to = self._tested.get(robot_id, (since, since - DELAY_STEPS))
            if tested_since != since:
                tested_to = since - DELAY_STEPS
            fresh = [rest for rest in self.rests if tested_to < rest.step <= visible_to]
            self._tested[robot_id] = (since, visible_to)
            if fresh and _covers(fresh, motions[robot_id], now_s, radius_m[robot_id]):
                woken.append(robot_id)
                del self._tested[robot_id]
        for robot_id in [r for r in self._tested if r not in asleep_driving]:
            del self._tested[robot_id]
        # a sleep said from now on (at a step ≥ step - DELAY_STEPS + 1) tests rests after its own step -
        # DELAY_STEPS: older ones are needed only by sleeps tested already
        oldest = min([step + 1 - 2 * DELAY_STEPS, *(to for _, to in self._tested.values())])
        self.rests = [rest for rest in self.rests if rest.step > oldest]
        return woken


def _covers(rests: Sequence[Rest], motion: Trajectory, now_s: float, radius_m: float) -> bool:
    points = remaining_points_xy(motion, now_s)
    if not len(points):
        return False
    within = radius_m + INFLATION_MARGIN_M + CELL_M
    return any(
        bool((footprint_distance_m(outline, points) <= within).any())
        for rest in rests
        for outline in rest.outlines
        if len(outline) >= 3
    )


def remaining_points_xy(motion: Trajectory, now_s: float) -> NDArray[np.float64]:
    """Points ``(n, 2)`` along what is left of ``motion`` after ``now_s``, at most ``SAMPLE_M`` apart (empty
    once it has ended)."""
    if now_s >= motion.end_s:
        return np.empty((0, 2))
    here = motion.pose_at(now_s)
    corners = [(here[0], here[1])]
    ahead = zip(motion.times_s, motion.poses, strict=True)
    corners += [(pose[0], pose[1]) for at_s, pose in ahead if at_s > now_s]
    points = [np.asarray(corners[0], float)[None, :]]
    for (x0, y0), (x1, y1) in itertools.pairwise(corners):
        count = max(1, math.ceil(math.hypot(x1 - x0, y1 - y0) / SAMPLE_M))
        share = np.arange(1, count + 1, dtype=float)[:, None] / count
        points.append(np.array([x0, y0]) + share * np.array([x1 - x0, y1 - y0]))
    return np.concatenate(points)
