"""What a site fits to the walls beside it goes in after them: linings and floor finishes (pure, for the
support graph).

**Linings.** Why: the Revit duplex's 152 mm stud furring lines its 550 mm CMU party wall face to face
over 2 m, on the same floor. Neither rests on the other, so the derived sequence could put the furring up
first; the party wall's precast panel, 6.8 t, was then set by the crane against a furring that stood 6 mm
off its own target, was stopped at the contact 13-15 mm from where it belonged and failed ``misplaced``
three times, and seven components on it with it. A site builds the structure first and fixes its lining
to it: a lining is set against the wall as built, which leaves a light stud wall room to fit.

A **lining** of a wall: both are walls (``IfcWall`` and its subclasses); their boxes meet in plan (within
``tolerance_m``) along a run of at least ``MIN_RUN_M`` on a long side, each at most as thick across that
run as the overlap's other side allows (face to face, not an end against a face: a T-junction's run is
the crossing wall's thickness); they share height (their heights overlap by at least half the lower
one's); and the lining is at most ``THICKNESS_RATIO`` as thick as the wall. Thickness is the smaller side
of a wall's own box in plan (its local frame: a wall's axis runs along one side), so a wall drawn at an
angle is judged by its real thickness.

**Floor finishes.** Why: the duplex's 152 mm furring stands on the slab between its party wall's face and
the 13 mm tile floor's edge, both drawn touching it. Set after the tiles, it had no room left once the
wall and the tiles stood a few millimetres off their targets, and failed ``misplaced`` with 80 components
on it. A site lays floor finishes after the walls: tiles and boards are cut to the walls as they stand. A
**floor finish** is a slab or covering at most ``FINISH_MAX_M`` thick; it goes in after every wall whose
box meets its own in plan (within ``tolerance_m``) and which stands no higher than it (the wall's bottom
at most ``tolerance_m`` above the finish's bottom) and rises past its top; a wall standing on the
finish is carried by it, and the finish goes first.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .manifest import Component

MIN_RUN_M = 1.0  # face to face over at least this run in plan
THICKNESS_RATIO = 0.5  # a lining at most half as thick as the wall it lines
SHARED_HEIGHT = 0.5  # their heights overlap by at least this share of the lower one's
FINISH_MAX_M = 0.05  # a floor finish: tiles, boards, a covering (a screed is cast: not a lifted finish)
FINISH_CLASSES = ("IfcSlab", "IfcCovering")


def thickness_m(wall: Component) -> float:
    """The smaller side of ``wall``'s own box in plan."""
    low, high = np.asarray(wall.bbox_local.min_m), np.asarray(wall.bbox_local.max_m)
    return float(min(high[0] - low[0], high[1] - low[1]))


def fitted_after(components: Sequence[Component], tolerance_m: float) -> list[tuple[str, str]]:
    """(wall, what goes in after it) GUID pairs: linings, then floor finishes (see the module docstring)."""
    return [*lining_pairs(components, tolerance_m), *finish_pairs(components, tolerance_m)]


def finish_pairs(components: Sequence[Component], tolerance_m: float) -> list[tuple[str, str]]:
    """(wall, floor finish) GUID pairs among ``components`` (see the module docstring)."""
    walls = [item for item in components if item.ifc_class.startswith("IfcWall")]
    finishes = [
        item
        for item in components
        if item.ifc_class.startswith(FINISH_CLASSES)
        and item.bbox_world.max_m[2] - item.bbox_world.min_m[2] <= FINISH_MAX_M
    ]
    if not walls or not finishes:
        return []
    mins = np.array([item.bbox_world.min_m for item in walls])
    maxs = np.array([item.bbox_world.max_m for item in walls])
    pairs: list[tuple[str, str]] = []
    for finish in finishes:
        low, high = np.asarray(finish.bbox_world.min_m), np.asarray(finish.bbox_world.max_m)
        meets = np.all(
            (mins[:, :2] <= high[:2] + tolerance_m) & (maxs[:, :2] >= low[:2] - tolerance_m), axis=1
        )
        beside = (mins[:, 2] <= low[2] + tolerance_m) & (maxs[:, 2] > high[2] + tolerance_m)
        pairs.extend((walls[int(index)].guid, finish.guid) for index in np.flatnonzero(meets & beside))
    return pairs


def lining_pairs(components: Sequence[Component], tolerance_m: float) -> list[tuple[str, str]]:
    """(wall, lining) GUID pairs among ``components`` (see the module docstring), in component order."""
    walls = [item for item in components if item.ifc_class.startswith("IfcWall")]
    if len(walls) < 2:
        return []
    mins = np.array([item.bbox_world.min_m for item in walls])
    maxs = np.array([item.bbox_world.max_m for item in walls])
    thick = np.array([thickness_m(item) for item in walls])
    pairs: list[tuple[str, str]] = []
    for index, lining in enumerate(walls):
        overlap = np.minimum(maxs, maxs[index]) - np.maximum(mins, mins[index])  # per axis, each wall
        run = np.maximum(overlap[:, 0], overlap[:, 1])
        across = np.minimum(overlap[:, 0], overlap[:, 1])
        heights = np.minimum(maxs[:, 2] - mins[:, 2], maxs[index, 2] - mins[index, 2])
        candidates = (
            (run >= MIN_RUN_M)
            & (across >= -tolerance_m)
            & (across <= np.minimum(thick, thick[index]) + tolerance_m)
            & (overlap[:, 2] >= SHARED_HEIGHT * heights)
            & (thick[index] <= THICKNESS_RATIO * thick)
        )
        pairs.extend((walls[int(other)].guid, lining.guid) for other in np.flatnonzero(candidates))
    return pairs
