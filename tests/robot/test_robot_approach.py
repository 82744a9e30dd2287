"""Approach poses: free for the robot's body, within reach, reachable, facing the component, never outside."""

from __future__ import annotations

import math

import numpy as np
import pytest
from frames import convert_small_frame

from bimbot.services.robot.approach import (
    ApproachConfig,
    approach_pose,
    cut_off,
    no_approach_reason,
    reachable_region,
    sets_from_outside,
    way_out_after,
    within_reach,
)
from bimbot.services.robot.astar import plan_path
from bimbot.services.robot.site_map import SiteMap
from bimbot.shared.footprint import Footprint, posed_footprint
from bimbot.shared.manifest import Manifest, read_manifest
from bimbot.shared.occupancy_grid import OccupancyGrid, from_footprints, inflate
from bimbot.shared.reasons import ReasonCode
from bimbot.shared.robot_description import DEFAULT_ROBOT
from bimbot.shared.site_layout import plan_site
from bimbot.shared.site_plan import Rect

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


def _rect(x0: float, y0: float, x1: float, y1: float, z_max_m: float = 0.5) -> Footprint:
    return Footprint(np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]]), 0.0, z_max_m)


def _open_site():
    """An empty 20 m × 20 m site, inflated like the robot's map (the fence as a 0.2 m wall around it)."""
    walls = [(0.0, 0.0, 20.0, 0.2), (0.0, 19.8, 20.0, 20.0), (0.0, 0.0, 0.2, 20.0), (19.8, 0.0, 20.0, 20.0)]
    return inflate(from_footprints((0.0, 0.0, 20.0, 20.0), 0.1, boxes_xy_m=walls), 0.75)


@pytest.mark.parametrize(
    ("name", "footprint"),
    [
        ("4 m x 3 m footing slab", _rect(8.0, 8.5, 12.0, 11.5, 0.5)),
        ("5 m wall in place", _rect(7.5, 9.9, 12.5, 10.1, 3.0)),
        (
            "5 m wall turned 30 degrees",
            Footprint(
                np.array([[-2.5, -0.1], [2.5, -0.1], [2.5, 0.1], [-2.5, 0.1]])
                @ np.array([[math.cos(0.52), math.sin(0.52)], [-math.sin(0.52), math.cos(0.52)]])
                + (10.0, 10.0),
                0.0,
                3.0,
            ),
        ),
    ],
)
def test_wide_components_have_an_approach_within_reach_of_their_nearest_edge(
    name: str, footprint: Footprint
) -> None:
    # Before the shared reach rule, stand-points were kept within reach of the footprint's *centre* and
    # outside its outline: nothing wider than 2 × (1.4 − 0.75) m had any.
    grid = _open_site()
    config = ApproachConfig(reach_m=DEFAULT_ROBOT.reach_m, body_clearance_m=0.75)
    for robot_xy in ((2.0, 2.0), (18.0, 18.0)):
        found = approach_pose(grid, footprint, robot_xy, blocks_band=True, config=config)
        assert found is not None, name
        assert DEFAULT_ROBOT.reaches(found.xy_m, footprint.polygon_xy_m), "the one reach rule physics checks"
        distance = footprint.distance_m([found.xy_m])[0]
        assert found.reach_distance_m == pytest.approx(distance)
        assert 0.75 <= distance <= DEFAULT_ROBOT.reach_m - config.reach_margin_m, "body clear, within reach"
        assert grid.is_free(*found.xy_m)


def test_the_approach_is_on_the_robots_side_and_another_side_when_one_is_avoided() -> None:
    grid = _open_site()
    wall = _rect(7.5, 9.9, 12.5, 10.1, 3.0)
    south = approach_pose(grid, wall, (10.0, 3.0), blocks_band=True, config=CONFIG)
    north = approach_pose(grid, wall, (10.0, 17.0), blocks_band=True, config=CONFIG)
    assert south is not None and north is not None
    assert south.y_m < 9.9 and north.y_m > 10.1, "each robot stays on its own side of the wall"
    assert abs(south.x_m - 10.0) < 0.5, "the middle of the long side"
    other = approach_pose(grid, wall, (10.0, 3.0), blocks_band=True, config=CONFIG, avoid_xy_m=[south.xy_m])
    assert other is not None and math.dist(other.xy_m, south.xy_m) > 1.0


def test_a_column_inside_a_closed_room_is_unreachable_with_the_numbers() -> None:
    room = [(8.0, 8.0, 14.0, 8.2), (8.0, 13.8, 14.0, 14.0), (8.0, 8.0, 8.2, 14.0), (13.8, 8.0, 14.0, 14.0)]
    grid = inflate(from_footprints((0.0, 0.0, 20.0, 20.0), 0.1, boxes_xy_m=room), 0.75)
    column = _rect(10.9, 10.9, 11.1, 11.1, 3.0)
    config = ApproachConfig(reach_m=1.5, body_clearance_m=0.75)
    assert approach_pose(grid, column, (2.0, 2.0), blocks_band=True, config=config) is None
    reason = no_approach_reason(
        grid, column, (2.0, 2.0), blocks_band=True, config=config, what="Column R1", robot="r1"
    )
    assert reason.code is ReasonCode.UNREACHABLE
    assert (
        "Column R1 (0.20 m × 0.20 m at (11.00, 11.00)) is cut off from r1 at (2.00, 2.00)" in reason.message
    )
    inside = approach_pose(grid, column, (9.5, 9.5), blocks_band=True, config=config)
    assert inside is not None, "from inside the room it is reachable"


def test_a_robot_walled_in_itself_is_trapped_not_the_component_unreachable() -> None:
    """A robot inside a closed room asked for a component outside: the robot's problem, not the component's
    (the planner then hands the task to another robot)."""
    room = [(8.0, 8.0, 14.0, 8.2), (8.0, 13.8, 14.0, 14.0), (8.0, 8.0, 8.2, 14.0), (13.8, 8.0, 14.0, 14.0)]
    grid = inflate(from_footprints((0.0, 0.0, 20.0, 20.0), 0.1, boxes_xy_m=room), 0.75)
    beam = _rect(3.0, 2.9, 6.0, 3.1, 0.2)
    config = ApproachConfig(reach_m=1.5, body_clearance_m=0.75)
    kwargs = {"blocks_band": True, "config": config, "what": "Beam B1", "robot": "r2"}
    trapped = no_approach_reason(grid, beam, (11.0, 11.0), home_xy_m=(1.0, 1.0), **kwargs)
    assert trapped.code is ReasonCode.ROBOT_TRAPPED
    assert (
        trapped.message.startswith("r2 at (11.00, 11.00) is walled in") and "(1.00, 1.00)" in trapped.message
    )
    # a robot outside, for a component inside the room: the component is the one cut off
    inside = _rect(10.9, 10.9, 11.1, 11.1, 3.0)
    cut_off = no_approach_reason(grid, inside, (2.0, 2.0), home_xy_m=(1.0, 1.0), **kwargs)
    assert cut_off.code is ReasonCode.UNREACHABLE


def test_no_free_stand_point_at_all_is_no_approach_pose() -> None:
    grid = from_footprints((0.0, 0.0, 10.0, 10.0), 0.1, boxes_xy_m=[(3.0, 3.0, 7.0, 7.0)])
    item = _rect(4.5, 4.5, 5.5, 5.5, 0.2)
    reason = no_approach_reason(
        grid, item, (1.0, 1.0), blocks_band=True, config=CONFIG, what="Footing F1", robot="r1", radius_m=0.6
    )
    assert reason.code is ReasonCode.NO_APPROACH_POSE
    assert reason.message == (
        "no free cell within 1.40 m of Footing F1 (1.00 m × 1.00 m at (5.00, 5.00)), 0.75 m clear of it, "
        "holds r1 (footprint radius 0.60 m, reach 1.50 m)"
    )


def test_within_reach_is_the_reach_rule_with_the_body_clear() -> None:
    wall = _rect(7.5, 9.9, 12.5, 10.1, 3.0)
    config = ApproachConfig(reach_m=1.5, reach_margin_m=0.1, body_clearance_m=0.75)
    assert within_reach(wall, (12.0, 9.0), blocks_band=True, config=config), "0.9 m from the long edge"
    assert not within_reach(wall, (10.0, 8.4), blocks_band=True, config=config), "1.5 m: beyond the margin"
    assert not within_reach(wall, (10.0, 9.5), blocks_band=True, config=config), "0.4 m: the body hits it"
    assert within_reach(wall, (10.0, 10.0), blocks_band=False, config=config), "under a beam is fine"


def test_a_wall_on_the_structures_edge_is_set_from_outside_it_and_a_partition_inside_from_inside() -> None:
    """A structure 10 m × 10 m (its floor flush, no obstacle) with a robot inside it: the wall on its east
    edge is approached from outside the structure's footprint, though a stand-point inside is nearer the
    robot; a partition in the middle, with no stand-point outside in reach, from inside."""
    grid = from_footprints((-10.0, -10.0, 30.0, 30.0), 0.1, boxes_xy_m=[])
    structure = Rect((0.0, 0.0), (10.0, 10.0))
    edge_wall = _rect(9.82, 2.0, 9.92, 8.0, 3.0)
    robot_xy = (5.0, 5.0)
    kwargs = {"blocks_band": True, "config": CONFIG}
    nearest = approach_pose(grid, edge_wall, robot_xy, **kwargs)
    assert nearest is not None and nearest.x_m < 10.0, "without the rule: the side nearer the robot, inside"
    outside = approach_pose(grid, edge_wall, robot_xy, outside_of=structure, **kwargs)
    assert outside is not None and outside.x_m > 10.0, outside
    assert outside.reach_distance_m <= CONFIG.reach_m - CONFIG.reach_margin_m + 1e-9
    partition = _rect(4.95, 2.0, 5.05, 8.0, 3.0)
    inside = approach_pose(grid, partition, robot_xy, outside_of=structure, **kwargs)
    assert inside is not None and 0.0 < inside.x_m < 10.0, "no stand-point outside: one inside"


def test_only_enclosing_elements_are_set_from_outside() -> None:
    """Walls, curtain walls and their panels close the building in; a column or a beam closes nothing in
    and is approached from its nearest side (the demo's edge columns failed from across the frame)."""
    for enclosing in ("IfcWall", "IfcWallStandardCase", "IfcCurtainWall", "IfcPlate", "IfcWindow"):
        assert sets_from_outside(enclosing), enclosing
    for frame in ("IfcColumn", "IfcBeam", "IfcSlab", "IfcFooting", "IfcMember"):
        assert not sets_from_outside(frame), frame


def test_the_partition_that_closes_a_room_is_set_from_the_side_with_the_way_out() -> None:
    """A room open on its west side (a 4 m gap), the robot inside it, its depot outside: the partition
    that closes the gap is set from outside, though the inside is nearer the robot (the Revit house's
    carrier set such a partition from inside and was walled in). A partition that closes nothing may be set
    from either side: the nearer one."""
    room = [(8.0, 8.0, 14.0, 8.2), (8.0, 13.8, 14.0, 14.0), (13.8, 8.0, 14.0, 14.0)]  # no west wall
    grid = inflate(from_footprints((0.0, 0.0, 20.0, 20.0), 0.1, boxes_xy_m=room), 0.75)
    home, robot = (1.0, 1.0), (9.5, 11.0)
    gap = _rect(8.0, 8.2, 8.1, 13.8, 3.0)
    kwargs = {"blocks_band": True, "config": ApproachConfig(reach_m=1.5, body_clearance_m=0.75)}
    nearest = approach_pose(grid, gap, robot, **kwargs)
    assert nearest is not None and nearest.x_m > 8.1, "without a way out: the side nearer the robot, inside"
    way_out = way_out_after(grid, gap.outlines_meeting(0.02, 1.0), home, 0.75)
    assert way_out is not None
    kept = approach_pose(grid, gap, robot, way_out=way_out, **kwargs)
    assert kept is not None and kept.x_m < 8.0, kept
    free_standing = _rect(11.0, 9.5, 11.1, 12.5, 3.0)  # a partition inside the room that closes nothing
    way_out = way_out_after(grid, free_standing.outlines_meeting(0.02, 1.0), home, 0.75)
    near = approach_pose(grid, free_standing, robot, way_out=way_out, **kwargs)
    assert near is not None and near.x_m < 11.0, "both sides leave a way out: the nearer one"


def test_a_stand_point_in_a_pocket_the_component_closes_at_the_robots_inflation_keeps_no_way_out() -> None:
    """A room whose west wall has a 3 m opening; a post set in its middle leaves 1.45 m either side, less
    than the inflated robot's 1.5 m, so on the robot's map the room is closed once the post stands (the
    restaurant's carrier set a curtain-wall door from such a pocket and was walled in). The way out is
    judged at the inflation the robot plans with: the post is set from outside the room."""
    bounds, inflation = (0.0, 0.0, 20.0, 20.0), 0.75
    walls = [(8.0, 2.0, 8.2, 10.0), (8.0, 13.0, 8.2, 18.0), (8.0, 2.0, 16.0, 2.2), (8.0, 17.8, 16.0, 18.0)]
    walls.append((15.8, 2.0, 16.0, 18.0))
    grid = inflate(from_footprints(bounds, 0.1, boxes_xy_m=walls), inflation)
    home, robot = (1.0, 1.0), (10.0, 11.5)
    post = _rect(8.05, 11.45, 8.15, 11.55, 3.0)
    after = inflate(from_footprints(bounds, 0.1, boxes_xy_m=[*walls, (8.05, 11.45, 8.15, 11.55)]), inflation)
    assert cut_off(after, robot, home), "once the post stands, the room is closed on the robot's map"
    kwargs = {"blocks_band": True, "config": ApproachConfig(reach_m=1.5, body_clearance_m=inflation)}
    nearest = approach_pose(grid, post, robot, **kwargs)
    assert nearest is not None and nearest.x_m > 8.2, "without a way out: the side nearer the robot, inside"
    way_out = way_out_after(grid, post.outlines_meeting(0.02, 1.0), home, inflation)
    assert way_out is not None
    kept = approach_pose(grid, post, robot, way_out=way_out, **kwargs)
    assert kept is not None and kept.x_m < 8.0, kept
    assert not cut_off(after, kept.xy_m, home), "from there it drives home once the post stands"


def test_a_gap_two_free_cells_touch_only_at_a_corner_is_no_way_through_for_the_region_as_for_a_star() -> None:
    """The Janesville restaurant's storefront vestibule opened onto the rest of the site only through two
    inflated cells touching at a corner: the walled-in check (8-connected then) found a way to the depot that
    A*, which never cuts a corner, could not take; the carrier inside took task after task and gave each back
    ``no_progress``, three mullions failed. The region is what A* reaches: 4-connected."""
    occupied = np.ones((5, 5), bool)
    occupied[1, 1] = occupied[2, 2] = occupied[3, 3] = False  # a diagonal of free cells, corners only
    grid = OccupancyGrid(occupied, 1.0, (0.0, 0.0))
    start, goal = grid.cell_to_world((1, 1)), grid.cell_to_world((3, 3))
    assert not plan_path(grid, start, goal).found
    region = reachable_region(grid, start)
    assert region is not None and region.sum() == 1
    assert cut_off(grid, start, goal)
    occupied[1, 2] = occupied[2, 3] = False  # a straight step beside each corner: a way A* takes
    open_grid = OccupancyGrid(occupied, 1.0, (0.0, 0.0))
    assert plan_path(open_grid, start, goal).found and not cut_off(open_grid, start, goal)
