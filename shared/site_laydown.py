"""Where a crane's heavy loads lie: the laydown beside the crane (pure, part of the site plan).

Why: a component heavier than every ground robot's payload is never brought to the crane; the crane lifts
it where it lies, and its load chart lifts that mass only within a radius. A site plans for it: heavy
precast panels and members are set down by the delivery truck in a laydown beside the crane, within the
chart's radius for their mass, not at the far end of the yard. Here:

* **crane-only** — a component that is lifted (not built in place), heavier than the largest payload among
  the fleet's ground types that carry, and no heavier than a hook-lifting type's largest payload;
* each goes, heaviest first, to the free spot nearest the first crane (robot id order) that can lift it:
  lying as in the yard (:func:`.yard_slot.laid_slot`), its centre at a hook radius between the trolley's
  innermost radius and the chart's radius for its mass, clear by a gap of what is blocked (the building,
  yard, depot and main street with their lanes, every machine's base and staging area with a lane around
  them, so ground robots still reach the staging area) and of the loads laid before it;
* a load with no such spot is left out (the caller keeps it in the yard, where a run gives its reason).

Deterministic: candidate centres lie on a grid ``SPOT_STEP_M`` apart around the mast, nearest first.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .manifest import Component
from .robot_description import Capability, RobotDescription
from .site_plan import Rect, YardSlot
from .work_methods import BUILT_IN_PLACE
from .yard_slot import laid_slot

SPOT_STEP_M = 0.5  # candidate centres around the mast
LAYDOWN_GAP_M = 0.6  # between two loads, and between a load and what is blocked


@dataclass(frozen=True)
class Crane:
    """A hook-lifting machine as set up: its description and its pose (x, y, yaw)."""

    description: RobotDescription
    pose: tuple[float, float, float]


def ground_payload_kg(fleet: Sequence[RobotDescription]) -> float:
    """The largest payload a ground type carries (0 with none)."""
    return max(
        (item.payload_kg for item in fleet if item.can(Capability.DRIVE) and item.can(Capability.CARRY)),
        default=0.0,
    )


def crane_only(components: Sequence[Component], fleet: Sequence[RobotDescription]) -> list[int]:
    """Indices of the lifted components no ground type carries and a hook-lifting type lifts."""
    ground_kg = ground_payload_kg(fleet)
    hook_kg = max((item.payload_kg for item in fleet if item.can(Capability.HOOK_LIFT)), default=0.0)
    return [
        index
        for index, component in enumerate(components)
        if component.method not in BUILT_IN_PLACE and ground_kg < component.mass_kg <= hook_kg
    ]


def lay_down(
    components: Sequence[Component], cranes: Sequence[Crane], blocked: Sequence[Rect]
) -> dict[str, YardSlot]:
    """Slots beside the cranes for ``components`` (the crane-only ones), by the module docstring's rule;
    a component without a spot is not in the result."""
    taken = [rect.grown(LAYDOWN_GAP_M) for rect in blocked]
    slots: dict[str, YardSlot] = {}
    order = sorted(range(len(components)), key=lambda i: (-components[i].mass_kg, i))
    for index in order:
        component = components[index]
        for crane in cranes:
            spec = crane.description.crane
            if spec is None or component.mass_kg > crane.description.payload_kg:
                continue
            probe = laid_slot(component, 0.0, 0.0).footprint
            size = (probe.max_xy[0] - probe.min_xy[0], probe.max_xy[1] - probe.min_xy[1])
            spot = _free_spot(
                crane.pose[:2], size, spec.min_radius_m, spec.radius_for(component.mass_kg), taken
            )
            if spot is None:
                continue
            slot = laid_slot(component, spot[0] - size[0] / 2.0, spot[1] - size[1] / 2.0)
            slots[component.guid] = slot
            taken.append(slot.footprint.grown(LAYDOWN_GAP_M))
            break
    return slots


def _free_spot(
    mast_xy: Sequence[float],
    size: tuple[float, float],
    min_radius_m: float,
    max_radius_m: float,
    taken: list[Rect],
) -> tuple[float, float] | None:
    """The centre nearest the mast (ties: the grid's order) of a ``size`` footprint overlapping none of
    ``taken``, at a hook radius in ``[min_radius_m, max_radius_m]``. The candidates are tried against every
    taken footprint a block at a time (a site of thousands of panels lays thousands of loads, each tried
    against all laid before it)."""
    if max_radius_m < min_radius_m:
        return None
    offsets_x, offsets_y = _candidate_offsets(max_radius_m, min_radius_m)
    xs, ys = offsets_x + mast_xy[0], offsets_y + mast_xy[1]
    half_x, half_y = size[0] / 2.0, size[1] / 2.0
    lows = np.array([rect.min_xy for rect in taken]).reshape(-1, 2)
    highs = np.array([rect.max_xy for rect in taken]).reshape(-1, 2)
    for start in range(0, len(xs), _BLOCK):
        x, y = xs[start : start + _BLOCK, None], ys[start : start + _BLOCK, None]
        clear = (
            (x + half_x <= lows[:, 0])
            | (x - half_x >= highs[:, 0])
            | (y + half_y <= lows[:, 1])
            | (y - half_y >= highs[:, 1])
        ).all(axis=1)
        hits = np.flatnonzero(clear)
        if hits.size:
            first = start + int(hits[0])
            return (float(xs[first]), float(ys[first]))
    return None


_BLOCK = 256  # candidate centres tried together


def _candidate_offsets(max_radius_m: float, min_radius_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Grid offsets from the mast at a radius in ``[min_radius_m, max_radius_m]``, nearest first (ties: x,
    then y)."""
    xs, ys, radius = _ordered_grid(int(max_radius_m // SPOT_STEP_M), min_radius_m)
    keep = radius <= max_radius_m + 1e-9  # sorted by radius: the nearer ones, in the same order
    return xs[keep], ys[keep]


@functools.lru_cache(maxsize=256)
def _ordered_grid(steps: int, min_radius_m: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The grid's offsets ``steps`` each way at a radius of at least ``min_radius_m``, nearest first, with
    their radii; cached by the grid's size (a chart's radius for each load's mass is a new number, its grid
    seldom is); read-only."""
    offsets = np.arange(-steps, steps + 1) * SPOT_STEP_M
    dx, dy = np.meshgrid(offsets, offsets, indexing="ij")
    radius = np.hypot(dx, dy).ravel()
    inside = radius >= min_radius_m - 1e-9
    order = np.lexsort((dy.ravel()[inside], dx.ravel()[inside], np.round(radius[inside], 6)))
    arrays = dx.ravel()[inside][order], dy.ravel()[inside][order], radius[inside][order]
    for array in arrays:
        array.flags.writeable = False
    return arrays


def hook_radius_m(crane: Crane, slot: YardSlot) -> float:
    """The hook radius over a slot's footprint centre."""
    (x0, y0), (x1, y1) = slot.footprint.min_xy, slot.footprint.max_xy
    return math.hypot((x0 + x1) / 2.0 - crane.pose[0], (y0 + y1) / 2.0 - crane.pose[1])
