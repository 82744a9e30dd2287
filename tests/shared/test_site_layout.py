"""Site layout on the bundled frame, the two Revit samples, the generated site model and synthetic mixes:
every component lies flat in the yard, nothing overlaps or lies on the building, every slot is reachable
by the robot through aisles it fits in, long and wide elements get rows of their own, the fence leaves a
lane, the depot holds the robots, and the yard is compact (driving distances, measured on a grid)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from component_boxes import box_component
from sample_builds import converted_sample
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra
from scipy.spatial.transform import Rotation
from site_models import build_site_model

from bimbot.services.converter.convert import convert_model
from bimbot.shared.fleet import default_fleet
from bimbot.shared.ifc_input import open_model
from bimbot.shared.manifest import Component, Manifest, read_manifest
from bimbot.shared.occupancy_grid import from_footprints, inflate
from bimbot.shared.robot_description import DEFAULT_ROBOT, Capability
from bimbot.shared.site_layout import INFLATION_MARGIN_M, aisle_width_m, plan_site
from bimbot.shared.site_plan import FENCE_THICKNESS_M, SiteLayout
from bimbot.shared.yard_slot import GROUND_CLEARANCE_M, lying_rotation

GRID_M = 0.2
REACH_MARGIN_M = 0.1  # the robot's approach stays this much inside its reach


# --- the models --------------------------------------------------------------------------------------------


def _component(guid: str, size_m: tuple[float, float, float], at_m: tuple[float, float, float]) -> Component:
    return box_component(guid, size_m, at_m)


def synthetic_mix(count: int = 60, seed: int = 7) -> list[Component]:
    """Beams, columns, long walls, wide slabs and small parts, standing on three storeys of a 30 m block."""
    rng = np.random.default_rng(seed)
    kinds = [(8.0, 0.3, 0.5), (3.0, 0.4, 0.4), (24.0, 4.0, 0.3), (18.0, 11.0, 0.3), (0.5, 0.3, 0.1)]
    components = []
    for number in range(count):
        length, width, height = kinds[number % len(kinds)] * rng.uniform(0.7, 1.0, 3)
        at = (rng.uniform(0, 30 - length), rng.uniform(0, 20 - width), 3.0 * (number % 3))
        components.append(_component(f"synthetic{number:04d}", (length, width, height), at))
    return components


@pytest.fixture(scope="module")
def frame(bundled_build: Path) -> list[Component]:
    return read_manifest(bundled_build).components


def _convert(source: Path, out: Path) -> Manifest:
    return convert_model(open_model(source), source, out)


@pytest.fixture(scope="module")
def hub(samples_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> list[Component]:
    return converted_sample("revit2021_structural_hub.ifc", tmp_path_factory)[1].components


@pytest.fixture(scope="module")
def house(samples_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> list[Component]:
    return converted_sample("revit2021_sample_project.ifc", tmp_path_factory)[1].components


@pytest.fixture(scope="module")
def site_model(tmp_path_factory: pytest.TempPathFactory) -> list[Component]:
    out = tmp_path_factory.mktemp("site_model")
    return _convert(build_site_model().write(out / "site.ifc"), out / "build").components


MODELS = ["frame", "hub", "house", "site_model", "synthetic"]


@pytest.fixture(params=MODELS)
def components(request: pytest.FixtureRequest) -> list[Component]:
    if request.param == "synthetic":
        return synthetic_mix()
    return request.getfixturevalue(request.param)


# --- checks ------------------------------------------------------------------------------------------------


def _site_grid(site: SiteLayout):
    """Slots, the building footprint and the fence on a grid; free where the robot's centre may be."""
    (x0, y0), (x1, y1) = site.fence.min_xy, site.fence.max_xy
    t = FENCE_THICKNESS_M
    boxes = [(*slot.footprint.min_xy, *slot.footprint.max_xy) for slot in site.slots.values()]
    boxes += [(*site.building.min_xy, *site.building.max_xy)]
    boxes += [(*machine.min_xy, *machine.max_xy) for machine in site.machines]  # cranes, pumps, block layers
    boxes += [
        (x0 - t, y0 - t, x1 + t, y0),
        (x0 - t, y1, x1 + t, y1 + t),
        (x0 - t, y0, x0, y1),
        (x1, y0, x1 + t, y1),
    ]
    bounds = site.bounds.grown(1.0)
    grid = from_footprints((*bounds.min_xy, *bounds.max_xy), GRID_M, boxes_xy_m=boxes)
    return grid, ~inflate(grid, DEFAULT_ROBOT.radius_m + INFLATION_MARGIN_M).occupied


def _cell_centres(grid) -> np.ndarray:
    rows, cols = np.indices(grid.shape)
    return grid.cell_to_world(np.stack([rows.ravel(), cols.ravel()], axis=1)).reshape(*grid.shape, 2)


def _gap_to_rect(xy: np.ndarray, rect) -> np.ndarray:
    gap = np.maximum(np.maximum(np.array(rect.min_xy) - xy, xy - np.array(rect.max_xy)), 0.0)
    return np.hypot(gap[..., 0], gap[..., 1])


def driving_distances_m(site: SiteLayout) -> dict[str, float]:
    """Per slot: the shortest drive (8-connected grid, robot inflated) from the middle of the building's
    south edge to a cell within reach of the slot; inf when there is none."""
    grid, free = _site_grid(site)
    index = -np.ones(free.shape, np.int64)
    index[free] = np.arange(free.sum())
    edges = []
    height, width = free.shape
    for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):  # each neighbour pair once
        rows_a, rows_b = slice(0, height - dr), slice(dr, height)
        cols_a, cols_b = (
            (slice(0, width - dc), slice(dc, width)) if dc >= 0 else (slice(-dc, width), slice(0, width + dc))
        )
        both = free[rows_a, cols_a] & free[rows_b, cols_b]
        edges.append((index[rows_a, cols_a][both], index[rows_b, cols_b][both], math.hypot(dr, dc) * GRID_M))
    rows = np.concatenate([e[0] for e in edges])
    cols = np.concatenate([e[1] for e in edges])
    weights = np.concatenate([np.full(len(e[0]), e[2]) for e in edges])
    graph = coo_matrix((weights, (rows, cols)), shape=(int(free.sum()),) * 2).tocsr()
    start_xy = ((site.building.min_xy[0] + site.building.max_xy[0]) / 2, site.building.min_xy[1] - 1.5)
    start = index[tuple(grid.world_to_cell(np.array([start_xy]))[0])]
    assert start >= 0, "the lane south of the building is not free"
    distance = np.full(free.shape, np.inf)
    distance[free] = dijkstra(graph, directed=False, indices=int(start))
    centres = _cell_centres(grid)
    result = {}
    for guid, slot in site.slots.items():
        near = _gap_to_rect(centres, slot.footprint) <= DEFAULT_ROBOT.reach_m - REACH_MARGIN_M
        result[guid] = float(distance[near].min()) if near.any() else math.inf
    return result


def _laid_corners(component: Component, slot) -> np.ndarray:
    low, high = np.array(component.bbox_local.min_m), np.array(component.bbox_local.max_m)
    corners = np.array(
        [[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])]
    )
    return Rotation.from_quat(slot.quat_xyzw).apply(corners) + np.array(slot.position_m)


# --- tests -------------------------------------------------------------------------------------------------


def test_every_component_gets_a_slot_and_no_two_overlap(components: list[Component]) -> None:
    site = plan_site(components, robots=3)
    assert set(site.slots) == {c.guid for c in components}
    rects = np.array([(*s.footprint.min_xy, *s.footprint.max_xy) for s in site.slots.values()])
    apart = (
        (rects[:, None, 2] <= rects[None, :, 0] + 1e-9)
        | (rects[None, :, 2] <= rects[:, None, 0] + 1e-9)
        | (rects[:, None, 3] <= rects[None, :, 1] + 1e-9)
        | (rects[None, :, 3] <= rects[:, None, 1] + 1e-9)
    )
    assert (apart | np.eye(len(rects), dtype=bool)).all()


def test_nothing_lies_on_the_building_and_the_fence_leaves_a_lane_around_all(
    components: list[Component],
) -> None:
    site = plan_site(components, robots=2)
    lane = aisle_width_m()
    inner = site.fence.grown(-lane)
    for area in [*(slot.footprint for slot in site.slots.values()), site.building, site.depot]:
        assert inner.min_xy[0] <= area.min_xy[0] + 1e-9 and area.max_xy[0] <= inner.max_xy[0] + 1e-9
        assert inner.min_xy[1] <= area.min_xy[1] + 1e-9 and area.max_xy[1] <= inner.max_xy[1] + 1e-9
    for slot in site.slots.values():
        assert not slot.footprint.overlaps(site.building)
        assert not slot.footprint.overlaps(site.depot)
    for component in components:  # the building footprint covers the structure
        assert site.building.min_xy[0] <= component.bbox_world.min_m[0]
        assert component.bbox_world.max_m[1] <= site.building.max_xy[1]


def test_components_lie_flat_longest_along_the_rows_inside_their_footprint(
    components: list[Component],
) -> None:
    site = plan_site(components)
    for component in components:
        slot = site.slots[component.guid]
        corners = _laid_corners(component, slot)
        assert corners[:, 2].min() == pytest.approx(GROUND_CLEARANCE_M, abs=1e-9)
        np.testing.assert_allclose(corners[:, :2].min(axis=0), slot.footprint.min_xy, atol=1e-9)
        np.testing.assert_allclose(corners[:, :2].max(axis=0), slot.footprint.max_xy, atol=1e-9)
        extents = corners.max(axis=0) - corners.min(axis=0)
        assert extents[1] >= extents[0] - 1e-9 >= extents[2] - 2e-9  # longest along y, shortest vertical


@pytest.mark.parametrize("fleet", [None, "default"])
def test_the_robot_reaches_every_slot_by_driving_from_the_building(
    components: list[Component], fleet: str | None
) -> None:
    """Also with the default fleet's machines set up around the building (a crane, a pump, a block layer):
    they block no slot, no staging area and not the depot."""
    types = default_fleet().robot_types() if fleet else None
    site = plan_site(components, robots=2, fleet=types)
    distances = driving_distances_m(site)
    unreachable = [guid for guid, distance in distances.items() if not math.isfinite(distance)]
    assert unreachable == []
    grid, free = _site_grid(site)  # and the depot and the staging areas are connected to the same free region
    labels, _ = ndimage.label(free, structure=np.ones((3, 3)))
    start_xy = ((site.building.min_xy[0] + site.building.max_xy[0]) / 2, site.building.min_xy[1] - 1.5)
    region = labels[tuple(grid.world_to_cell(np.array([start_xy]))[0])]
    ground = [start for start, item in zip(site.robot_starts, types or [DEFAULT_ROBOT] * 2, strict=True)
              if item.can(Capability.DRIVE)]  # fmt: skip
    for x, y, _ in ground:
        assert labels[tuple(grid.world_to_cell(np.array([(x, y)]))[0])] == region
    for area in site.staging:
        spot = ((area.min_xy[0] + area.max_xy[0]) / 2, (area.min_xy[1] + area.max_xy[1]) / 2)
        assert labels[tuple(grid.world_to_cell(np.array([spot]))[0])] == region


def test_every_slot_faces_an_aisle_as_wide_as_the_robot_needs(components: list[Component]) -> None:
    site = plan_site(components)
    width = aisle_width_m()
    assert width >= 2 * (DEFAULT_ROBOT.radius_m + INFLATION_MARGIN_M) + 0.5
    for aisle in site.aisles:
        assert aisle.size[0] == pytest.approx(width) and aisle.size[1] == pytest.approx(site.yard.size[1])
    footprints = [slot.footprint for slot in site.slots.values()]
    for slot in site.slots.values():
        (x0, y0), (x1, y1) = slot.footprint.min_xy, slot.footprint.max_xy
        sides = [((x1, y0), (x1 + width, y1)), ((x0 - width, y0), (x0, y1))]
        free_sides = [
            side
            for side in sides
            if not any(_overlap(side, other.min_xy, other.max_xy) for other in footprints)
        ]
        assert free_sides, slot.guid


def _overlap(side, low, high) -> bool:
    (a0, b0), (a1, b1) = side
    return a0 < high[0] - 1e-9 and low[0] < a1 - 1e-9 and b0 < high[1] - 1e-9 and low[1] < b1 - 1e-9


def test_a_row_never_mixes_widths_more_than_twice_apart(components: list[Component]) -> None:
    site = plan_site(components)
    rows = _rows(site)
    for row in rows:
        widths = [slot.footprint.size[0] for slot in row]
        assert max(widths) <= 2.0 * min(widths) + 0.5 + 1e-9, widths


def test_robots_start_in_the_depot_apart_from_each_other(frame: list[Component]) -> None:
    for robots in (1, 3, 8):
        site = plan_site(frame, robots=robots)
        starts = np.array(site.robot_starts)
        assert len(starts) == robots
        radius = DEFAULT_ROBOT.radius_m
        assert np.all(
            (starts[:, 0] - radius >= site.depot.min_xy[0]) & (starts[:, 0] + radius <= site.depot.max_xy[0])
        )
        assert np.all(
            (starts[:, 1] - radius >= site.depot.min_xy[1]) & (starts[:, 1] + radius <= site.depot.max_xy[1])
        )
        gaps = np.linalg.norm(starts[:, None, :2] - starts[None, :, :2], axis=2) + np.eye(robots) * 9
        assert gaps.min() >= 2 * radius
        assert not site.depot.overlaps(site.yard) and not site.depot.overlaps(site.building)


def test_layout_is_deterministic(components: list[Component]) -> None:
    assert plan_site(components, robots=2) == plan_site([c.model_copy() for c in components], robots=2)


@pytest.mark.parametrize(("model", "mean_limit_m"), [("frame", 8.0), ("hub", 40.0), ("house", 25.0)])
def test_the_yard_is_compact_in_driving_distance(model: str, mean_limit_m: float, request) -> None:
    """Before the north–south rows: 11.5 m (frame), 82 m (hub) and 46 m (house) from the building's south
    edge to a slot on average, since rows along x had to be driven round at their ends."""
    components = request.getfixturevalue(model)
    distances = np.array(list(driving_distances_m(plan_site(components, robots=2)).values()))
    assert distances.mean() <= mean_limit_m


def _rows(site: SiteLayout) -> list[list]:
    """Slots grouped by row: slots whose x ranges overlap share a row."""
    rows: list[list] = []
    for slot in sorted(site.slots.values(), key=lambda slot: slot.footprint.min_xy[0]):
        if rows and slot.footprint.min_xy[0] < max(s.footprint.max_xy[0] for s in rows[-1]) - 1e-9:
            rows[-1].append(slot)
        else:
            rows.append([slot])
    return rows


def test_the_components_needed_first_lie_at_the_front_of_their_rows(components: list[Component]) -> None:
    """Needed first = lowest target bottom, manifest order among equals; the front is the north end."""
    site = plan_site(components)
    rank = {
        c.guid: number
        for number, c in enumerate(
            sorted(components, key=lambda c: (round(c.bbox_world.min_m[2], 2), components.index(c)))
        )
    }
    for row in _rows(site):
        front_to_back = sorted(row, key=lambda slot: -slot.footprint.max_xy[1])
        ranks = [rank[slot.guid] for slot in front_to_back]
        assert ranks == sorted(ranks)
    first = site.slots[min(rank, key=rank.get)]  # the very first one: front of a row of the middle pair
    assert first.footprint.max_xy[1] == pytest.approx(site.yard.max_xy[1])
    x = (first.footprint.min_xy[0] + first.footprint.max_xy[0]) / 2
    west = sum(aisle.max_xy[0] <= x for aisle in site.aisles)
    assert abs(west - (len(site.aisles) - west)) <= 1


@pytest.mark.parametrize("extents", [(3.0, 0.1, 0.1), (0.1, 0.1, 3.0), (0.6, 0.6, 0.3), (0.2, 5.0, 1.0)])
def test_lying_rotation_is_proper_and_puts_the_longest_extent_along_x(
    extents: tuple[float, float, float],
) -> None:
    rotation = lying_rotation(extents)
    assert np.linalg.det(rotation) == pytest.approx(1.0)
    laid = np.abs(rotation @ np.array(extents))
    assert laid[0] == max(extents) and laid[2] == min(extents)


def test_a_large_site_is_planned_quickly_enough_for_every_service_start() -> None:
    """10,000 components: every service plans the same site at start-up (counts, not time: it must not
    degrade to one row per component)."""
    components = synthetic_mix(10_000, seed=3)
    site = plan_site(components, robots=4)
    assert len(site.slots) == 10_000
    assert len(site.aisles) < 2_500


def _aisle_index(site: SiteLayout, slot) -> int:
    """The aisle (or -1: a lane at the yard's edge) that ``slot`` is flush with."""
    edge_x = slot.footprint.min_xy[0] if slot.aisle_side < 0 else slot.footprint.max_xy[0]
    for number, aisle in enumerate(site.aisles):
        if min(abs(aisle.min_xy[0] - edge_x), abs(aisle.max_xy[0] - edge_x)) < 1e-6:
            return number
    return -1


def _grid_of(name: str, size_m: tuple[float, float, float], z_m: float) -> list[Component]:
    """300 components of one size on a 2 m grid, 20 by 15."""
    return [_component(f"{name}{n:03d}", size_m, (2.0 * (n % 20), 2.0 * (n // 20), z_m)) for n in range(300)]


@pytest.mark.parametrize("robots", [4, 10])
def test_components_needed_together_lie_at_one_aisle_per_robot(robots: int) -> None:
    """300 footings on a 40 m grid (needed first, all at once) and 300 columns on them: the first
    ``robots`` footings lie at ``robots`` different aisles, near the front (before: eight 44 m rows of
    footings in four aisles, where ten robots met head-on), and the footing rows stay ≥ 8 m deep."""
    footings, columns = _grid_of("footing", (0.6, 0.6, 0.3), 0.0), _grid_of("column", (0.2, 0.2, 3.5), 0.3)
    site = plan_site(footings + columns, robots=robots)
    first = [site.slots[f"footing{n:03d}"] for n in range(robots)]
    aisles = [_aisle_index(site, slot) for slot in first]
    assert len(set(aisles)) == robots, aisles
    assert all(site.yard.max_xy[1] - slot.footprint.min_xy[1] < 1.0 for slot in first)
    deepest = max(site.yard.max_xy[1] - site.slots[f"footing{n:03d}"].footprint.min_xy[1] for n in range(300))
    assert deepest >= 8.0 - 1.0  # spread only while a row stays about 8 m deep (1 m: a footing and its gap)


def test_one_robot_keeps_the_rows_as_deep_as_driving_asks() -> None:
    """With one robot nothing is spread: the footings fill as few rows as the compact yard wants."""
    footings = _grid_of("footing", (0.6, 0.6, 0.3), 0.0)
    one, ten = plan_site(footings, robots=1), plan_site(footings, robots=10)
    assert len(one.aisles) < len(ten.aisles)
