"""Approach poses: free for the robot's body, within reach, reachable, facing the component, never outside."""

from __future__ import annotations

import math

import numpy as np
import pytest
from robot_sim import convert_small_frame

from bimbot.services.robot.approach import ApproachConfig, approach_pose, reachable_region
from bimbot.services.robot.site_map import SiteMap
from bimbot.shared.footprint import Footprint, posed_footprint
from bimbot.shared.manifest import Manifest, read_manifest
from bimbot.shared.occupancy_grid import from_footprints, inflate
from bimbot.shared.site_layout import plan_site

CONFIG = ApproachConfig(reach_m=1.5, body_clearance_m=0.75)


@pytest.fixture(scope="module")
def frame(tmp_path_factory: pytest.TempPathFactory) -> Manifest:
    return read_manifest(convert_small_frame(tmp_path_factory.mktemp("frame")))


@pytest.fixture
def site(frame: Manifest) -> SiteMap:
    return SiteMap(plan_site(frame.components, robots=1), frame.components)


def test_every_yard_item_gets_a_free_reachable_approach_facing_it(site: SiteMap) -> None:
    grid = site.inflated_grid()
    start = site.layout.robot_starts[0][:2]
    region = reachable_region(grid, start)
    assert region is not None
    for guid in site.layout.slots:
        footprint = site.footprints[guid]
        found = approach_pose(grid, footprint, start, blocks_band=True, config=CONFIG, region=region)
        assert found is not None, guid
        assert grid.is_free(*found.xy_m)
        assert region[tuple(grid.world_to_cell(found.xy_m))]
        assert found.reach_distance_m <= CONFIG.reach_m - CONFIG.reach_margin_m + 1e-9
        assert footprint.distance_m([found.xy_m])[0] >= CONFIG.body_clearance_m
        centre = footprint.centre_xy_m
        assert found.yaw_rad == pytest.approx(math.atan2(centre[1] - found.y_m, centre[0] - found.x_m))
        (x0, y0), (x1, y1) = site.layout.fence.min_xy, site.layout.fence.max_xy
        assert x0 < found.x_m < x1 and y0 < found.y_m < y1, "inside the fence"


def test_a_beam_above_the_band_may_be_approached_from_under_it(frame: Manifest, site: SiteMap) -> None:
    beam = next(c for c in frame.components if c.ifc_class == "IfcBeam")
    target = beam.target_pose_world
    footprint = posed_footprint(beam, target.position_m, target.quat_xyzw)
    assert not site.blocks(footprint)
    found = approach_pose(
        site.inflated_grid(), footprint, site.layout.robot_starts[0][:2], blocks_band=False, config=CONFIG
    )
    assert found is not None
    assert found.reach_distance_m < 0.3, "right under the middle of the beam"


def test_a_column_target_keeps_the_robot_body_clear_of_it(frame: Manifest, site: SiteMap) -> None:
    column = next(c for c in frame.components if c.ifc_class == "IfcColumn")
    target = column.target_pose_world
    footprint = posed_footprint(column, target.position_m, target.quat_xyzw)
    assert site.blocks(footprint)
    found = approach_pose(
        site.inflated_grid(), footprint, site.layout.robot_starts[0][:2], blocks_band=True, config=CONFIG
    )
    assert found is not None
    assert CONFIG.body_clearance_m <= footprint.distance_m([found.xy_m])[0]
    assert found.reach_distance_m <= CONFIG.reach_m


def test_cells_cut_off_from_the_robot_are_never_chosen() -> None:
    # A 1 m box inside a closed pen: the free cells right beside it are unreachable from outside.
    walls = [(4.0, 4.0, 8.0, 4.2), (4.0, 7.8, 8.0, 8.0), (4.0, 4.0, 4.2, 8.0), (7.8, 4.0, 8.0, 8.0)]
    grid = inflate(from_footprints((0.0, 0.0, 12.0, 12.0), 0.1, boxes_xy_m=walls), 0.3)
    item = Footprint(np.array([[8.3, 5.5], [9.3, 5.5], [9.3, 6.5], [8.3, 6.5]]), 0.0, 0.2)
    found = approach_pose(grid, item, (1.0, 1.0), blocks_band=True, config=ApproachConfig(1.5, 0.1, 0.4))
    assert found is not None
    assert found.x_m > 8.0, "outside the pen, on the item's open side"


def test_no_approach_when_nothing_within_reach_is_free() -> None:
    grid = from_footprints((0.0, 0.0, 10.0, 10.0), 0.1, boxes_xy_m=[(3.0, 3.0, 7.0, 7.0)])
    item = Footprint(np.array([[4.5, 4.5], [5.5, 4.5], [5.5, 5.5], [4.5, 5.5]]), 0.0, 0.2)
    assert approach_pose(grid, item, (1.0, 1.0), blocks_band=True, config=CONFIG) is None
