"""A distance field clipped at a bound, kept current under local changes of what occupies the grid.

Why: a robot's maps of a large site (988 components: 2,500 × 3,000 cells at the localiser's 5 cm) change
whenever a component moves. A Euclidean distance transform of the whole grid takes about a second there,
and ten robots redoing it after every change ran a ten-robot build at 0.4× real time. A cell's distance
clipped at ``max_distance_m`` depends only on what is occupied within that distance of it, so after a
change only the cells within the bound of the changed cells are recomputed, from the occupancy within twice
the bound: the field is the same as the whole transform's, cell for cell.

Pure numpy/scipy; the owner says which cells changed (:meth:`ClippedDistanceField.touch`) and how to read
its occupancy in a window (``occupancy(rows, cols)``); the field is brought up to date when read.
Conventions as :mod:`.occupancy_grid`: ``[row, col]`` cells, distances between cell centres in metres.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

Window = tuple[int, int, int, int]  # rows [r0, r1), cols [c0, c1)
Occupancy = Callable[[slice, slice], NDArray[np.bool_]]


class ClippedDistanceField:
    """Distance from every cell centre to the nearest occupied cell centre, clipped at ``max_distance_m``
    (0 on occupied cells); computed whole once, then only around the cells :meth:`touch` names."""

    def __init__(
        self, shape: tuple[int, int], resolution_m: float, max_distance_m: float, occupancy: Occupancy
    ) -> None:
        if not max_distance_m > 0 or not resolution_m > 0:
            raise ValueError("need max_distance_m > 0 and resolution_m > 0")
        self.shape = (int(shape[0]), int(shape[1]))
        self.resolution_m = float(resolution_m)
        self.max_distance_m = float(max_distance_m)
        self._occupancy = occupancy
        self._reach = math.ceil(self.max_distance_m / self.resolution_m) + 1  # cells a change reaches
        self._field = np.full(self.shape, self.max_distance_m)
        self._dirty: list[Window] = [(0, self.shape[0], 0, self.shape[1])]

    @property
    def reach_cells(self) -> int:
        """How many cells from a changed cell the field may change."""
        return self._reach

    def touch(self, cells: NDArray[np.integer]) -> None:
        """Cells ``(n, 2)`` whose occupancy changed (or may have): the field around them is recomputed on
        the next read."""
        rc = np.asarray(cells).reshape(-1, 2)
        if len(rc) == 0:
            return
        low, high = rc.min(axis=0), rc.max(axis=0) + 1
        self._dirty.append((int(low[0]), int(high[0]), int(low[1]), int(high[1])))

    @property
    def distance_m(self) -> NDArray[np.float64]:
        """The field, up to date (read-only view: the owner's changes go through :meth:`touch`)."""
        if self._dirty:
            for window in merged_windows([self._grown(window, self._reach) for window in self._dirty]):
                self._refresh(window)
            self._dirty = []
        view = self._field.view()
        view.setflags(write=False)
        return view

    def _grown(self, window: Window, cells: int) -> Window:
        r0, r1, c0, c1 = window
        rows, cols = self.shape
        return (max(0, r0 - cells), min(rows, r1 + cells), max(0, c0 - cells), min(cols, c1 + cells))

    def _refresh(self, window: Window) -> None:
        """Recompute the cells of ``window`` from the occupancy within the bound around it."""
        source = self._grown(window, self._reach)
        occupied = self._occupancy(slice(source[0], source[1]), slice(source[2], source[3]))
        inner = (
            slice(window[0] - source[0], window[1] - source[0]),
            slice(window[2] - source[2], window[3] - source[2]),
        )
        target = (slice(window[0], window[1]), slice(window[2], window[3]))
        if not occupied.any():
            self._field[target] = self.max_distance_m
            return
        distance = ndimage.distance_transform_edt(~occupied, sampling=self.resolution_m)
        self._field[target] = np.minimum(distance[inner], self.max_distance_m)


def merged_windows(windows: list[Window]) -> list[Window]:
    """Windows that overlap joined into their bounding window, until none overlap (few windows: quadratic
    is fine), so no cell is recomputed twice."""
    merged = list(windows)
    changed = True
    while changed:
        changed = False
        for i in range(len(merged)):
            for j in range(i + 1, len(merged)):
                a, b = merged[i], merged[j]
                if a[0] < b[1] and b[0] < a[1] and a[2] < b[3] and b[2] < a[3]:
                    merged[i] = (min(a[0], b[0]), max(a[1], b[1]), min(a[2], b[2]), max(a[3], b[3]))
                    del merged[j]
                    changed = True
                    break
            if changed:
                break
    return merged
