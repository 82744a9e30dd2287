"""The robots' free region kept current around each change of the grid, without labelling the whole grid.

Why: the planner's access check places every component of a plan in turn and asks, after each placement,
which components the free region (the inflated free cells 4-connected to the depot) still reaches. On a
5,743-component Revit office the grid is 2,549 × 3,572 cells at 0.2 m: labelling it after every
placement (37 ms, and as much again to pick the region out of the labels) was 80 % of the check, which
took about seven minutes a pass. A placement changes the free cells only within a few cells of the part
it moves, so the region is decided in a window round the change:

* **cells taken** (a part set down): when every piece of the region in the window goes on as one piece
  (:func:`splits_nothing`), the region outside the window is joined as it was, and the region after is
  the region before less the cells taken;
* **cells freed** (a part lifted from its yard slot): the region in the window becomes the free cells
  joined, within the window, to the region before; unless such a piece reaches the window's edge where
  the region did not (a pocket outside the window joined through the change), the region outside the
  window is as it was;
* anything else (a piece split, a pocket joined, taken and freed cells whose windows meet, a change near
  the depot's start) is labelled on the whole grid, as before.

The answer is the region cell for cell (``tests/shared/test_free_region.py`` checks it against a whole
labelling along random builds). Pure numpy/scipy; the owner reads the free cells of a window from its
distance field.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from .clipped_distance import Window, merged_windows

FreeIn = Callable[[Window], NDArray[np.bool_]]  # the free cells of a window, as the grid stands now
FOUR = ndimage.generate_binary_structure(2, 1)


@dataclass
class RegionChanges:
    """The windows where cells were taken and freed since the region was last known, each grown by
    ``margin`` cells (how far a changed cell changes the free cells, and one more for the window's edge)."""

    shape: tuple[int, int]
    margin: int
    taken: list[Window] = field(default_factory=list)
    freed: list[Window] = field(default_factory=list)

    def add(self, cells: NDArray[np.integer], *, taken: bool) -> None:
        rc = np.asarray(cells).reshape(-1, 2)
        if len(rc) == 0:
            return
        low, high = rc.min(axis=0) - self.margin, rc.max(axis=0) + 1 + self.margin
        rows, cols = self.shape
        window = (max(0, int(low[0])), min(rows, int(high[0])), max(0, int(low[1])), min(cols, int(high[1])))
        (self.taken if taken else self.freed).append(window)

    def clear(self) -> None:
        self.taken.clear()
        self.freed.clear()

    def __bool__(self) -> bool:
        return bool(self.taken or self.freed)


def updated_region(
    region: NDArray[np.bool_], changes: RegionChanges, free_in: FreeIn, start_window: Window
) -> NDArray[np.bool_] | None:
    """The region after ``changes`` (a new array; ``region`` is left as it was), or None when some change
    cannot be decided in its window (see the module docstring): the owner labels the whole grid."""
    taken, freed = merged_windows(changes.taken), merged_windows(changes.freed)
    if any(_meet(a, b) for a in taken for b in freed) or any(_meet(w, start_window) for w in taken + freed):
        return None
    after = region.copy()
    for window in taken:
        rows, cols = slice(window[0], window[1]), slice(window[2], window[3])
        free = free_in(window)
        if not splits_nothing(after[rows, cols], free):
            return None
        after[rows, cols] &= free
    for window in freed:
        rows, cols = slice(window[0], window[1]), slice(window[2], window[3])
        joined = _joined(after[rows, cols], free_in(window))
        if joined is None:
            return None
        after[rows, cols] = joined
    return after


def splits_nothing(before: NDArray[np.bool_], free: NDArray[np.bool_]) -> bool:
    """In a window, ``before``: the free region before a placement; ``free``: the cells free after it.
    True when every piece of the region in the window survives the placement as one piece, and the
    placement's cells keep off the window's edge: the region outside the window is then joined as it was,
    and the region after is the region before less the cells taken."""
    taken = before & ~free
    if taken[0].any() or taken[-1].any() or taken[:, 0].any() or taken[:, -1].any():
        return False
    labels_before, count = ndimage.label(before, structure=FOUR)
    labels_after, _ = ndimage.label(before & free, structure=FOUR)
    kept = labels_after > 0
    pairs = np.unique(np.stack([labels_before[kept], labels_after[kept]]), axis=1)
    # each piece before goes on as exactly one piece after (none lost, none split)
    return pairs.shape[1] == count and len(np.unique(pairs[0])) == count


def _joined(before: NDArray[np.bool_], free: NDArray[np.bool_]) -> NDArray[np.bool_] | None:
    """The region in a window after cells were freed in it (``before`` within ``free``): the free pieces
    that hold region cells; None when one of them reaches the window's edge where the region did not."""
    if (before & ~free).any():
        return None  # a cell of the region is no longer free: not only freed cells here
    labels, _ = ndimage.label(free, structure=FOUR)
    held = np.unique(labels[before])
    after = np.isin(labels, held[held > 0])
    edges = (np.s_[0, :], np.s_[-1, :], np.s_[:, 0], np.s_[:, -1])
    if any((after[edge] & ~before[edge]).any() for edge in edges):
        return None
    return after


def _meet(a: Window, b: Window) -> bool:
    return a[0] < b[1] and b[0] < a[1] and a[2] < b[3] and b[2] < a[3]
