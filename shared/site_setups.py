"""Where a truck-mounted machine may set up besides its main position: its set-up positions (pure, part of
the site plan).

Why: a boom pump or a block layer on a real site does not pour or lay everything from one spot. For a
pour or a wall its boom cannot reach, it stows its boom and outriggers, drives on site to another set-up
point and sets up again. The site plan gives each machine that may ``relocate`` a set of set-up positions;
the planner, ``bimbot fleet check`` and the machine itself count a component within reach when the boom
covers it from any of them.

The rule, for each machine that relocates (robot id order), after every machine's main set-up
(:mod:`.site_machines`) is chosen:

* **candidates** — the eight positions around the building of :mod:`.site_machines`, and positions along
  each side every ``SIDE_STEP_M`` (the middle of a side shifted along it), each facing the building a lane
  clear of it, the truck alongside the side, then the same with the truck square to the side (narrower
  along it: it fits between two machines where a truck alongside does not); a candidate over the yard,
  the depot or the main street is dropped, one that meets another machine's set-up (main or extra) or a
  crane's staging area moves out along its direction until it keeps a lane from them (its own set-ups may
  overlap: it stands at one at a time);
* **a piling rig** also over the building's own ground — piles are the first work on a site, driven into
  open ground before anything stands there, so the rig tracks in to them: the centres of a grid over the
  building's rectangle, its cells no wider than the rig's reach (every pile in a cell lies within reach of
  its centre), that meet no other machine's set-up;
* **greedy cover** — the components of its method (pour: cast in place; lay: laid; pile: driven) that some
  candidate's boom covers and its main set-up does not are covered by adding, one at a time, the candidate
  that covers the most of those still uncovered (then the one nearest its main set-up, then candidate
  order), until each is covered by some set-up. A component no candidate covers stays out of reach (its
  reason names the nearest set-up).

Deterministic: the same components and fleet give the same set-ups. A machine that does not relocate has
its main set-up only.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .manifest import Component
from .robot_description import Capability, RobotDescription
from .site_machines import (
    Setup,
    base_rect,
    covered_by_boom,
    footprint_corners,
    keep_clear,
    machine_yaw,
    pushed_clear,
    side_offsets,
)
from .site_plan import Rect
from .work_methods import WORK_METHOD

SIDE_STEP_M = 2.0  # candidates along each side of the building, this far apart
_SIDES = ((1, 0), (0, 1), (-1, 0), (0, -1))
_CORNERS = ((1, 1), (-1, 1), (-1, -1), (1, -1))


def setup_candidates(
    building: Rect, machine: RobotDescription, lane_m: float, fixed: Sequence[Rect], blocked: Sequence[Rect]
) -> list[Setup]:
    """The candidates of the module docstring, in order: sides' middles, corners, then along the sides."""
    places: list[tuple[tuple[int, int], float, bool]] = [
        (direction, 0.0, False) for direction in (*_SIDES, *_CORNERS)
    ]
    for turned in (False, True):
        for direction in _SIDES:
            offsets = side_offsets(building, direction, SIDE_STEP_M)
            places += [(direction, offset, turned) for offset in ([0.0] if turned else []) + offsets]
    found = [
        pushed_clear(
            building, machine, lane_m, direction, fixed=fixed, blocked=blocked, along_m=along_m, turned=turned
        )
        for direction, along_m, turned in places
    ]
    return [setup for setup in found if setup is not None]


def inside_candidates(building: Rect, machine: RobotDescription, blocked: Sequence[Rect]) -> list[Setup]:
    """A piling rig's candidates over the building's own ground (see the module): the centres of a grid
    over ``building`` whose cells are no wider than its reach, clear of ``blocked``."""
    (x0, y0), (x1, y1) = building.min_xy, building.max_xy
    columns = max(1, math.ceil((x1 - x0) / machine.reach_m))
    rows = max(1, math.ceil((y1 - y0) / machine.reach_m))
    yaw = machine_yaw(machine, 0.0)
    found: list[Setup] = []
    for column in range(columns):
        for row in range(rows):
            pose = (x0 + (column + 0.5) * (x1 - x0) / columns, y0 + (row + 0.5) * (y1 - y0) / rows, yaw)
            setup = Setup(pose, base_rect(machine, pose))
            if not any(setup.base.overlaps(other) for other in blocked):
                found.append(setup)
    return found


def plan_setups(
    machines: Sequence[RobotDescription],
    mains: Sequence[Setup],
    components: Sequence[Component],
    *,
    building: Rect,
    yard: Rect,
    depot: Rect,
    lane_m: float,
) -> list[tuple[Setup, ...]]:
    """Each machine's set-ups (in the order of ``machines``, whose main set-ups are ``mains``): its main one
    first, then for a machine that relocates the extra ones of the module docstring's rule."""
    fixed = keep_clear(building, yard, depot, lane_m)
    corners = footprint_corners(components)
    methods = [component.method for component in components]
    extras_taken: list[Rect] = []
    planned: list[tuple[Setup, ...]] = []
    for index, (machine, main) in enumerate(zip(machines, mains, strict=True)):
        if not machine.relocates:
            planned.append((main,))
            continue
        own = {method for capability, method in WORK_METHOD.items() if machine.can(capability)}
        mine = np.array([method in own for method in methods], dtype=bool)
        others = [rect.grown(lane_m) for j, setup in enumerate(mains) if j != index for rect in setup.rects]
        found = setup_candidates(building, machine, lane_m, fixed, [*others, *extras_taken])
        if machine.can(Capability.PILE):
            found += inside_candidates(building, machine, [*others, *extras_taken])
        covers = [covered_by_boom(machine, setup.pose[:2], corners) & mine for setup in found]
        covered = covered_by_boom(machine, main.pose[:2], corners) & mine
        coverable = np.logical_or.reduce([covered, *covers]) if covers else covered
        chosen = [main]
        while (missing := coverable & ~covered).any():
            best = min(
                range(len(found)),
                key=lambda i: (
                    -int((covers[i] & missing).sum()),
                    round(math.dist(found[i].pose[:2], main.pose[:2]), 6),
                    i,
                ),
            )
            chosen.append(found[best])
            covered |= covers[best]
        extras_taken += [rect.grown(lane_m) for setup in chosen[1:] for rect in setup.rects]
        planned.append(tuple(chosen))
    return planned
