"""The planner's access check keeps the robots' free region current around each placement, cell for cell
the region of a whole distance transform (which took 50–100 ms a placement on the 988-component site's
0.1 m grid, once per placement of every checking round)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from doorway_room import room_round
from scipy import ndimage

from bimbot.shared.manifest import Component, read_manifest
from bimbot.shared.occupancy_grid import distance_field_m, nearest_free_cell
from bimbot.shared.robot_description import DEFAULT_ROBOT
from bimbot.shared.site_access import AccessConfig, SiteAccess, check_order
from bimbot.shared.site_layout import plan_site


def _region_from_scratch(access: SiteAccess) -> np.ndarray:
    """The free region as a whole transform gives it: inflated free cells 8-connected to the depot start."""
    base = access.occupancy()
    free = ~(distance_field_m(base) <= access.inflation_m + 1e-9)
    labels, _ = ndimage.label(free, structure=np.ones((3, 3), bool))
    depot = access.layout.robot_starts[0][:2]
    start = nearest_free_cell(base.with_occupied(~free), depot, max_distance_m=5.0)
    assert start is not None
    return labels == labels[start]


def test_the_region_after_placements_and_removals_is_that_of_a_whole_transform(bundled_build: Path) -> None:
    components = read_manifest(bundled_build).components
    access = SiteAccess(components, plan_site(components, robots=2), DEFAULT_ROBOT, AccessConfig(0.1))
    guids = [component.guid for component in components]
    assert np.array_equal(access.region(), _region_from_scratch(access))
    rng = np.random.default_rng(5)
    for step, guid in enumerate(rng.permutation(guids)):
        access.place(str(guid))
        if step % 5 == 4:
            access.remove(str(guids[step]))  # back to its yard slot
        assert np.array_equal(access.region(), _region_from_scratch(access)), step
    assert access.placed  # placements happened, and the region shrank where they stand
    check = check_order(SiteAccess(components, access.layout, DEFAULT_ROBOT, AccessConfig(0.1)), guids)
    assert not check.inaccessible  # the bundled frame's manifest order keeps every component accessible


def test_a_floor_within_the_robots_step_is_driven_on_not_round(bundled_build: Path) -> None:
    """An 8 m × 8 m floor 6 cm high laid round a column: every stand-point of the column lies on it. A
    robot that drives up a 7 cm edge still reaches the column; one whose step is 5 cm does not (the
    restaurant's 5 cm floors cut 245 of its 470 components off)."""
    components = list(read_manifest(bundled_build).components)
    column = next(c for c in components if c.ifc_class == "IfcColumn")
    footing = next(c for c in components if c.ifc_class == "IfcFooting")
    box = footing.bbox_local
    depth_m = box.max_m[2] - box.min_m[2]
    floor_box = box.model_copy(update={"min_m": (-4.0, -4.0, -depth_m / 2), "max_m": (4.0, 4.0, depth_m / 2)})
    cx, cy, _ = column.target_pose_world.position_m
    at = footing.target_pose_world.model_copy(update={"position_m": (cx, cy, 0.06 - depth_m / 2)})
    floor = footing.model_copy(
        update={"bbox_local": floor_box, "target_pose_world": at, "name": "Floor", "ifc_class": "IfcSlab"}
    )
    components = [floor if c.guid == footing.guid else c for c in components]
    layout = plan_site(components, robots=1)
    for step_m, reaches in ((0.07, True), (0.05, False)):
        robot = DEFAULT_ROBOT.model_copy(update={"max_step_m": step_m})
        access = SiteAccess(components, layout, robot, AccessConfig(0.1))
        assert access.target_accessible(column.guid)
        access.place(floor.guid)
        assert access.target_accessible(column.guid) is reaches, step_m


def test_what_is_in_place_before_the_robots_come_stands_in_the_access_check(bundled_build: Path) -> None:
    """Existing work occupies the site grid where the model puts it: an existing 8 m × 8 m plinth round a
    column leaves no stand-point for it."""
    components = list(read_manifest(bundled_build).components)
    column = next(c for c in components if c.ifc_class == "IfcColumn")
    footing = next(c for c in components if c.ifc_class == "IfcFooting")
    box = footing.bbox_local
    plinth_box = box.model_copy(update={"min_m": (-4.0, -4.0, -0.25), "max_m": (4.0, 4.0, 0.25)})
    cx, cy, _ = column.target_pose_world.position_m
    at = footing.target_pose_world.model_copy(update={"position_m": (cx, cy, 0.25)})
    plinth = footing.model_copy(update={"bbox_local": plinth_box, "target_pose_world": at, "name": "Plinth"})
    built = [c for c in components if c.guid != footing.guid]
    layout = plan_site(built, robots=1)
    assert SiteAccess(built, layout, DEFAULT_ROBOT, AccessConfig(0.1)).target_accessible(column.guid)
    walled = SiteAccess(built, layout, DEFAULT_ROBOT, AccessConfig(0.1), in_place=[plinth])
    assert not walled.target_accessible(column.guid)


def test_a_doorway_under_its_lintel_is_driven_through_a_wall_closed_to_the_floor_is_not(
    bundled_build: Path,
) -> None:
    """A wall's collision parts occupy the grid, not its bounding box: the opening under a door's lintel is
    free (the restaurant's existing walls, each one box, closed all 470 new components in). Closed to the
    floor, or known only by its bounding box, the room round the column shuts it off."""
    components = list(read_manifest(bundled_build).components)
    column = next(c for c in components if c.ifc_class == "IfcColumn")
    footing = next(c for c in components if c.ifc_class == "IfcFooting")
    built = [c for c in components if c.guid != footing.guid]
    layout = plan_site(built, robots=1)
    with_door = room_round(column, footing, doorway_to_m=2.2)
    closed = room_round(column, footing, doorway_to_m=0.0)
    one_box = with_door.model_copy(update={"part_boxes_local": []})
    for ring, reaches in ((with_door, True), (closed, False), (one_box, False)):
        access = SiteAccess(built, layout, DEFAULT_ROBOT, AccessConfig(0.1), in_place=[ring])
        assert access.target_accessible(column.guid) is reaches, ring.part_boxes_local[-1:] or "one box"


def _room_with_gate(bundled_build: Path) -> tuple[list[Component], Component, Component, Component]:
    """The bundled frame, a room of walls (a component) round one of its columns, and a gate: a part
    standing in the room's doorway, to the floor."""
    components = list(read_manifest(bundled_build).components)
    column = next(c for c in components if c.ifc_class == "IfcColumn")
    footing = next(c for c in components if c.ifc_class == "IfcFooting")
    ring = room_round(column, footing, doorway_to_m=2.2)
    cx, cy, _ = column.target_pose_world.position_m
    gate_box = footing.bbox_local.model_copy(
        update={"min_m": (-0.15, -1.25, 0.0), "max_m": (0.15, 1.25, 2.2)}
    )
    at = footing.target_pose_world.model_copy(update={"position_m": (cx - 2.85, cy, 0.0)})
    gate = footing.model_copy(
        update={
            "guid": "0GateInTheDoorway000000",
            "name": "Gate",
            "bbox_local": gate_box,
            "target_pose_world": at,
        }
    )
    built = [c for c in components if c.guid != footing.guid] + [ring, gate]
    return built, column, ring, gate


def test_what_a_placement_would_cut_off_is_answered_without_changing_the_grid(bundled_build: Path) -> None:
    """The gate in the room's doorway cuts the column off; asked, the grid and its free region stay as
    they were. Answered in a window round the part, and on the whole grid when that cannot tell: the same
    answers along a whole build order."""
    from bimbot.shared import free_region, site_access

    built, column, ring, gate = _room_with_gate(bundled_build)
    layout = plan_site(built, robots=1)
    access = SiteAccess(built, layout, DEFAULT_ROBOT, AccessConfig(0.1))
    access.place(ring.guid)
    others = [c.guid for c in built if c.guid not in (ring.guid, gate.guid)]
    region, occupied = access.region().copy(), access.occupancy().occupied.copy()
    assert access.cut_off_by(gate.guid, others) == [column.guid]
    assert np.array_equal(access.region(), region) and np.array_equal(access.occupancy().occupied, occupied)
    assert np.array_equal(_region_from_scratch(access), region)
    access.place(column.guid)
    assert access.cut_off_by(gate.guid, [g for g in others if g != column.guid]) == []
    access.remove(column.guid)

    order = [g for g in others if g != column.guid] + [column.guid, gate.guid]
    answers = []
    for guid in order:
        answers.append(access.cut_off_by(guid, order))
        access.place(guid)
    whole = SiteAccess(built, layout, DEFAULT_ROBOT, AccessConfig(0.1))
    whole.place(ring.guid)
    local, site_access.splits_nothing = site_access.splits_nothing, lambda before, free: False
    free_region.splits_nothing = site_access.splits_nothing  # and the region itself labelled whole
    try:
        for guid, answer in zip(order, answers, strict=True):
            assert whole.cut_off_by(guid, order) == answer, guid
            whole.place(guid)
    finally:
        site_access.splits_nothing = free_region.splits_nothing = local
    assert any(answers), "some placement in the order cuts something off"


def test_the_check_asks_only_whose_reach_the_region_changed_in_and_answers_as_asking_all(
    bundled_build: Path,
) -> None:
    """A placement changes the free region round itself (or splits it): the check asks again only the
    components reached from the boxes where it changed (a slot freed and a part placed are two boxes);
    asking every component after every placement gives the same answers, along several orders of the
    room, its gate and the frame."""
    from bimbot.shared import site_access

    built, _, _, _ = _room_with_gate(bundled_build)
    layout = plan_site(built, robots=1)
    rng = np.random.default_rng(11)
    guids = [c.guid for c in built]
    whole_grid = lambda before, after: [(0, before.shape[0] - 1, 0, before.shape[1] - 1)]  # noqa: E731
    cutting = 0
    for _ in range(4):
        order = [str(g) for g in rng.permutation(guids)]
        fast = check_order(SiteAccess(built, layout, DEFAULT_ROBOT), order)
        local, site_access._changed_boxes = site_access._changed_boxes, whole_grid
        try:
            everyone = check_order(SiteAccess(built, layout, DEFAULT_ROBOT), order)
        finally:
            site_access._changed_boxes = local
        assert fast == everyone
        cutting += bool(fast.cut_offs)
    assert cutting, "some order cuts something off (the gate, the room)"


def test_the_region_changed_in_two_places_is_two_boxes_that_hold_every_changed_cell() -> None:
    """A slot freed in the yard and a part placed across the site are two boxes, not the one box round
    both (on a 9,802-component frame that one box met hundreds of components' reach a placement)."""
    from bimbot.shared.site_access import _changed_boxes

    before = np.zeros((50, 60), bool)
    after = before.copy()
    assert _changed_boxes(before, after) == []
    after[2:4, 5:9] = True  # the slot
    after[40:45, 50:52] = True  # the target
    after[41, 51] = False
    boxes = _changed_boxes(before, after)
    assert sorted(boxes) == [(2, 3, 5, 8), (40, 44, 50, 51)]
    after[20, 30] = True  # a third change in a row band of its own and a column band of its own
    covered = np.zeros_like(before)
    for r0, r1, c0, c1 in _changed_boxes(before, after):
        covered[r0 : r1 + 1, c0 : c1 + 1] = True
    assert not ((before != after) & ~covered).any() and covered.sum() < 50 * 60 / 10


def test_a_check_taken_on_from_an_earlier_order_answers_as_a_check_from_the_start(
    bundled_build: Path,
) -> None:
    """A mended plan shares its first steps with the order checked before it: the check takes those
    answers over and goes on from the first step that differs. Along several pairs of orders of the room,
    its gate and the frame (the second the first with a tail shuffled), the answers equal a whole check's,
    and the steps taken over are not checked again."""
    built, _, _, _ = _room_with_gate(bundled_build)
    layout = plan_site(built, robots=1)
    rng = np.random.default_rng(5)
    guids = [c.guid for c in built]
    taken_over = 0
    for keep in (0, 3, len(guids) // 2, len(guids) - 2, len(guids)):
        first = [str(g) for g in rng.permutation(guids)]
        second = first[:keep] + [str(g) for g in rng.permutation(first[keep:])]
        access = SiteAccess(built, layout, DEFAULT_ROBOT)
        earlier = check_order(access, first)
        access.reset()
        steps: list[int] = []
        resumed = check_order(
            access, second, lambda done, _, seen=steps: seen.append(done), earlier=(first, earlier)
        )
        assert resumed == check_order(SiteAccess(built, layout, DEFAULT_ROBOT), second)
        shared = next((i for i, (a, b) in enumerate(zip(first, second, strict=True)) if a != b), len(second))
        assert steps == list(range(shared, len(second)))
        assert access.placed == set(second)
        taken_over += shared
    assert taken_over > 0


def test_what_the_access_remembers_between_changes_is_what_it_would_read_afresh(bundled_build: Path) -> None:
    """Along a whole build order, with the cut-off question (which changes the grid and puts it back)
    asked before each placement: every component's openness and every robot point's nearest free cell,
    as remembered, equal those read afresh from the grid as it stands. A memory kept past a change of
    the grid would answer for the grid before it."""
    built, column, _ring, gate = _room_with_gate(bundled_build)
    layout = plan_site(built, robots=1)
    access = SiteAccess(built, layout, DEFAULT_ROBOT, AccessConfig(0.1))
    order = [c.guid for c in built if c.guid not in (column.guid, gate.guid)] + [column.guid, gate.guid]
    cx, cy, _ = column.target_pose_world.position_m
    points = [(cx + dx, cy + dy) for dx in (-1.2, 0.0, 0.9) for dy in (-0.8, 0.0, 0.7)]
    moved = 0
    for guid in order:
        before = [access._near_cached(point) for point in points]
        access.cut_off_by(guid, order)
        access.place(guid)
        for other in order:
            afresh = access.slot_accessible(other) and access.target_accessible(other)
            assert access.open_now(other) == afresh, other
        now = [access._near_cached(point) for point in points]
        assert now == [access._free_cell_near(point) for point in points], guid
        moved += now != before
    assert moved, "some placement moves a point's nearest free cell (the memory was cleared and read again)"
