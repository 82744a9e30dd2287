"""The construction site around the building, as in the paper's Fig. 10: a yard, a robot depot and a fence.

Pure and deterministic. Physics plans the site once (:func:`plan_site`) and serves the plan with its site
info (``SiteInfoMsg.layout``); robots (which navigate it), the planner (which checks access in it) and the
observer (which draws it) ask for it instead of planning a copy. The plan's data types live in
:mod:`.site_plan`, free of numpy, so every process can decode the message:

* **building** — the footprint of the target structure (its components' world bounding boxes, grown by a
  margin): where the BIM places it.
* **yard** — south of the building (−y), beyond a driving lane. Every component lies flat on the ground
  (shortest extent vertical, longest along y) in **lay-down rows that run north–south**, towards the
  building. Rows come in back-to-back pairs; between two pairs runs an **aisle** as wide as the robot's
  inflated footprint plus a corridor (:func:`aisle_width_m`), open at both ends: onto the lane along the
  building to the north and the lane inside the fence to the south. Every component is flush with the
  aisle (or the lane) on its side of the pair, so a robot in that aisle reaches it, and the way from the
  building to any slot is the lane, then straight down one aisle.
* **long and wide elements** get rows of their own: a row holds components of one width class (widths
  within a factor of two: a 12 m slab never widens a row of 0.3 m beams), and components longer than the
  yard's row depth go to long rows (all as deep as the longest of them) instead of deepening every row.
* **compact**: the row depth is chosen among a few candidates to minimise the mean driving distance
  from the building's south edge (lane + along the lane + down the aisle); the components needed first
  (lowest target first — footings, then columns, then beams and slabs: the manifest's components sorted by
  the bottom of their target, manifest order among equals) lie at the front of the rows, nearest the
  building, and the rows holding them nearest the building's centre line.
* **depot** — west of the yard (−x), beyond a lane: the robots' start poses one behind the other, facing
  +x, the first on the line of the lane between the building and the yard (the site's main street).
* **machines that stand fixed** — cranes, concrete pumps, block layers set up around the building, clear of
  every lane, the yard and the depot (a crane where its hook covers the building, then the yard, with a
  staging area beside it; a boom machine where its boom covers the most of its work): :mod:`.site_machines`.
* **fence** — a rectangle around all of it with a driving lane inside (site hoarding), which also gives
  the robots' lasers something to localise against on an otherwise empty site.

Nothing overlaps and nothing lies on the building footprint. Frames: the simulation world frame of
:mod:`bimbot.shared.manifest` (metres, Z up).
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from itertools import groupby, zip_longest

import numpy as np

from .manifest import Component
from .robot_description import DEFAULT_ROBOT, Capability, RobotDescription
from .site_laydown import Crane, crane_only, lay_down
from .site_machines import keep_clear, plan_machines
from .site_plan import (  # the plan's data types; physics serves a plan with its site info
    BUILDING_MARGIN_M,
    Rect,
    SiteLayout,
    YardSlot,
)
from .site_setups import plan_setups
from .yard_slot import laid_slot

LANE_M = 3.0  # driving lane between the building footprint and the yard, beside the depot, inside the fence
INFLATION_MARGIN_M = 0.15  # the robots' map inflates obstacles by their radius plus this
AISLE_CORRIDOR_M = 0.6  # free corridor left in an aisle between the two inflated rows
GAP_M = 0.4  # between components in a row, and between the two rows of a pair
MIN_ROW_DEPTH_M = 4.0
MIN_YARD_WIDTH_M = 12.0  # a small model's site keeps lanes long enough for robots to pass and localise
MAX_DEPTH_CANDIDATES = 12
WIDTH_CLASS_BASE_M = 0.5  # width classes: ≤ 0.5 m, ≤ 1 m, ≤ 2 m, ≤ 4 m, …
ROBOT_SPACING_M = 1.6
SPREAD_MIN_ROW_M = 8.0  # a kind is spread over more rows (one aisle per robot) only while rows stay this deep


def aisle_width_m(robot: RobotDescription = DEFAULT_ROBOT) -> float:
    """An aisle fits the robot inflated on both sides (radius + map margin) and a corridor between."""
    return 2.0 * (robot.radius_m + INFLATION_MARGIN_M) + AISLE_CORRIDOR_M


def laid_size_m(component: Component) -> tuple[float, float, float]:
    """(x, y, z) extents of ``component`` lying in the yard: middle, longest and shortest extent."""
    extents = sorted(np.array(component.bbox_local.max_m) - np.array(component.bbox_local.min_m))
    return (float(extents[1]), float(extents[2]), float(extents[0]))


def building_footprint(components: Sequence[Component]) -> Rect:
    low = np.min([c.bbox_world.min_m for c in components], axis=0)
    high = np.max([c.bbox_world.max_m for c in components], axis=0)
    return Rect((float(low[0]), float(low[1])), (float(high[0]), float(high[1]))).grown(BUILDING_MARGIN_M)


def width_class(width_m: float) -> int:
    """0 for ≤ 0.5 m, 1 for ≤ 1 m, 2 for ≤ 2 m, …: components of one class share rows."""
    return max(0, math.ceil(math.log2(max(width_m, 1e-9) / WIDTH_CLASS_BASE_M) - 1e-9))


@dataclass
class _Row:
    """One lay-down row: components stacked from its front (north) end, flush with its aisle side."""

    kind: tuple[bool, int]  # (long row?, width class)
    limit_m: float
    items: list[int]  # component indices, front first
    first_rank: int = 0  # priority rank of its first component
    filled_m: float = 0.0
    width_m: float = 0.0


def plan_site(
    components: Sequence[Component],
    robots: int = 1,
    *,
    robot: RobotDescription = DEFAULT_ROBOT,
    fleet: Sequence[RobotDescription] | None = None,
) -> SiteLayout:
    """The site for ``components`` (in manifest order) and ``robots`` robots of type ``robot``, or the
    robots of ``fleet`` (one description per robot, in robot id order; the machines that stand fixed set up
    around the building, see :mod:`.site_machines`; the loads only a crane lifts lie beside it, see
    :mod:`.site_laydown`, when each finds a spot there, else every component lies in the yard)."""
    if not components:
        raise ValueError("a site needs at least one component")
    heavy = set(crane_only(components, fleet)) if fleet is not None else set()
    for _ in range(2):  # a load without a spot beside its crane goes back to the yard, which moves the crane
        if not heavy or len(heavy) == len(components):
            break
        in_yard = [component for index, component in enumerate(components) if index not in heavy]
        site = _plan_site(components, in_yard, robots, robot, fleet)
        laid, missing = _with_laydown(site, [components[index] for index in sorted(heavy)], fleet or ())
        if not missing:
            return laid
        heavy -= {index for index in heavy if components[index].guid in missing}
    return _plan_site(components, components, robots, robot, fleet)


def _plan_site(
    components: Sequence[Component],
    in_yard: Sequence[Component],
    robots: int,
    robot: RobotDescription,
    fleet: Sequence[RobotDescription] | None,
) -> SiteLayout:
    """The site for the building of ``components`` with ``in_yard`` (a subset) laid in the yard."""
    if fleet is not None:
        ground = [item for item in fleet if item.can(Capability.DRIVE)]
        robot = max(ground, key=lambda item: item.radius_m, default=robot)
        robots = len(ground)
    building = building_footprint(components)
    sizes = np.array([laid_size_m(component)[:2] for component in in_yard])
    bottoms = [round(component.bbox_world.min_m[2], 2) for component in in_yard]
    priority = sorted(range(len(in_yard)), key=lambda index: (bottoms[index], index))
    aisle_m = aisle_width_m(robot)
    lane_m = max(LANE_M, aisle_m)
    centre_x = (building.min_xy[0] + building.max_xy[0]) / 2.0
    front_y = building.min_xy[1] - lane_m  # the yard's north edge
    best: tuple[float, float, list[_Row]] | None = None
    for depth_m in _depth_candidates(sizes, aisle_m):
        rows = _fill_rows(sizes, priority, depth_m, spread_rows=2 * max(1, robots))
        cost = _mean_drive_m(rows, sizes, aisle_m)
        if best is None or cost < best[0] - 1e-9:
            best = (cost, depth_m, rows)
    assert best is not None
    rows = best[2]
    slots, aisles, yard = _place_rows(
        in_yard, rows, sizes, aisle_m=aisle_m, centre_x=centre_x, front_y=front_y
    )
    depot_width = 2.0 * ROBOT_SPACING_M
    first_y = front_y + lane_m / 2.0  # the first robot on the lane between the building and the yard
    depot = Rect(
        (
            yard.min_xy[0] - lane_m - depot_width,
            first_y + ROBOT_SPACING_M / 2.0 - max(1, robots) * ROBOT_SPACING_M,
        ),
        (yard.min_xy[0] - lane_m, first_y + ROBOT_SPACING_M / 2.0),
    )
    depot_starts = [
        (depot.min_xy[0] + depot_width / 2.0, first_y - i * ROBOT_SPACING_M, 0.0) for i in range(robots)
    ]
    union = Rect(
        (min(building.min_xy[0], depot.min_xy[0]), min(yard.min_xy[1], depot.min_xy[1])),
        (max(building.max_xy[0], yard.max_xy[0]), building.max_xy[1]),
    )
    types = list(fleet) if fleet is not None else [robot] * robots
    machines = [item for item in types if not item.can(Capability.DRIVE)]
    mains = plan_machines(machines, components, building=building, yard=yard, depot=depot, lane_m=lane_m)
    every = plan_setups(machines, mains, components, building=building, yard=yard, depot=depot, lane_m=lane_m)
    setups = iter(mains)
    starts: list[tuple[float, float, float]] = []
    staging: list[Rect] = []
    bases: list[Rect] = []
    for item in types:
        if item.can(Capability.DRIVE):
            starts.append(depot_starts.pop(0))
            continue
        setup = next(setups)
        starts.append(setup.pose)
        bases.append(setup.base)
        if setup.staging is not None:
            staging.append(setup.staging)
        for rect in (*setup.rects, *(extra.base for extra in every[len(bases) - 1][1:])):
            union = Rect(
                (min(union.min_xy[0], rect.min_xy[0]), min(union.min_xy[1], rect.min_xy[1])),
                (max(union.max_xy[0], rect.max_xy[0]), max(union.max_xy[1], rect.max_xy[1])),
            )
    return SiteLayout(
        building,
        yard,
        depot,
        union.grown(lane_m),
        slots,
        tuple(starts),
        aisles,
        tuple(staging),
        tuple(bases),
        setups=tuple(tuple(setup.pose for setup in machine_setups) for machine_setups in every),
    )


def _depth_candidates(sizes: np.ndarray, aisle_m: float) -> list[float]:
    """Row depths to try, about a quarter apart (at most ``MAX_DEPTH_CANDIDATES``): from the typical
    component's length up to the longest one, or to twice the side of a square yard when there are many."""
    lengths = sizes[:, 1]
    square_side = math.sqrt(float(np.sum((sizes[:, 0] + aisle_m / 2.0) * (lengths + GAP_M))))
    last = max(float(lengths.max()), 2.0 * square_side, MIN_ROW_DEPTH_M)
    first = max(MIN_ROW_DEPTH_M, float(np.median(lengths)))
    if first >= last:
        return [last]
    steps = min(MAX_DEPTH_CANDIDATES - 1, math.ceil(math.log(last / first) / math.log(1.25)))
    return [float(depth) for depth in np.geomspace(first, last, steps + 1)]


def _fill_rows(
    sizes: np.ndarray, priority: Sequence[int], depth_m: float, spread_rows: int = 1
) -> list[_Row]:
    """Components in rows of one kind each (long or not, width class); in priority order, each goes to
    the least filled row of its kind that has room, so the first ones needed lie at the row fronts.

    A kind gets at least ``spread_rows`` rows (two per robot: one aisle each, see :func:`_ordered_pairs`)
    while its rows stay ``SPREAD_MIN_ROW_M`` deep: components of one kind are needed at about the same
    time, and robots fetching them from one deep aisle that fits a single robot meet head-on in it (on a
    988-component site with ten robots, the 324 footings filled eight 44 m rows and the robots jammed)."""
    longest = float(sizes[:, 1].max())
    kinds: dict[tuple[bool, int], list[int]] = {}
    rank = {index: number for number, index in enumerate(priority)}
    for index in priority:
        width, length = sizes[index]
        kinds.setdefault((bool(length > depth_m), width_class(width)), []).append(index)
    rows: list[_Row] = []
    for kind in sorted(kinds):
        members = kinds[kind]
        limit = longest if kind[0] else depth_m
        total = sum(float(sizes[i, 1]) + GAP_M for i in members)
        start = len(rows)
        spread = min(spread_rows, len(members), math.ceil(total / SPREAD_MIN_ROW_M))
        count = max(1, math.ceil(total / (limit + GAP_M)), spread)
        rows += [_Row(kind, limit, []) for _ in range(count)]
        heap = [(0.0, number) for number in range(start, len(rows))]
        for index in members:
            width, length = (float(v) for v in sizes[index])
            filled, number = heap[0]
            if filled + length > limit + 1e-9:  # the least filled row is full: so are all the others
                number = len(rows)
                rows.append(_Row(kind, limit, []))
                filled = 0.0
            else:
                heapq.heappop(heap)
            row = rows[number]
            if not row.items:
                row.first_rank = rank[index]
            row.items.append(index)
            row.filled_m = filled + length + GAP_M
            row.width_m = max(row.width_m, width)
            heapq.heappush(heap, (row.filled_m, number))
    return [row for row in rows if row.items]


def _ordered_pairs(rows: list[_Row]) -> list[list[_Row]]:
    """Rows sorted by the first component they hold, paired back to back, the first pair in the middle,
    the next ones alternately east and west of it (west to east).

    Within a run of rows of one kind, row ``i`` pairs with row ``i + ⌈n/2⌉``: consecutive components go
    to consecutive rows (least filled first), so the ones needed together sit at different aisles."""
    rows = sorted(rows, key=lambda row: row.first_rank)
    rows = [row for _, run in groupby(rows, key=lambda row: row.kind) for row in _interleaved(list(run))]
    pairs = [rows[i : i + 2] for i in range(0, len(rows), 2)]
    west: list[list[_Row]] = []
    east: list[list[_Row]] = []
    for number, pair in enumerate(pairs):
        (east if number % 2 == 0 else west).append(pair)
    return [*reversed(west), *east]


def _interleaved(run: list[_Row]) -> list[_Row]:
    """``[0, h, 1, h + 1, …]`` with ``h = ⌈n/2⌉``: paired two by two, row i shares an aisle with row i + h."""
    half = math.ceil(len(run) / 2)
    return [row for pair in zip_longest(run[:half], run[half:]) for row in pair if row is not None]


def _pair_width_m(pair: list[_Row]) -> float:
    return sum(row.width_m for row in pair) + GAP_M * (len(pair) - 1)


def _mean_drive_m(rows: list[_Row], sizes: np.ndarray, aisle_m: float) -> float:
    """Mean distance from the middle of the yard's front to each component: across, then down its row."""
    pairs = _ordered_pairs(rows)
    total_width = sum(_pair_width_m(pair) for pair in pairs) + aisle_m * (len(pairs) - 1)
    x = -total_width / 2.0
    distance = 0.0
    for pair in pairs:
        for side, row in enumerate(pair):
            aisle_x = x - aisle_m / 2.0 if side == 0 else x + _pair_width_m(pair) + aisle_m / 2.0
            along = 0.0
            for index in row.items:
                distance += abs(aisle_x) + along + float(sizes[index, 1]) / 2.0
                along += float(sizes[index, 1]) + GAP_M
        x += _pair_width_m(pair) + aisle_m
    return distance / len(sizes)


def _place_rows(
    components: Sequence[Component],
    rows: list[_Row],
    sizes: np.ndarray,
    *,
    aisle_m: float,
    centre_x: float,
    front_y: float,
) -> tuple[dict[str, YardSlot], tuple[Rect, ...], Rect]:
    """Slots of every component, the aisles between the pairs and the yard, centred on ``centre_x``."""
    pairs = _ordered_pairs(rows)
    total_width = sum(_pair_width_m(pair) for pair in pairs) + aisle_m * (len(pairs) - 1)
    depth = max(row.filled_m - GAP_M for row in rows)
    half = max(total_width, MIN_YARD_WIDTH_M) / 2.0
    yard = Rect((centre_x - half, front_y - depth), (centre_x + half, front_y))
    placed: dict[int, YardSlot] = {}
    aisles: list[Rect] = []
    x = centre_x - total_width / 2.0
    for number, pair in enumerate(pairs):
        right_edge = x + _pair_width_m(pair)
        for side, row in enumerate(pair):
            y = front_y
            for index in row.items:
                width, length = (float(v) for v in sizes[index])
                min_x = x if side == 0 else right_edge - width  # flush with this row's aisle
                slot = laid_slot(components[index], min_x, y - length)
                placed[index] = replace(slot, aisle_side=-1 if side == 0 else 1)
                y -= length + GAP_M
        if number < len(pairs) - 1:
            aisles.append(Rect((right_edge, yard.min_xy[1]), (right_edge + aisle_m, front_y)))
        x = right_edge + aisle_m
    slots = {placed[index].guid: placed[index] for index in range(len(components))}
    return slots, tuple(aisles), yard


def _with_laydown(
    site: SiteLayout, heavy: Sequence[Component], fleet: Sequence[RobotDescription]
) -> tuple[SiteLayout, set[str]]:
    """``site`` (planned without ``heavy`` in its yard) with ``heavy`` laid down beside the cranes
    (:mod:`.site_laydown`) and the fence around them, and the GlobalIds of those that found no spot."""
    fixed = [
        (item, pose)
        for item, pose in zip(fleet, site.robot_starts, strict=True)
        if not item.can(Capability.DRIVE)
    ]
    cranes = [Crane(item, pose) for item, pose in fixed if item.can(Capability.HOOK_LIFT)]
    lane_m = lane_for(fleet)
    blocked = [
        *keep_clear(site.building, site.yard, site.depot, lane_m),
        *(rect.grown(lane_m) for rect in (*site.machines, *site.staging)),
    ]
    slots = lay_down(heavy, cranes, blocked)
    fence = site.fence
    for slot in slots.values():
        grown = slot.footprint.grown(lane_m)
        fence = Rect(
            (min(fence.min_xy[0], grown.min_xy[0]), min(fence.min_xy[1], grown.min_xy[1])),
            (max(fence.max_xy[0], grown.max_xy[0]), max(fence.max_xy[1], grown.max_xy[1])),
        )
    missing = {component.guid for component in heavy if component.guid not in slots}
    return replace(site, slots={**site.slots, **slots}, fence=fence), missing


def lane_for(fleet: Sequence[RobotDescription]) -> float:
    """The site's driving lane for ``fleet`` (one description per robot): wide enough for its largest ground
    robot's aisle, :data:`LANE_M` at least."""
    ground = [item for item in fleet if item.can(Capability.DRIVE)]
    return max(LANE_M, aisle_width_m(max(ground, key=lambda item: item.radius_m, default=DEFAULT_ROBOT)))
