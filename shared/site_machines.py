"""Where the machines that stand fixed are set up: cranes, concrete pumps, block layers (pure, part of the
site plan).

Why: a machine that never travels reaches only what its set-up position allows, so the position decides
what it can build. The rule, for each machine in robot id order, hook-lifting machines first:

* **candidates** — eight positions on a ring around the building, a lane (``lane_m``) clear of it: the
  middle of the east, north, west and south sides, then the north-east, north-west, south-west and
  south-east corners (a tie goes to the earlier one). A machine faces the building (at a corner: its east or
  west side), a crane with its jib at slew 0 (+x), a truck-mounted boom with its working side (+y), the
  truck parked alongside; so it stands square to the site and its set-up rectangle (``length_m`` ×
  ``width_m``) is the one the site plan records (``SiteLayout.machines``) and its URDF fills;
* **clear of every ground-robot path** — a candidate is taken only when the machine's base (and a crane's
  staging area) keeps a lane clear of the building, the yard (so the lanes at its edges stay), the depot,
  the main street between the building and the yard, and every machine or staging area set up before it;
  a candidate on the building's lane side of the yard, the depot or the main street is dropped, and one
  that meets a machine or staging area set up before moves out along its direction (``PUSH_STEP_M`` at a
  time) until it is clear;
* a **hook-lifting** machine (a tower crane) takes the candidate that minimises the farthest point of the
  building from its mast — the largest hook radius a placement asks of it, so its load chart lifts the
  most there — then the farthest point of the building and of the yard (a yard larger than its chart's
  radius is served through its staging area, where ground robots hand loads off); it gets a staging area
  beside it (:mod:`.site_cranes`);
* a **boom** machine (a pump, a block layer) takes the candidate whose boom covers (``reach_m`` from its
  base to every corner of a component's footprint) the most components of the method it works (pour: cast
  in place; lay: laid), then the most components of any method, then the one nearest the building's far
  side (the smallest farthest-corner distance);
* a **further crane** (a site that erects two or more for a building one jib does not cover) stands where
  it hooks the most lifted parts no crane set up before it hooks (the hook over the centre of a part's
  target, within the radius its chart lifts the part's mass to), then farthest from the cranes set up
  before it (their jibs overlap the least), among the eight and the positions along each side every
  ``CRANE_SIDE_STEP_M``; where it would hook none of those parts, by the first crane's rule. (A second
  crane used to stand behind the first and hook what the first hooked.)

Deterministic: the same components and fleet give the same positions.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .construction_methods import ConstructionMethod
from .manifest import Component
from .robot_description import Capability, RobotDescription
from .site_cranes import staging_area
from .site_plan import Rect
from .work_methods import WORK_METHOD

CRANE_SIDE_STEP_M = 4.0  # a further crane's candidates along each side of the building, this far apart
PUSH_STEP_M = 0.5  # a candidate that is not clear moves this far out at a time…
MAX_PUSH_M = 150.0  # …up to this far (then the direction is given up)

_LIFTED = frozenset({ConstructionMethod.LIFTED, ConstructionMethod.PANELISED})
# (x, y) direction from the building's centre, in candidate order: sides first, then corners
_DIRECTIONS = ((1, 0), (0, 1), (-1, 0), (0, -1), (1, 1), (-1, 1), (-1, -1), (1, -1))


@dataclass(frozen=True)
class Setup:
    """A machine's set-up: its pose (x, y, yaw), the rectangle its base covers and its staging area."""

    pose: tuple[float, float, float]
    base: Rect
    staging: Rect | None = None

    @property
    def rects(self) -> tuple[Rect, ...]:
        return (self.base,) if self.staging is None else (self.base, self.staging)


def machine_yaw(machine: RobotDescription, heading_rad: float) -> float:
    """The yaw of a machine facing ``heading_rad``: a crane's jib along it, a truck's working side (+y)."""
    return heading_rad if machine.can(Capability.HOOK_LIFT) else heading_rad - math.pi / 2.0


def base_rect(machine: RobotDescription, pose: tuple[float, float, float]) -> Rect:
    """The axis-aligned rectangle around the machine's ``length_m`` × ``width_m`` footprint at ``pose``
    (the footprint itself at the site plan's yaws, multiples of a quarter turn)."""
    x, y, yaw = pose
    c, s = abs(math.cos(yaw)), abs(math.sin(yaw))
    half_x = (machine.length_m * c + machine.width_m * s) / 2.0
    half_y = (machine.length_m * s + machine.width_m * c) / 2.0
    return Rect((x - half_x, y - half_y), (x + half_x, y + half_y))


def candidate(
    building: Rect,
    machine: RobotDescription,
    lane_m: float,
    direction: tuple[int, int],
    extra_m: float = 0.0,
    *,
    along_m: float = 0.0,
    turned: bool = False,
) -> Setup:
    """The machine's set-up beside ``building`` in ``direction`` (a side: ``(1, 0)`` east…, a corner:
    ``(1, 1)`` north-east…), a lane and ``extra_m`` clear of it, facing it; on a side, moved ``along_m``
    from its middle along it; when ``turned``, a quarter turn about itself (a truck square to the side
    instead of alongside it: its boom slews round)."""
    (x0, y0), (x1, y1) = building.min_xy, building.max_xy
    dx, dy = direction
    yaw = machine_yaw(machine, math.atan2(-dy, 0.0) if dx == 0 else math.atan2(0.0, -dx))
    if turned:
        yaw = math.remainder(yaw + math.pi / 2.0, math.tau)
    half = base_rect(machine, (0.0, 0.0, yaw)).max_xy
    gap_x, gap_y = lane_m + half[0] + extra_m, lane_m + half[1] + extra_m
    x = (x0 + x1) / 2.0 + along_m if dx == 0 else (x1 + gap_x if dx > 0 else x0 - gap_x)
    y = (y0 + y1) / 2.0 + along_m if dy == 0 else (y1 + gap_y if dy > 0 else y0 - gap_y)
    pose = (x, y, yaw)
    staging = staging_area(pose, machine) if machine.can(Capability.HOOK_LIFT) else None
    return Setup(pose, base_rect(machine, pose), staging)


def clear_candidates(
    building: Rect,
    machine: RobotDescription,
    lane_m: float,
    fixed: Sequence[Rect],
    taken: Sequence[Rect],
    *,
    along_sides: bool = False,
) -> list[Setup]:
    """Per direction (in candidate order), the set-up :func:`pushed_clear` finds; with ``along_sides`` also
    from the positions along each side every ``CRANE_SIDE_STEP_M`` (after the eight)."""
    places = [(direction, 0.0) for direction in _DIRECTIONS]
    if along_sides:
        places += [
            (direction, along)
            for direction in _DIRECTIONS[:4]
            for along in side_offsets(building, direction, CRANE_SIDE_STEP_M)
        ]
    found = [
        pushed_clear(building, machine, lane_m, direction, fixed=fixed, blocked=taken, along_m=along_m)
        for direction, along_m in places
    ]
    return [setup for setup in found if setup is not None]


def pushed_clear(
    building: Rect,
    machine: RobotDescription,
    lane_m: float,
    direction: tuple[int, int],
    *,
    fixed: Sequence[Rect],
    blocked: Sequence[Rect],
    along_m: float = 0.0,
    turned: bool = False,
) -> Setup | None:
    """The nearest :func:`candidate` out along ``direction`` whose base (and staging area) overlaps none of
    ``fixed`` and ``blocked``; None when the first one meets ``fixed`` (over the yard, the depot or the
    main street: not pushed across them) or none within ``MAX_PUSH_M`` is clear."""
    first = candidate(building, machine, lane_m, direction, along_m=along_m, turned=turned)
    if any(rect.overlaps(other) for rect in first.rects for other in fixed):
        return None
    everything = [*fixed, *blocked]
    for step in range(int(MAX_PUSH_M / PUSH_STEP_M) + 1):
        extra_m = step * PUSH_STEP_M
        setup = candidate(building, machine, lane_m, direction, extra_m, along_m=along_m, turned=turned)
        if not any(rect.overlaps(other) for rect in setup.rects for other in everything):
            return setup
    return None


def side_offsets(building: Rect, direction: tuple[int, int], step_m: float) -> list[float]:
    """Offsets from the middle of the side in ``direction``, ``step_m`` apart within it, each distance
    east/north first (not 0: the middle is a candidate of its own)."""
    half_m = building.size[0 if direction[1] else 1] / 2.0
    count = int(half_m // step_m)
    return [sign * number * step_m for number in range(1, count + 1) for sign in (1.0, -1.0)]


def keep_clear(building: Rect, yard: Rect, depot: Rect, lane_m: float) -> list[Rect]:
    """What no machine may stand on: the building, the yard and the depot with a lane around each, and the
    main street between the building and the yard, from the depot's far side to the site's east end."""
    street = Rect(
        (depot.min_xy[0] - lane_m, yard.max_xy[1]),
        (max(building.max_xy[0], yard.max_xy[0]) + lane_m, building.min_xy[1]),
    )
    return [building.grown(lane_m), yard.grown(lane_m), depot.grown(lane_m), street]


def farthest_m(xy: tuple[float, float], *rects: Rect) -> float:
    """The distance from ``xy`` to the farthest point of ``rects`` (one of their corners)."""
    return max(
        math.hypot(x - xy[0], y - xy[1])
        for rect in rects
        for x in (rect.min_xy[0], rect.max_xy[0])
        for y in (rect.min_xy[1], rect.max_xy[1])
    )


def plan_machines(
    machines: Sequence[RobotDescription],
    components: Sequence[Component],
    *,
    building: Rect,
    yard: Rect,
    depot: Rect,
    lane_m: float,
) -> list[Setup]:
    """The set-up of each of ``machines`` (in their order), by the rule of the module docstring."""
    fixed = keep_clear(building, yard, depot, lane_m)
    taken: list[Rect] = []
    corners = footprint_corners(components)
    methods = [component.method for component in components]
    order = sorted(range(len(machines)), key=lambda i: (not machines[i].can(Capability.HOOK_LIFT), i))
    setups: dict[int, Setup] = {}
    hooked: np.ndarray | None = None  # per component: a crane set up so far hooks it (None: no crane yet)
    masts: list[tuple[float, float]] = []  # of the cranes set up so far
    for index in order:
        machine = machines[index]
        lifts = machine.crane is not None and machine.can(Capability.HOOK_LIFT)
        reach = HookReach.of(machine, components) if lifts else None
        free = clear_candidates(building, machine, lane_m, fixed, taken) or [
            candidate(building, machine, lane_m, _DIRECTIONS[0], MAX_PUSH_M)  # never on a 150 m wide site
        ]
        setups[index] = min(free, key=lambda setup: _cost(machine, setup, (building, yard), corners, methods))
        if reach is not None and hooked is not None:  # a crane after the first
            along = clear_candidates(building, machine, lane_m, fixed, taken, along_sides=True)
            setups[index] = _further_crane(reach, ~hooked, masts, along) or setups[index]
        if reach is not None:
            masts.append(setups[index].pose[:2])
            reached = reach.hooked(setups[index].pose[:2])
            hooked = reached if hooked is None else hooked | reached
        taken += [rect.grown(lane_m) for rect in setups[index].rects]
    return [setups[index] for index in range(len(machines))]


def _further_crane(
    reach: HookReach, left: np.ndarray, masts: Sequence[tuple[float, float]], free: Sequence[Setup]
) -> Setup | None:
    """The set-up among ``free`` that hooks the most of the parts ``left`` (not hooked by a crane before
    it), then the farthest from the ``masts`` of those; None when none hooks any of them."""
    best: tuple[int, float, int] | None = None
    for number, setup in enumerate(free):
        new = int((reach.hooked(setup.pose[:2]) & left).sum())
        apart_m = min(math.dist(setup.pose[:2], mast) for mast in masts)
        key = (-new, -round(apart_m, 6), number)
        if new and (best is None or key < best):
            best = key
    return None if best is None else free[best[2]]


@dataclass(frozen=True)
class HookReach:
    """Where a crane type hooks each component: the centre of its target's footprint and the radius its
    chart lifts its mass to (-1 for a part it does not lift: built in place, or too heavy)."""

    centres_xy_m: np.ndarray  # (n, 2)
    radius_m: np.ndarray  # (n,)
    min_radius_m: float

    @classmethod
    def of(cls, crane: RobotDescription, components: Sequence[Component]) -> HookReach:
        chart = crane.crane
        assert chart is not None
        low = np.array([component.bbox_world.min_m[:2] for component in components]).reshape(-1, 2)
        high = np.array([component.bbox_world.max_m[:2] for component in components]).reshape(-1, 2)
        radius_m = np.array(
            [
                chart.radius_for(component.mass_kg)
                if component.method in _LIFTED and component.mass_kg <= crane.payload_kg
                else -1.0
                for component in components
            ]
        )
        return cls((low + high) / 2.0, radius_m, chart.min_radius_m)

    def hooked(self, mast_xy: Sequence[float]) -> np.ndarray:
        """Per component: the crane at ``mast_xy`` hooks it where it goes."""
        distance_m = np.hypot(*(self.centres_xy_m - np.asarray(mast_xy, float)[:2]).T)
        return (distance_m >= self.min_radius_m - 1e-9) & (distance_m <= self.radius_m + 1e-9)


def _cost(
    machine: RobotDescription,
    setup: Setup,
    site: tuple[Rect, Rect],
    corners: np.ndarray,
    methods: Sequence[ConstructionMethod],
) -> tuple[float, ...]:
    """Smaller is better (``min`` keeps the first of equals: candidate order breaks ties); ``site``: the
    building and the yard."""
    building, yard = site
    xy = setup.pose[:2]
    if machine.can(Capability.HOOK_LIFT):
        return (round(farthest_m(xy, building), 6), round(farthest_m(xy, building, yard), 6))
    covered = covered_by_boom(machine, xy, corners)
    own = {method for capability, method in WORK_METHOD.items() if machine.can(capability)}
    mine = sum(1 for hit, method in zip(covered, methods, strict=True) if hit and method in own)
    return (-float(mine), -float(covered.sum()), round(farthest_m(xy, building), 6))


def covered_by_boom(machine: RobotDescription, base_xy: Sequence[float], corners: np.ndarray) -> np.ndarray:
    """Per component (``corners``: ``(n, 4, 2)``), whether the boom reaches every corner from ``base_xy``."""
    if len(corners) == 0:
        return np.zeros(0, dtype=bool)
    far = np.hypot(*(corners - np.asarray(base_xy, float)[:2]).transpose(2, 0, 1)).max(axis=1)
    return far <= machine.reach_m + 1e-9


def footprint_corners(components: Sequence[Component]) -> np.ndarray:
    """The four corners of each component's target box seen from above, ``(n, 4, 2)``."""
    if not components:
        return np.zeros((0, 4, 2))
    low = np.array([component.bbox_world.min_m[:2] for component in components])
    high = np.array([component.bbox_world.max_m[:2] for component in components])
    return np.stack(
        [low, np.stack([high[:, 0], low[:, 1]], axis=1), high, np.stack([low[:, 0], high[:, 1]], axis=1)],
        axis=1,
    )
