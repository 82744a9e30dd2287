"""Where ground robots stage loads for a crane (pure, part of the site plan).

Why: a crane never travels (where it stands: :mod:`.site_machines`), so a component whose yard slot its
hook cannot reach is brought to it. Beside each machine that lifts by hook, on its side away from the
building, lies its **staging area**: where a ground robot puts such a component down (a hand-off), well
inside the crane's reach. :func:`staging_spots` lists the spots a planner hands out, nearest the centre
first. Only hook-lifting machines have one: a pump or a block layer works where it stands.
"""

from __future__ import annotations

import math

from .robot_description import RobotDescription
from .site_plan import Rect

STAGING_SIDE_M = 8.0  # a staging area is this square, beside its crane
STAGING_GAP_M = 1.5  # between the crane's base and its staging area
STAGING_SPACING_M = 3.0  # between staging spots


def staging_area(crane_xy_yaw: tuple[float, float, float], crane: RobotDescription) -> Rect:
    """The square beside the crane, on the side away from the building (opposite its heading)."""
    x, y, yaw = crane_xy_yaw
    distance = crane.radius_m + STAGING_GAP_M + STAGING_SIDE_M / 2.0
    cx, cy = x - distance * math.cos(yaw), y - distance * math.sin(yaw)
    half = STAGING_SIDE_M / 2.0
    return Rect((cx - half, cy - half), (cx + half, cy + half))


def staging_spots(area: Rect) -> list[tuple[float, float]]:
    """Put-down spots in ``area`` on a grid ``STAGING_SPACING_M`` apart (the centre first, then outwards)."""
    (x0, y0), (x1, y1) = area.min_xy, area.max_xy
    count_x = max(1, int((x1 - x0) // STAGING_SPACING_M))
    count_y = max(1, int((y1 - y0) // STAGING_SPACING_M))
    step_x, step_y = (x1 - x0) / count_x, (y1 - y0) / count_y
    spots = [
        (x0 + (i + 0.5) * step_x, y0 + (j + 0.5) * step_y) for i in range(count_x) for j in range(count_y)
    ]
    centre = ((x0 + x1) / 2.0, (y0 + y1) / 2.0)
    return sorted(spots, key=lambda spot: (math.hypot(spot[0] - centre[0], spot[1] - centre[1]), spot))
