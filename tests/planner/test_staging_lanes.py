"""Staging spots keep a driving robot's lane between the loads put down there: big loads take fewer spots
at once, so the middle of the staging area never closes round a robot."""

from __future__ import annotations

import math

from planner_builders import portal_manifest

from bimbot.services.planner.assignment import (
    SPOT_CLEARANCE_M,
    StagedLoad,
    aisle_m,
    lying_half_m,
    spot_is_free,
)
from bimbot.services.planner.capability import SiteRobot
from bimbot.shared.fleet import default_fleet
from bimbot.shared.site_cranes import staging_spots
from bimbot.shared.site_layout import INFLATION_MARGIN_M
from bimbot.shared.site_plan import Rect

TYPES = default_fleet().types
AREA = Rect((0.0, 0.0), (8.0, 8.0))  # the 8 m staging area: four spots 4 m apart


def _fill(half_m: float, lane_m: float) -> list[StagedLoad]:
    """Loads of ``half_m`` put down one after the other on the first free spot, until none is free."""
    taken: list[StagedLoad] = []
    while True:
        spot = next((s for s in staging_spots(AREA) if spot_is_free(s, half_m, taken, lane_m)), None)
        if spot is None:
            return taken
        taken.append(StagedLoad(spot, half_m))


def test_small_loads_take_every_spot_and_ceiling_panels_only_the_diagonal_ones() -> None:
    lane_m = aisle_m({"r1": SiteRobot("r1", TYPES["carrier"], (0.0, 0.0, 0.0))})
    assert lane_m == 2.0 * (TYPES["carrier"].radius_m + INFLATION_MARGIN_M)
    assert len(_fill(0.5, lane_m)) == 4  # boxes: a lane between every two
    panels = _fill(0.5 * math.hypot(2.4, 1.2), lane_m)  # 2.4 m x 1.2 m boards
    assert len(panels) == 2
    (a, b) = (load.xy_m for load in panels)
    assert math.dist(a, b) > 5.0  # on a diagonal: the other two spots left open for the lanes
    assert len(_fill(2.5, lane_m)) == 1  # a 5 m panel: one at a time


def test_a_crane_and_pumps_need_no_lane_but_the_minimum_spacing_holds() -> None:
    site = {"r1": SiteRobot("r1", TYPES["tower_crane"], (0.0, 0.0, 0.0))}
    assert aisle_m(site) == 0.0
    near = StagedLoad((0.0, 0.0), 0.1)
    assert not spot_is_free((SPOT_CLEARANCE_M - 0.1, 0.0), 0.1, [near], 0.0)
    assert spot_is_free((SPOT_CLEARANCE_M, 0.0), 0.1, [near], 0.0)


def test_a_load_lying_flat_is_measured_by_its_two_largest_extents() -> None:
    column = next(c for c in portal_manifest().components if c.guid.startswith("col"))
    low, high = column.bbox_local.min_m, column.bbox_local.max_m
    extents = sorted(h - lo for lo, h in zip(low, high, strict=True))
    assert lying_half_m(column) == 0.5 * math.hypot(extents[1], extents[2])
