"""Blocks drawn round the project that are not part of its work: context massing.

Why: an architect's model often shows the neighbourhood as well as the building. Revit's advanced sample
office (PyPI ``ifc-mcp`` 0.1.0, ``AdvancedProject.ifc``) stands among 18 neighbouring blocks drawn as
hollow shells: "Generic - 200mm" walls 18-46 m tall, painted, with a roof slab on top and nothing inside,
in the same IfcBuilding and storeys as the office. Converted as work, they were 4,805 of its 5,761
components (their walls cut into storey-high panels), spread over a 236 × 161 m site no crane reaches
from outside; no contractor builds the neighbours. The IFC says nothing of it (their phase is "New
Construction" like the office's), so the converter reads it from what the blocks are:

* a **block** is a set of elements whose plan boxes touch, directly or through each other (within
  ``DETACHED_GAP_M``); the project is the block with the most elements, and is always built;
* a detached block is **context massing** when the model has doors or windows (an architectural model:
  the rule never applies to a structural model, whose cores and frames have none), and the block has
  none, nor a stair or a ramp (nobody could enter or use it), when it holds nothing but walls, slabs
  and roofs, at least ``MIN_WALLS`` walls (an enclosure, not a garden wall), and stands at least
  ``MIN_HEIGHT_M`` tall (two storeys: a boundary or retaining wall is lower).

Its elements are left out with a reason that says so, as entourage is (:mod:`.left_out`, once every
element is converted: the rule needs their boxes); ``bimbot convert --build-context`` builds them as work.
Pure.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from bimbot.shared.manifest import Component

DETACHED_GAP_M = 1.0  # plan boxes this far apart or more belong to different blocks
MIN_HEIGHT_M = 7.0  # two storeys: lower detached walls are garden, boundary or retaining walls
MIN_WALLS = 3  # an enclosure
ENTERABLE = ("IfcDoor", "IfcWindow", "IfcStair", "IfcStairFlight", "IfcRamp", "IfcRampFlight")
MASSING = ("IfcWall", "IfcWallStandardCase", "IfcWallElementedCase", "IfcSlab", "IfcRoof")
_CHUNK = 512  # rows of the pairwise box test at a time (memory: _CHUNK × elements booleans)


@dataclass(frozen=True)
class ContextBlock:
    """A detached block of context massing: its elements (GlobalIds), their classes and its extent."""

    guids: tuple[str, ...]
    classes: Counter[str]
    height_m: float
    apart_m: float  # from the project's nearest element, in plan

    def reason(self) -> str:
        """The skip reason of each of its elements."""
        walls = sum(count for name, count in self.classes.items() if name.startswith("IfcWall"))
        roofs = sum(count for name, count in self.classes.items() if not name.startswith("IfcWall"))
        made = f"{walls} wall(s)" + (f" and {roofs} slab(s) or roof(s)" if roofs else "")
        return (
            f"not part of the work (context massing): one of a detached block of {made}, "
            f"{self.height_m:.1f} m tall, {self.apart_m:.1f} m from the project, with no door, window or "
            "stair: a neighbouring building or a massing study drawn round the project; "
            "bimbot convert --build-context builds it"
        )


def context_reasons(components: Sequence[Component]) -> dict[str, str]:
    """Element GlobalId → its skip reason, for each element of the context massing among ``components``."""
    return {guid: block.reason() for block in context_blocks(components) for guid in block.guids}


def context_blocks(components: Sequence[Component]) -> list[ContextBlock]:
    """The context massing among ``components`` (an element's panels or bays count as that element), by
    the rule of the module docstring; none when the model has a single block."""
    keys, classes, low, high = _elements(components)
    if len(keys) < 2 or not any(name in ENTERABLE for name in classes):
        return []
    labels = _blocks(low, high)
    sizes = np.bincount(labels)
    project = int(np.argmax(sizes))  # the first of equals: the block of the earliest element
    found = []
    in_project = labels == project
    for block in range(len(sizes)):
        members = np.flatnonzero(labels == block)
        names = Counter(classes[index] for index in members)
        walls = sum(count for name, count in names.items() if name.startswith("IfcWall"))
        height_m = float(high[members, 2].max() - low[members, 2].min())
        if (
            block == project
            or any(name not in MASSING for name in names)
            or walls < MIN_WALLS
            or height_m < MIN_HEIGHT_M
        ):
            continue
        apart_m = _plan_gap_m(low[members], high[members], low[in_project], high[in_project])
        found.append(ContextBlock(tuple(keys[index] for index in members), names, height_m, apart_m))
    return found


def _elements(
    components: Sequence[Component],
) -> tuple[list[str], list[str], np.ndarray, np.ndarray]:
    """Per element (in first-seen order): its GlobalId, class and world box (the union of its parts')."""
    index: dict[str, int] = {}
    classes: list[str] = []
    lows: list[np.ndarray] = []
    highs: list[np.ndarray] = []
    for component in components:
        key = component.parent_guid or component.guid
        low, high = np.asarray(component.bbox_world.min_m), np.asarray(component.bbox_world.max_m)
        if key in index:
            at = index[key]
            lows[at], highs[at] = np.minimum(lows[at], low), np.maximum(highs[at], high)
            continue
        index[key] = len(classes)
        classes.append(component.ifc_class)
        lows.append(low)
        highs.append(high)
    shape = (len(classes), 3)
    return list(index), classes, np.array(lows).reshape(shape), np.array(highs).reshape(shape)


def _blocks(low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """Per element, the number of its block: elements whose plan boxes come within ``DETACHED_GAP_M`` of
    each other, directly or through others."""
    from scipy.sparse import coo_matrix  # not at import: a command that fails early does not pay for it
    from scipy.sparse.csgraph import connected_components

    rows: list[np.ndarray] = []
    columns: list[np.ndarray] = []
    for start in range(0, len(low), _CHUNK):
        lo, hi = low[start : start + _CHUNK, None, :2], high[start : start + _CHUNK, None, :2]
        near = ((lo < high[None, :, :2] + DETACHED_GAP_M) & (hi + DETACHED_GAP_M > low[None, :, :2])).all(2)
        row, column = np.nonzero(near)
        rows.append(row + start)
        columns.append(column)
    pairs = coo_matrix(
        (np.ones(sum(len(row) for row in rows)), (np.concatenate(rows), np.concatenate(columns))),
        shape=(len(low), len(low)),
    )
    return connected_components(pairs, directed=False)[1]


def _plan_gap_m(low_a: np.ndarray, high_a: np.ndarray, low_b: np.ndarray, high_b: np.ndarray) -> float:
    """The least plan distance between a box of one set and a box of the other."""
    gap = np.maximum(
        0.0, np.maximum(low_a[:, None, :2] - high_b[None, :, :2], low_b[None, :, :2] - high_a[:, None, :2])
    )
    return float(np.hypot(gap[..., 0], gap[..., 1]).min())
