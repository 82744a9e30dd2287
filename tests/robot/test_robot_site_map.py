"""The robot's site map: yard items block until picked, columns once built; beams and footings never do."""

from __future__ import annotations

import numpy as np
import pytest
from doorway_room import room_round
from frames import convert_small_frame

from bimbot.services.robot.site_map import MapConfig, SiteMap, outline
from bimbot.shared.construction_methods import CastWork, ConstructionMethod
from bimbot.shared.fleet import default_fleet
from bimbot.shared.footprint import Footprint, convex_hull_xy, posed_footprint
from bimbot.shared.manifest import Component, Manifest, read_manifest
from bimbot.shared.messages import ComponentPoseMsg, ComponentState, PoseMsg
from bimbot.shared.occupancy_grid import OccupancyGrid, inflate
from bimbot.shared.site_layout import plan_site


@pytest.fixture(scope="module")
def frame(tmp_path_factory: pytest.TempPathFactory) -> Manifest:
    return read_manifest(convert_small_frame(tmp_path_factory.mktemp("frame")))


@pytest.fixture
def site(frame: Manifest) -> SiteMap:
    return SiteMap(plan_site(frame.components, robots=1), frame.components)


def of_class(frame: Manifest, ifc_class: str) -> Component:
    return next(c for c in frame.components if c.ifc_class == ifc_class)


def pose(guid: str, position, quat=(0.0, 0.0, 0.0, 1.0), **flags: object) -> ComponentPoseMsg:
    return ComponentPoseMsg(
        guid=guid, pose=PoseMsg(position_m=position, quat_xyzw=quat), sim_time_s=1.0, **flags
    )


def at_target(component: Component, **flags: object) -> ComponentPoseMsg:
    target = component.target_pose_world
    return pose(component.guid, target.position_m, target.quat_xyzw, **flags)


def test_every_yard_item_blocks_its_slot_and_the_fence_encloses_the_site(site: SiteMap) -> None:
    grid = site.static_grid()
    for slot in site.layout.slots.values():
        centre = np.add(slot.footprint.min_xy, slot.footprint.max_xy) / 2
        assert not grid.is_free(*centre)
    (x0, y0), (x1, y1) = site.layout.fence.min_xy, site.layout.fence.max_xy
    assert not grid.is_free(x0 - 0.1, (y0 + y1) / 2) and not grid.is_free((x0 + x1) / 2, y1 + 0.1)
    assert grid.is_free(*site.layout.robot_starts[0][:2])


def test_the_machines_set_up_on_site_block_driving_and_are_in_the_lasers_map(frame: Manifest) -> None:
    """A crane's, a pump's, a block layer's, a line pump's and a piling rig's set-up rectangle is an obstacle
    to plan around and, as its URDF fills it up to 1 m, something the laser sees: in the localiser's map
    and among the outlines a robot aligns to before it places (on the bundled frame the pump stood where
    the fence had been, unmapped, and the robots placing the columns beside it found nothing to align to)."""
    fleet = default_fleet().robot_types()
    site = SiteMap(plan_site(frame.components, fleet=fleet), frame.components)
    assert len(site.layout.machines) == 5
    static, laser, fine = site.static_grid(), site.laser_grid(), site.laser_field_grid()
    segments = site.laser_segments()
    for machine in site.layout.machines:
        centre = np.add(machine.min_xy, machine.max_xy) / 2
        corner = np.add(machine.min_xy, 0.2)  # inside the rectangle, beside the truck or the footing
        for grid in (static, laser, fine):
            assert not grid.is_free(*centre) and not grid.is_free(*corner)
        (x0, y0), x1 = machine.min_xy, machine.max_xy[0]
        edge = np.array([[x0, y0], [x1, y0]])  # its south side, one of the outlines
        assert any(np.allclose(np.sort(segment, axis=0), edge) for segment in segments), machine
    assert static.is_free(*site.layout.robot_starts[0][:2])


def test_a_picked_item_leaves_the_map_and_comes_back_where_physics_fixes_it(
    frame: Manifest, site: SiteMap
) -> None:
    column = of_class(frame, "IfcColumn")
    slot = site.layout.slots[column.guid].footprint
    centre = np.add(slot.min_xy, slot.max_xy) / 2
    version = site.version
    assert site.observe_pose(pose(column.guid, (0.0, 0.0, 0.5), attached_to="r1"))
    assert site.version > version and site.carried[column.guid] == "r1"
    assert site.static_grid().is_free(*centre)
    target = column.target_pose_world.position_m
    assert site.static_grid().is_free(*target[:2])
    assert site.observe_pose(at_target(column, fixed=True))
    assert not site.static_grid().is_free(*target[:2]), "a built column stands in the robot's height band"
    assert not site.observe_pose(at_target(column, fixed=True)), "a repeated pose changes nothing"


def test_beams_above_and_footings_below_the_height_band_do_not_block(frame: Manifest, site: SiteMap) -> None:
    for ifc_class in ("IfcBeam", "IfcFooting"):
        component = of_class(frame, ifc_class)
        site.observe_pose(at_target(component, fixed=True, joined=True))  # built
        footprint = site.footprints[component.guid]
        assert not site.blocks(footprint, component.guid)
        assert site.static_grid().is_free(*footprint.centre_xy_m), ifc_class


def test_a_constructed_state_without_a_pose_puts_the_component_at_its_target(
    frame: Manifest, site: SiteMap
) -> None:
    column = of_class(frame, "IfcColumn")
    assert site.observe_state(column.guid, ComponentState.CONSTRUCTED)
    assert not site.static_grid().is_free(*column.target_pose_world.position_m[:2])


def test_inflation_keeps_the_robot_centre_off_obstacles_by_radius_plus_margin(site: SiteMap) -> None:
    inflated = site.inflated_grid()
    config = site.config
    slot = next(iter(site.layout.slots.values())).footprint
    mid_x = (slot.min_xy[0] + slot.max_xy[0]) / 2
    near = slot.max_xy[1] + config.inflation_m - 0.1
    far = slot.max_xy[1] + config.inflation_m + 0.15
    assert not inflated.is_free(mid_x, near) and inflated.is_free(mid_x, far)
    assert inflated.occupied.sum() > site.static_grid().occupied.sum()


def test_laser_marks_far_from_the_map_are_added_and_inflated_for_planning(site: SiteMap) -> None:
    start = np.array(site.layout.robot_starts[0][:2])
    mark = start + np.array([2.0, 0.0])
    assert len(site.unexplained([mark])) == 1
    fence_hit = (site.layout.fence.min_xy[0] - 0.05, start[1])
    assert len(site.unexplained([fence_hit])) == 0
    grid = site.planning_grid([mark])
    assert not grid.is_free(*(mark + np.array([site.config.inflation_m - 0.1, 0.0])))
    assert site.inflated_grid().is_free(*mark)
    # inflated around the marks only, the same as inflating them over the whole grid
    marks = [mark, start + np.array([-1.0, 3.0]), (site.layout.fence.min_xy[0] + 0.05, start[1])]
    cells = np.zeros(site.geometry.shape, bool)
    rc = site.geometry.world_to_cell(np.array(marks))
    cells[rc[:, 0], rc[:, 1]] = True
    whole = inflate(site.geometry.with_occupied(cells), site.config.inflation_m + 0.2).occupied
    expected = whole | site.inflated_grid().occupied
    assert np.array_equal(site.planning_grid(marks, marks_extra_m=0.2).occupied, expected)


def test_the_localiser_map_keeps_everything_the_laser_can_see_flat_yard_stacks_too(
    frame: Manifest, site: SiteMap
) -> None:
    laser = site.laser_field_grid()
    footing = of_class(frame, "IfcFooting")  # 0.3 m high lying in the yard
    column = of_class(frame, "IfcColumn")  # 0.1 m high lying in the yard: the laser at 6 cm sees it
    slot = site.footprints[column.guid].centre_xy_m
    assert not laser.is_free(*site.footprints[footing.guid].centre_xy_m)
    assert not laser.is_free(*slot)
    site.observe_pose(at_target(column, fixed=True))
    built = site.laser_field_grid()
    assert not built.is_free(*column.target_pose_world.position_m[:2])
    assert built.is_free(*slot)  # it left the yard


def test_geometry_helpers() -> None:
    hull = convex_hull_xy([(0, 0), (1, 0), (1, 1), (0, 1), (0.5, 0.5), (1, 0)])
    assert len(hull) == 4
    footprint = Footprint(hull, 0.0, 1.0)
    distances = footprint.distance_m([(0.5, 0.5), (2.0, 0.5), (2.0, 2.0)])
    np.testing.assert_allclose(distances, [0.0, 1.0, np.sqrt(2.0)])
    solid = OccupancyGrid(np.pad(np.ones((3, 3), bool), 1), 1.0, (0.0, 0.0))
    assert outline(solid).occupied.sum() == 8, "the centre of a 3×3 block is no surface"


def test_map_config_default_inflation() -> None:
    assert MapConfig().inflation_m == pytest.approx(0.75)


def test_a_placed_footing_not_yet_joined_is_kept_off_until_it_is(frame: Manifest, site: SiteMap) -> None:
    """A footing flush with the ground is driven over once built, but not while it settles (a robot's wheel
    would knock it): placed and not joined, it blocks the grid whatever its height."""
    footing = of_class(frame, "IfcFooting")
    target = footing.target_pose_world
    x, y = target.position_m[0], target.position_m[1]
    assert site.observe_pose(at_target(footing, fixed=True))
    assert not site.static_grid().is_free(x, y)
    assert site.observe_pose(at_target(footing, fixed=True, joined=True))
    assert site.static_grid().is_free(x, y)  # built: below the robots' band, driven over


def test_a_footing_judged_misplaced_settles_no_more_and_does_not_wall_in_its_robot(
    frame: Manifest, site: SiteMap
) -> None:
    """A misplaced flush footing stays placed and not joined until it is picked again; kept off as if it
    still settled, it walled in the carrier that had set it standing over its edge (0 of 12 built)."""
    footing = of_class(frame, "IfcFooting")
    target = footing.target_pose_world
    x, y = target.position_m[0], target.position_m[1]
    assert site.observe_pose(at_target(footing, fixed=True))
    assert not site.static_grid().is_free(x, y)
    assert site.observe_state(footing.guid, ComponentState.MISPLACED, 5.0)
    assert site.static_grid().is_free(x, y)  # at rest where it was judged: below the band
    assert not site.observe_pose(at_target(footing, fixed=True))  # physics repeats its pose: no change
    assert site.static_grid().is_free(x, y)


def test_the_distance_fields_follow_every_change_as_if_computed_whole(frame: Manifest, site: SiteMap) -> None:
    """The planner's static distance and the localiser's likelihood field are recomputed around each change
    only (a large site cannot afford the whole transform per change): after components are picked, carried,
    placed and moved, both equal the whole transform of their grid, clipped at their bound."""
    from scipy import ndimage

    from bimbot.services.robot.laser_layer import LASER_FIELD_MAX_M
    from bimbot.services.robot.site_map import STATIC_DISTANCE_MAX_M

    def whole(grid: OccupancyGrid, bound: float) -> np.ndarray:
        distance = ndimage.distance_transform_edt(~grid.occupied, sampling=grid.resolution_m)
        return np.minimum(distance, bound)

    assert site.static_distance_m().shape == site.static_grid().shape  # computed once, whole
    site.laser_distance_m()
    column, slab_or_beam = of_class(frame, "IfcColumn"), of_class(frame, "IfcBeam")
    site.observe_pose(pose(column.guid, (0.0, 0.0, 0.5), attached_to="r1"))
    site.observe_pose(at_target(column, fixed=True))
    site.observe_pose(pose(slab_or_beam.guid, (1.0, -2.0, 0.05), quat=(0.0, 0.0, 0.38268343, 0.92387953)))
    site.observe_pose(pose(slab_or_beam.guid, (1.3, -2.2, 0.05)))
    assert np.array_equal(site.static_distance_m(), whole(site.static_grid(), STATIC_DISTANCE_MAX_M))
    laser = outline(site.laser_field_grid())
    assert np.array_equal(site.laser_distance_m(), whole(laser, LASER_FIELD_MAX_M))
    assert site.laser_distance_m().shape == site.laser_field_geometry.shape


def test_the_localisers_map_is_made_when_first_asked_and_is_then_the_same_as_one_kept_from_the_start(
    frame: Manifest,
) -> None:
    """A robot that moves without a laser (plan fidelity) never pays for the localiser's finer map (1.6 GB
    of 3.2 GB on a 713 × 509 m site): it is made when first asked, from what the map holds then, and equals
    the map of a robot that kept it current from the start, then follows later changes as that one does."""
    layout = plan_site(frame.components, robots=1)
    kept, late = SiteMap(layout, frame.components), SiteMap(layout, frame.components)
    kept.laser_distance_m()
    column, beam = of_class(frame, "IfcColumn"), of_class(frame, "IfcBeam")
    moves = [
        pose(column.guid, (0.0, 0.0, 0.5), attached_to="r1"),
        at_target(column, fixed=True),
        pose(beam.guid, (1.0, -2.0, 0.05), quat=(0.0, 0.0, 0.38268343, 0.92387953)),
    ]
    for message in moves:
        kept.observe_pose(message)
        late.observe_pose(message)
    assert late._laser_layer is None  # asked for nothing the laser sees: not made
    assert np.array_equal(late.laser_field_grid().occupied, kept.laser_field_grid().occupied)
    assert np.array_equal(late.laser_distance_m(), kept.laser_distance_m())
    for map_ in (kept, late):
        map_.observe_pose(pose(beam.guid, (1.3, -2.2, 0.05)))
    assert not np.array_equal(
        late.laser_field_grid().occupied, SiteMap(layout, frame.components).laser_field_grid().occupied
    )
    assert np.array_equal(late.laser_field_grid().occupied, kept.laser_field_grid().occupied)
    assert np.array_equal(late.laser_distance_m(), kept.laser_distance_m())


def _floor(frame: Manifest, top_z_m: float) -> Component:
    """The frame's first footing raised so its top stands ``top_z_m`` above the ground: a floor's edge."""
    footing = of_class(frame, "IfcFooting")
    target = footing.target_pose_world
    lift_m = top_z_m - footing.bbox_world.max_m[2]
    position = (target.position_m[0], target.position_m[1], target.position_m[2] + lift_m)
    at = target.model_copy(update={"position_m": position})
    return footing.model_copy(update={"target_pose_world": at, "name": "Floor F", "ifc_class": "IfcSlab"})


def test_a_constructed_floor_within_the_robots_step_is_driven_on_and_its_edge_is_no_surprise(
    frame: Manifest,
) -> None:
    """A 6 cm slab blocks while it settles and until it is constructed; then a robot whose step is 7 cm
    drives on it (the restaurant's floors cut 245 components off), while its edge, at the laser's height,
    stays in the localiser's map and laser hits on it are no surprise. A robot of 5 cm step drives round."""
    floor = _floor(frame, 0.06)
    components = [floor if c.guid == floor.guid else c for c in frame.components]
    layout = plan_site(components, robots=1)
    centre = np.add(posed(floor).polygon_xy_m.min(axis=0), posed(floor).polygon_xy_m.max(axis=0)) / 2
    edge = posed(floor).polygon_xy_m[0]
    climber = SiteMap(layout, components, MapConfig(step_m=0.07))
    low = SiteMap(layout, components, MapConfig(step_m=0.05))
    for site in (climber, low):
        site.observe_pose(at_target(floor, fixed=True))
        assert not site.static_grid().is_free(*centre), "settling: keep off it"
        site.observe_pose(at_target(floor, fixed=True, joined=True))
        assert not site.static_grid().is_free(*centre), "joined, not yet constructed"
        site.observe_state(floor.guid, ComponentState.CONSTRUCTED, sim_s=10.0)
        site.advance(10.0)
    assert climber.static_grid().is_free(*centre) and climber.inflated_grid().is_free(*centre)
    assert not low.static_grid().is_free(*centre), "a 6 cm edge is beyond a 5 cm step"
    assert not climber.laser_grid().is_free(*centre), "the laser still sees its edge"
    assert len(climber.unexplained([edge])) == 0 and len(low.unexplained([edge])) == 0
    assert len(climber.unexplained([edge + 2.0])) == 1, "far from anything: a surprise"
    climber.observe_state(floor.guid, ComponentState.MISPLACED, sim_s=20.0)
    assert not climber.static_grid().is_free(*centre), "no longer constructed: round it again"
    sill = floor.model_copy(update={"ifc_class": "IfcMember", "name": "Sill"})
    components = [sill if c.guid == floor.guid else c for c in frame.components]
    site = SiteMap(layout, components, MapConfig(step_m=0.07))
    site.observe_pose(at_target(sill, fixed=True, joined=True))
    site.observe_state(sill.guid, ComponentState.CONSTRUCTED, sim_s=10.0)
    site.advance(10.0)
    assert not site.static_grid().is_free(*centre), "a curtain wall's sill member is no floor"


def test_a_cast_floor_is_driven_on_only_once_it_has_cured(frame: Manifest) -> None:
    floor = _floor(frame, 0.05)
    cast = CastWork(formwork_area_m2=4.0, volume_m3=0.5, formwork_s=3600.0, pour_s=600.0, cure_s=86_400.0)
    floor = floor.model_copy(update={"method": ConstructionMethod.CAST_IN_PLACE, "cast": cast})
    components = [floor if c.guid == floor.guid else c for c in frame.components]
    site = SiteMap(plan_site(components, robots=1), components, MapConfig(step_m=0.07))
    centre = np.add(posed(floor).polygon_xy_m.min(axis=0), posed(floor).polygon_xy_m.max(axis=0)) / 2
    site.observe_pose(at_target(floor, fixed=True, joined=True))
    site.observe_state(floor.guid, ComponentState.CONSTRUCTED, sim_s=100.0)
    assert not site.advance(86_000.0) and not site.static_grid().is_free(*centre), "green concrete"
    assert site.advance(86_500.0) and site.static_grid().is_free(*centre)


def posed(component: Component) -> Footprint:
    target = component.target_pose_world
    return posed_footprint(component, target.position_m, target.quat_xyzw)


def test_what_is_in_place_before_the_robots_come_stands_in_the_map_from_the_start(frame: Manifest) -> None:
    """The restaurant's 404 existing walls and slabs were in physics but not in the robots' maps: a carrier
    planned through them and was walled in. Existing work now stands where the model puts it (a low
    existing floor is driven on)."""
    floor = _floor(frame, 0.05)
    column = next(  # one not standing on that footing
        c
        for c in frame.components
        if c.ifc_class == "IfcColumn" and posed(floor).distance_m([posed(c).centre_xy_m])[0] > 2.0
    )
    components = [c for c in frame.components if c.guid not in (column.guid, floor.guid)]
    layout = plan_site(components, robots=1)
    site = SiteMap(layout, components, MapConfig(step_m=0.07), in_place=[column, floor])
    assert not site.static_grid().is_free(*posed(column).centre_xy_m), "an existing column blocks"
    assert site.laser_grid().occupied.any() and not site.laser_grid().is_free(*posed(column).centre_xy_m)
    assert site.static_grid().is_free(*posed(floor).centre_xy_m), "an existing 5 cm floor is driven on"
    assert column.guid not in site.carried and not site.in_yard(column.guid)


def test_a_doorway_under_its_lintel_is_free_in_the_map_and_the_laser_sees_through_it(frame: Manifest) -> None:
    """A wall occupies the map by its collision parts, not its bounding box: the doorway of an existing
    room round a column is free for planning and for the laser, its piers are not; a room known only by
    its bounding box fills the doorway."""
    footing = next(c for c in frame.components if c.ifc_class == "IfcFooting")
    column = next(c for c in frame.components if c.ifc_class == "IfcColumn")
    components = [c for c in frame.components if c.guid != footing.guid]
    layout = plan_site(components, robots=1)
    room = room_round(column, footing, doorway_to_m=2.2)
    cx, cy, _ = column.target_pose_world.position_m
    doorway, pier = (cx - 2.85, cy), (cx - 2.85, cy - 2.0)
    site = SiteMap(layout, components, MapConfig(step_m=0.07), in_place=[room])
    assert site.static_grid().is_free(*doorway) and not site.static_grid().is_free(*pier)
    assert site.laser_grid().is_free(*doorway) and not site.laser_grid().is_free(*pier)
    boxed = SiteMap(
        layout,
        components,
        MapConfig(step_m=0.07),
        in_place=[room.model_copy(update={"part_boxes_local": []})],
    )
    assert not boxed.static_grid().is_free(*doorway)


def test_what_a_robot_has_beside_it_is_what_occupies_its_map_not_the_floors_above_or_below_it(
    frame: Manifest,
) -> None:
    """A robot that could not get on named, as what lay beside it, three slabs 7.5 m above, 11.3 m above and
    under the ground, at 0.0 m each; the roof panel that had fallen over it, at 0.0 m too, went unnamed.
    What it names is what occupies its map."""
    upper = _floor(frame, 7.62)  # an upper storey's slab, over where the robot stands
    components = [c for c in frame.components if c.guid != upper.guid]
    layout = plan_site(components, robots=1)
    site = SiteMap(layout, components, MapConfig(step_m=0.07), in_place=[upper])
    centre = posed(upper).centre_xy_m
    assert site.static_grid().is_free(*centre)
    assert site.components_near(centre, 1.0) == []
    fallen = next(c for c in components if c.guid in layout.slots)
    laid = posed_footprint(fallen, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
    offset = centre - laid.centre_xy_m
    site.observe_pose(pose(fallen.guid, (offset[0], offset[1], 0.0), fixed=True))  # placed, never joined
    assert not site.static_grid().is_free(*centre)
    assert [name for name, _ in site.components_near(centre, 1.0)] == [fallen.name or fallen.guid]


def test_free_at_answers_as_the_inflated_grid_does_without_building_it(
    frame: Manifest, site: SiteMap
) -> None:
    grid = site.inflated_grid()
    rng = np.random.default_rng(3)
    (x0, y0, x1, y1) = grid.bounds_xy_m
    points = rng.uniform((x0 - 1.0, y0 - 1.0), (x1 + 1.0, y1 + 1.0), size=(4000, 2))
    points = np.vstack([points, grid.cell_to_world(np.argwhere(grid.occupied)[:2000])])
    assert np.array_equal(site.free_at(points), grid.is_free_xy(points))
    assert np.array_equal(site.free_at(points, 0.35), site.inflated_grid(0.35).is_free_xy(points))
    site.observe_pose(at_target(of_class(frame, "IfcColumn"), fixed=True))
    assert np.array_equal(site.free_at(points), site.inflated_grid().is_free_xy(points))


def test_a_part_placed_joined_and_constructed_where_it_lies_is_rasterised_once(
    frame: Manifest, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Placed (settling), joined, then said constructed at the same pose: the cells it covered are kept,
    not rasterised again (every robot did it for every component three times), and the map is the one a
    robot that heard only the end has; a pose that moved it is rasterised again."""
    import bimbot.services.robot.site_map as site_map_module

    column = of_class(frame, "IfcColumn")
    heard_all, heard_end = (SiteMap(plan_site(frame.components, robots=1), frame.components) for _ in "ab")
    rasterised = []
    real = site_map_module.covered_cells
    monkeypatch.setattr(site_map_module, "covered_cells", lambda *a: rasterised.append(1) or real(*a))
    heard_all.observe_pose(pose(column.guid, (0.0, 0.0, 0.5), attached_to="r1"))
    assert heard_all.observe_pose(at_target(column, fixed=True))
    assert len(rasterised) == 1
    assert heard_all.observe_pose(at_target(column, fixed=True, joined=True))
    heard_all.observe_state(column.guid, ComponentState.CONSTRUCTED, 2.0)
    assert len(rasterised) == 1
    heard_end.observe_pose(at_target(column, fixed=True, joined=True))
    heard_end.observe_state(column.guid, ComponentState.CONSTRUCTED, 2.0)
    assert np.array_equal(heard_all.static_grid().occupied, heard_end.static_grid().occupied)
    assert np.array_equal(heard_all.static_distance_m(), heard_end.static_distance_m())
    rasterised.clear()
    moved = column.target_pose_world.position_m
    heard_all.observe_pose(pose(column.guid, (moved[0] + 0.5, moved[1], moved[2]), fixed=True, joined=True))
    assert len(rasterised) == 1


def test_a_part_judged_misplaced_is_loose_until_taken_up_and_the_map_sees_past_it(
    frame: Manifest, site: SiteMap
) -> None:
    """What the shut-in check sees past (services/robot/shut_in_check.py): a column set down off its target,
    settling and then judged misplaced, lies loose; the grid without it is free where it lies, and its
    target is where its retry will set it. Taken up again, it is loose no more."""
    column = of_class(frame, "IfcColumn")
    target = column.target_pose_world
    off = (target.position_m[0] + 1.5, target.position_m[1], target.position_m[2])
    assert site.observe_pose(pose(column.guid, off, target.quat_xyzw, fixed=True))
    assert site.loose_targets()[0] == [column.guid]  # set down, not joined: settling, judged next
    assert site.observe_state(column.guid, ComponentState.MISPLACED, 5.0)
    assert site.loose == {column.guid}
    radius = site.config.inflation_m
    assert not site.inflated_grid(radius).is_free(off[0], off[1])
    assert site.inflated_grid_without([column.guid], radius).is_free(off[0], off[1])
    guids, outlines = site.loose_targets()
    assert guids == [column.guid] and len(outlines) >= 1
    centre = np.mean(np.vstack(outlines), axis=0)
    assert np.allclose(centre, target.position_m[:2], atol=0.3)
    assert site.loose_targets(but=column.guid) == ([], [])
    site.observe_state(column.guid, ComponentState.PICKING, 6.0)
    assert site.loose == set() and site.loose_targets() == ([], [])
