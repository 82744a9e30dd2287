"""The localiser's map of the site at the laser's finer resolution: what the laser sees, cell counts per
component, and the likelihood field of its surfaces.

Why a layer of its own, made when first asked: only a robot that localises by its laser reads it (the
particle filter, the fine alignment before a placement). At 5 cm it is four times the planning grid's cells;
on a 713 × 509 m site (a 5,743-component office and its yard) its counts and field took 1.6 GB of a robot's
3.2 GB and half of the 19 s its map took to build. A plan-fidelity robot moves along its timed path
without a laser and never asks for it. Made late, it is the same map cell for cell: it is rasterised from the
outlines :class:`.site_map.SiteMap` holds at that moment, then kept current with each change as before.

Pure numpy; :class:`.site_map.SiteMap` owns it and tells it which outlines a component now covers.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from bimbot.shared.clipped_distance import ClippedDistanceField
from bimbot.shared.occupancy_grid import BoundsXY, OccupancyGrid, covered_cells, empty_grid, from_footprints

LASER_FIELD_MAX_M = 2.0  # the likelihood field is clipped at 2 m (as it always was)


class LaserLayer:
    """Counts of the components the laser sees, per fine cell, with the fence and machines it sees, and the
    distance from every cell to the nearest surface (an occupied cell bordering a free one)."""

    def __init__(self, bounds_xy_m: BoundsXY, resolution_m: float, walls_seen: Sequence[Sequence[float]]):
        self.geometry = empty_grid(bounds_xy_m, resolution_m)
        self._fence = from_footprints(self.geometry.bounds_xy_m, resolution_m, boxes_xy_m=walls_seen).occupied
        self._counts = np.zeros(self.geometry.shape, np.int16)
        self._cells: dict[str, NDArray[np.int64]] = {}
        self._distance = ClippedDistanceField(
            self.geometry.shape, resolution_m, LASER_FIELD_MAX_M, self._outline_window
        )

    def add(self, guid: str, outlines: Sequence[NDArray[np.float64]]) -> None:
        """The component ``guid`` now covers ``outlines`` (it covered nothing here before)."""
        cells = covered_cells(self.geometry, outlines)
        self._cells[guid] = cells
        self._counts[cells[:, 0], cells[:, 1]] += 1
        self._distance.touch(cells)

    def remove(self, guid: str) -> None:
        """The component ``guid`` covers nothing here any more (nothing happens when it covered nothing)."""
        cells = self._cells.pop(guid, None)
        if cells is not None:
            self._counts[cells[:, 0], cells[:, 1]] -= 1
            self._distance.touch(cells)

    def grid(self) -> OccupancyGrid:
        """What the laser sees, at this layer's resolution."""
        return self.geometry.with_occupied(self._fence | (self._counts > 0))

    @property
    def distance_m(self) -> NDArray[np.float64]:
        """Distance from every cell to the nearest surface, clipped at ``LASER_FIELD_MAX_M`` (read-only)."""
        return self._distance.distance_m

    def _outline_window(self, rows: slice, cols: slice) -> NDArray[np.bool_]:
        """The surfaces in a window (read with one cell around it, so the outline at the window's edge is
        the whole grid's)."""
        r0, c0 = max(0, rows.start - 1), max(0, cols.start - 1)
        r1, c1 = min(self.geometry.shape[0], rows.stop + 1), min(self.geometry.shape[1], cols.stop + 1)
        occupied = self._fence[r0:r1, c0:c1] | (self._counts[r0:r1, c0:c1] > 0)
        surfaces = outline_cells(occupied)
        return surfaces[rows.start - r0 : rows.stop - r0, cols.start - c0 : cols.stop - c0]


def outline_cells(occ: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """Only the occupied cells that border a free cell (4-neighbourhood): the surfaces a laser can hit."""
    padded = np.pad(occ, 1, constant_values=False)
    interior = padded[:-2, 1:-1] & padded[2:, 1:-1] & padded[1:-1, :-2] & padded[1:-1, 2:] & occ
    return occ & ~interior
