"""The landing zone: a component is not set down where another robot stands.

Why: a carrier at its stand-point beside a curtain wall's sill stood where a 589 kg proxy was to go; a
second carrier set the proxy there (in the plan fidelity robots are kinematic: nothing pushed either away),
and the first was held where it stood, its body inside the new part's outline, to the end of the run: three
mullions failed ``robot_trapped`` and four more were blocked by them (the Janesville restaurant with three
carriers). A site keeps a load's landing zone clear: a load is not lowered onto or beside a machine, the
crew waits until the machine has moved off. So a place request whose component, at the pose asked for,
would cover another driving robot's body (its outline within the robot's circumscribed radius, at the
heights the robot's body takes up) is refused *for now*: the reply says how long to wait before asking
again, and the wait is no failed try.

Bounds: the robot in the way is at work or passing and moves on; one that does not (parked, walled in, two
robots each standing where the other's load goes) must not stop the build, so a component waits at most
``WAIT_MAX_S`` of sim time from its first refusal and is then placed anyway, logged.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np

from bimbot.shared.footprint import Footprint, footprint_distance_m

_log = logging.getLogger(__name__)

WAIT_MAX_S = 900.0  # sim s a component waits at most for a robot to leave where it goes
ASK_AGAIN_S = 5.0  # sim s between asks while it waits


@dataclass(frozen=True)
class Bystander:
    """A driving robot that is not the one placing: where its body stands (world, m)."""

    robot_id: str
    xy_m: tuple[float, float]
    radius_m: float  # circumscribed radius of its body
    z_low_m: float
    z_high_m: float


def in_the_way(footprint: Footprint, bystanders: Iterable[Bystander]) -> tuple[Bystander, float] | None:
    """The first bystander (by id) whose body the component's outline covers, and how far the outline
    reaches into its radius (m); None when the landing zone is clear. A part above a robot's body (a beam
    over a carrier) does not count: only the outlines at the heights its body takes up."""
    for robot in sorted(bystanders, key=lambda r: r.robot_id):
        outlines = footprint.outlines_meeting(robot.z_low_m, robot.z_high_m)
        if not outlines:
            continue
        point = np.asarray([robot.xy_m], float)
        distance_m = min(float(footprint_distance_m(outline, point)[0]) for outline in outlines)
        if distance_m < robot.radius_m:
            return robot, robot.radius_m - distance_m
    return None


@dataclass
class LandingWaits:
    """When each component's wait for a clear landing zone began (sim s), and the bound on it."""

    wait_max_s: float = WAIT_MAX_S
    since_s: dict[str, float] = field(default_factory=dict)

    def refusal(
        self, guid: str, name: str, found: tuple[Bystander, float] | None, now_s: float
    ) -> str | None:
        """Why ``guid`` may not be set down now (``found``: :func:`in_the_way`), or None: the zone is clear,
        or it has waited ``wait_max_s`` and goes anyway."""
        if found is None:
            self.since_s.pop(guid, None)
            return None
        robot, depth_m = found
        since_s = self.since_s.setdefault(guid, now_s)
        waited_s = now_s - since_s
        if waited_s >= self.wait_max_s:
            self.since_s.pop(guid, None)
            _log.warning(
                "%s is set down though %s stands %.2f m inside where it goes: waited %.0f s of sim time",
                name,
                robot.robot_id,
                depth_m,
                waited_s,
            )
            return None
        if waited_s == 0.0:
            _log.info(
                "%s waits: %s stands where it goes (%.2f m inside its outline); it goes once %s "
                "moved off, or after %.0f s of sim time",
                name,
                robot.robot_id,
                depth_m,
                robot.robot_id,
                self.wait_max_s,
            )
        return (
            f"{robot.robot_id} at ({robot.xy_m[0]:.2f}, {robot.xy_m[1]:.2f}) stands where {name} goes "
            f"({depth_m:.2f} m inside its outline): waiting {waited_s:.0f} of at most "
            f"{self.wait_max_s:.0f} s for it to move off"
        )
