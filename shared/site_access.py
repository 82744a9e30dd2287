"""Site access along a construction sequence: after each placement, can a robot still get everywhere? (pure)

Why: a structure closes around what is still to be built. Four walls put up before the column inside
them leave the column's target cut off; a row of columns can wall off a yard aisle. The robots find that
out late (after driving, after picking). This check finds it before the build, from the plan alone.

The model is the robots' own: the site grid (fence, yard stacks in their slots, what is in place before
the robots come, the structure built so far), where a component occupies the grid when it meets the
robot's height band (``band_min_z_m`` .. ``band_max_z_m``: a beam at 3 m does not, a footing flush with
the ground does not), inflated by the robot's radius plus the map margin
(:data:`bimbot.shared.site_layout.INFLATION_MARGIN_M`), as the robots plan. A floor placed at its target
whose top is within the robot's step (``max_step_m``: a ground slab, its flooring, :mod:`.floors`) is
driven on, not an obstacle, as in the robots' map once it is constructed (and cured). The robot's free
region is the 4-connected free cells around its depot start (what its A* reaches: it never cuts a
corner). A component is *accessible* when some cell of that region lies within the robot's reach of its
footprint (the one reach rule, :mod:`bimbot.shared.robot_description`: nearest point of the footprint,
``reach_m`` less a margin), and, for a component in the band, at least the inflation radius outside it
(the body stays clear): at its BIM target for the assembly and at its yard slot for the pick-up.

:func:`check_order` walks a sequence placing one component after the other and reports, for each step,
the components it cuts off (accessible before, not after) and the components not accessible at their own
turn. Cost per step: one distance transform and one labelling of the site grid, plus one index lookup per
remaining component (candidate cells are computed once); at 0.2 m, ~5–20 ms per step on the sample sites.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from .clipped_distance import ClippedDistanceField
from .floors import drives_onto
from .footprint import Footprint, posed_footprint
from .free_region import FOUR, RegionChanges, Window, splits_nothing, updated_region
from .manifest import Component
from .occupancy_grid import OccupancyGrid, covered_cells, empty_grid, from_footprints, nearest_free_cell
from .robot_description import RobotDescription
from .site_layout import INFLATION_MARGIN_M
from .site_plan import GRID_MARGIN_M, SiteLayout, fence_boxes, machine_boxes

_log = logging.getLogger(__name__)

NO_CELL = 2**62  # a row or column beyond every grid

# the robots' A* steps diagonally only between two free orthogonal neighbours (it never cuts a corner), so
# the cells it can reach are those 4-connected: a gap two cells touch only at a corner is no way through
# how far round a placed part its window reaches beyond the robot's body: room for the free region to go
# round the part inside the window, so a placement that splits nothing is seen to split nothing
WINDOW_MARGIN_M = 3.0
# how far from a robot's position the free cell that stands for it may be (a robot close to a wall stands
# in the inflated margin of the widest robot)
SHUT_IN_SEARCH_M = 1.0
START_SEARCH_M = 5.0  # the region grows from the free cell nearest the depot start, this near it
NEAR_CACHE_SIZE = 1024  # robots' points remembered at most, between two changes of the grid


@dataclass(frozen=True)
class AccessConfig:
    resolution_m: float = 0.2
    band_min_z_m: float = 0.02  # as the robots' site map: flush footings don't block
    band_max_z_m: float = 1.0  # beams above the robot don't block
    reach_margin_m: float = 0.1  # stand this far inside the reach, as the robots do


@dataclass(frozen=True)
class AccessCheck:
    """What a sequence does to site access (see :func:`check_order`)."""

    cut_offs: tuple[tuple[str, str], ...] = ()  # (placed, cut off): placing the first cuts the second off
    inaccessible: dict[str, tuple[str, ...]] = field(
        default_factory=dict
    )  # GUID → placed before it, cutting it


class Candidates(Protocol):
    """The components a question is about: asked whether one is among them, and gone through in order
    (a set or a dict; a list would answer ``in`` one by one)."""

    def __contains__(self, guid: object) -> bool: ...

    def __iter__(self) -> Iterator[str]: ...


class SiteAccess:
    """The site grid with every component either in its yard slot or placed at its target."""

    def __init__(
        self,
        components: Sequence[Component],
        layout: SiteLayout,
        robot: RobotDescription,
        config: AccessConfig = AccessConfig(),
        in_place: Sequence[Component] = (),
        *,
        on_step: Callable[[int, int], None] | None = None,
    ) -> None:
        """``on_step`` hears how far the grid is (components done, total): on a large site it takes a
        while (40 s for 9,802 components), and a trial user watched a stage stand at 0 meanwhile."""
        self.config, self.layout = config, layout
        self.inflation_m = robot.radius_m + INFLATION_MARGIN_M
        self._reach_m = robot.reach_m - config.reach_margin_m
        self._step_m = robot.max_step_m
        bounds = layout.bounds.grown(GRID_MARGIN_M)
        self.grid = empty_grid((*bounds.min_xy, *bounds.max_xy), config.resolution_m)
        boxes = fence_boxes(layout) + machine_boxes(layout)  # the fence and the machines set up on site
        fence = from_footprints(self.grid.bounds_xy_m, config.resolution_m, boxes_xy_m=boxes)
        self._fence = fence.occupied
        self._counts = np.zeros(self.grid.shape, np.int32)
        # asked for every released task at every assignment pass while the grid stays the same: the free
        # cell nearest each robot (cleared by any change of the grid), and which components are open in
        # the free region (kept with the region it was read from)
        self._near: dict[tuple[float, float], tuple[int, int] | None] = {}
        self._open_in: tuple[NDArray[np.bool_] | None, dict[str, bool]] = (None, {})
        # the distance to the nearest occupied cell, kept current around each change (a whole transform of
        # a 988-component site's 0.1 m grid took 50–100 ms, after every one of the check's placements)
        self._distance = ClippedDistanceField(
            self.grid.shape,
            config.resolution_m,
            self.inflation_m + 2.0 * config.resolution_m,
            lambda rows, cols: self._fence[rows, cols] | (self._counts[rows, cols] > 0),
        )
        # the cells taken and freed since the free region was last known: it is updated round them
        self._changes = RegionChanges(self.grid.shape, self._distance.reach_cells + 1)
        self._components = {component.guid: component for component in components}
        self._cells: dict[str, NDArray[np.int64]] = {}
        self._target_candidates: dict[str, NDArray[np.int64]] = {}
        self._slot_candidates: dict[str, NDArray[np.int64]] = {}
        # the cells each component occupies at its target and in its yard slot (None: none, or driven onto)
        self._target_cells: dict[str, NDArray[np.int64] | None] = {}
        self._slot_cells: dict[str, NDArray[np.int64] | None] = {}
        self.placed: set[str] = set()
        for done, (guid, component) in enumerate(self._components.items()):
            if on_step is not None:
                on_step(done, len(self._components))
            target = component.target_pose_world
            footprint = posed_footprint(component, target.position_m, target.quat_xyzw)
            self._target_candidates[guid] = self._candidates(footprint)
            driven_onto = drives_onto(component, footprint.z_max_m, self._step_m)
            self._target_cells[guid] = None if driven_onto else self._covered(footprint)
            slot = layout.slots.get(guid)
            if slot is not None:
                footprint = posed_footprint(component, slot.position_m, slot.quat_xyzw)
                self._slot_candidates[guid] = self._candidates(footprint)
                self._slot_cells[guid] = self._covered(footprint)
                self._occupy(guid, self._slot_cells[guid])
        for component in in_place:  # built before the robots came: it stands where the model puts it
            target = component.target_pose_world
            footprint = posed_footprint(component, target.position_m, target.quat_xyzw)
            if not drives_onto(component, footprint.z_max_m, self._step_m):
                self._occupy(f"in place {component.guid}", self._covered(footprint))
        self._start = layout.robot_starts[0][:2]
        self._region: NDArray[np.bool_] | None = None
        self._start_window: Window = (0, 0, 0, 0)  # the cells round the depot start (the region's seed)
        # the grid boxes of the cells each component is reached from, at its slot and at its target (one
        # row per component reached from somewhere; a box that holds no cell meets nothing): its access
        # changes only where the free region changes inside one. One box round both reached from the yard
        # to the building, and met the changes of every placement between them.
        self.reach_box_guids = [guid for guid in self._components if len(self._reach_cells(guid))]
        self._reach_box_array = np.array(
            [
                [_box_of(self._slot_candidates.get(guid)), _box_of(self._target_candidates[guid])]
                for guid in self.reach_box_guids
            ],
            np.int64,
        ).reshape(-1, 2, 4)

    # --- changes ----------------------------------------------------------------------------------------

    def place(self, guid: str) -> None:
        """``guid`` leaves its yard slot and stands at its BIM target."""
        self._release(guid)
        self._occupy(guid, self._target_cells[guid])
        self.placed.add(guid)

    def remove(self, guid: str) -> None:
        """Undo :meth:`place` (back to its slot)."""
        self._release(guid)
        self.placed.discard(guid)
        self._occupy(guid, self._slot_cells.get(guid))

    def reset(self) -> None:
        """Every placed component back in its yard slot: the grid as it was built, without building it
        again (the candidates of every component are kept)."""
        for guid in list(self.placed):
            self.remove(guid)

    def clear(self, guid: str) -> None:
        """``guid`` is neither in its yard slot nor at its target (a failed part carried or cleared away)."""
        self._release(guid)
        self.placed.discard(guid)

    def cut_off_by(self, guid: str, others: Candidates) -> list[str]:
        """Which of ``others`` (accessible now) placing ``guid`` at its target would cut off, in the order
        of ``others``; the grid is left as it was, and so is its free region.

        Most placements split nothing: the free region loses the cells round the new part and stays one
        piece. That is decided in a window round the part (:func:`.free_region.splits_nothing`), without
        labelling the whole grid (55 ms on the restaurant's 0.1 m grid of 4.3 M cells), and only the
        components reached from a cell of that window can lose their way: only those are asked (a
        released footing of the 9,802-component frame asked all the others, 32 million questions for the
        3,249 footings released at the start). Only a split, or a cut-off found that way, is checked on the
        whole grid, against every one of ``others``. A part that takes no cell at its target (a footing
        below the robots' band, a floor driven onto) cuts nothing off: its yard slot only frees cells."""
        if self._target_cells.get(guid) is None:
            return []
        region, cells, was_placed = self.region(), self._cells.get(guid), guid in self.placed
        self.place(guid)
        window = self._window_round(guid)
        cut: list[str] | None = None
        if window is not None:
            free = ~(self._distance.distance_m[window] <= self.inflation_m + 1e-9)
            if splits_nothing(region[window], free):
                after = region.copy()
                after[window] &= free
                near = [other for other in self._reached_in(window) if other != guid and other in others]
                # a cut-off found so is checked on the whole grid (the yard slot left may open a way)
                lost = any(_open(self, other, region) and not _open(self, other, after) for other in near)
                cut = None if lost else []
        if cut is None:
            before = [other for other in others if other != guid and _open(self, other, region)]
            self._region = None
            cut = [other for other in before if not _open(self, other)] if before else []
        self._release(guid)
        self._occupy(guid, cells)  # back where it was (its yard slot, or its target)
        if not was_placed:
            self.placed.discard(guid)
        self._keep_region(region)
        return cut

    def _reached_in(self, window: tuple[slice, slice]) -> list[str]:
        """The components reached from a cell of ``window``, in manifest order."""
        rows, cols = window
        meets = self.reached_from([(rows.start, rows.stop - 1, cols.start, cols.stop - 1)])
        return [self.reach_box_guids[index] for index in np.flatnonzero(meets)]

    def reached_from(self, boxes: Sequence[tuple[int, int, int, int]]) -> NDArray[np.bool_]:
        """For each of :attr:`reach_box_guids`: whether a cell it is reached from (slot or target) may lie
        in one of the grid ``boxes`` (first row, last row, first column, last column): the box round its
        slot's cells or round its target's meets one."""
        own = self._reach_box_array
        meets = np.zeros(own.shape[:2], bool)
        for r0, r1, c0, c1 in boxes:
            meets |= (own[..., 0] <= r1) & (own[..., 1] >= r0) & (own[..., 2] <= c1) & (own[..., 3] >= c0)
        reached: NDArray[np.bool_] = np.any(meets, axis=1)
        return reached

    def frees(self, guid: str, points_xy_m: Sequence[tuple[float, float]]) -> list[int]:
        """Which of ``points_xy_m`` (where robots stand), cut off from the depot start now, would have their
        way out if ``guid`` did not stand at its target: ``guid`` is what shuts them in. The grid is left as
        it was. A point stands for the free cell nearest it (within ``SHUT_IN_SEARCH_M``), on its side of
        any wall. Cost: nothing more than a lookup unless a point is cut off; then one labelling."""
        cells = self._target_cells.get(guid)
        if guid not in self.placed or cells is None or not points_xy_m:
            return []
        region = self.region()
        near = [self._near_cached(point) for point in points_xy_m]
        shut = [i for i, cell in enumerate(near) if cell is not None and not region[cell]]
        if not shut:
            return []
        self._release(guid)
        after = self.region()
        freed = [i for i in shut if after[near[i]]]
        self._occupy(guid, cells)
        self._keep_region(region)
        return freed

    def _near_cached(self, point_xy_m: tuple[float, float]) -> tuple[int, int] | None:
        """:meth:`_free_cell_near`, remembered until the grid changes (a few robots, many tasks a pass)."""
        key = (float(point_xy_m[0]), float(point_xy_m[1]))
        if key not in self._near:
            if len(self._near) >= NEAR_CACHE_SIZE:  # robots on the move: every pass asks new points
                self._near.clear()
            self._near[key] = self._free_cell_near(key)
        return self._near[key]

    def open_now(self, guid: str) -> bool:
        """Accessible at its yard slot and at its target in the free region as it stands, remembered with
        that region (every released task's check asks it of every component still to be built)."""
        region = self.region()
        held, known = self._open_in
        if held is not region:
            known = {}
            self._open_in = (region, known)
        is_open = known.get(guid)
        if is_open is None:
            is_open = known[guid] = self.slot_accessible(guid) and self.target_accessible(guid)
        return is_open

    def _free_cell_near(self, point_xy_m: tuple[float, float]) -> tuple[int, int] | None:
        """The free cell (the robot inflated) nearest ``point_xy_m``, within ``SHUT_IN_SEARCH_M``: read from
        the distance field in a window (``occupancy_grid.nearest_free_cell`` would need the whole inflated
        grid built first, on every assignment pass)."""
        row, col = (int(v) for v in self.grid.world_to_cell(np.asarray(point_xy_m, float)))
        half = int(np.ceil(SHUT_IN_SEARCH_M / self.config.resolution_m))
        rows, cols = self.grid.shape
        r0, r1, c0, c1 = (
            max(row - half, 0),
            min(row + half + 1, rows),
            max(col - half, 0),
            min(col + half + 1, cols),
        )
        if r0 >= r1 or c0 >= c1:
            return None
        free_r, free_c = np.nonzero(self._distance.distance_m[r0:r1, c0:c1] > self.inflation_m + 1e-9)
        if free_r.size == 0:
            return None
        best = int(np.argmin(np.hypot(free_r + r0 - row, free_c + c0 - col)))
        return int(free_r[best] + r0), int(free_c[best] + c0)

    def _window_round(self, guid: str) -> tuple[slice, slice] | None:
        """The grid window round ``guid``'s cells at its target, wide enough for the free region to go
        round it (None: it occupies no cell, or the window meets the grid's edge)."""
        cells = self._cells.get(guid)
        if cells is None or guid not in self.placed:
            return None
        pad = int(np.ceil((self.inflation_m + WINDOW_MARGIN_M) / self.config.resolution_m))
        (r0, c0), (r1, c1) = cells.min(axis=0) - pad, cells.max(axis=0) + pad + 1
        rows, cols = self.grid.shape
        if r0 < 0 or c0 < 0 or r1 > rows or c1 > cols:
            return None
        return slice(int(r0), int(r1)), slice(int(c0), int(c1))

    # --- questions --------------------------------------------------------------------------------------

    def occupancy(self) -> OccupancyGrid:
        """The fence and every component where it is now (yard slot or target), not inflated."""
        return self.grid.with_occupied(self._fence | (self._counts > 0))

    def region(self) -> NDArray[np.bool_]:
        """The robot's free region: inflated free cells 4-connected to its depot start; after a change,
        updated round it where that decides it (:mod:`.free_region`), else labelled on the whole grid."""
        if self._region is not None and self._changes:
            self._region = updated_region(self._region, self._changes, self._free_in, self._start_window)
            self._changes.clear()
        if self._region is None:
            free = ~(self._distance.distance_m <= self.inflation_m + 1e-9)
            labels, _ = ndimage.label(free, structure=FOUR)
            start = nearest_free_cell(
                self.grid.with_occupied(~free), self._start, max_distance_m=START_SEARCH_M
            )
            self._region = labels == labels[start] if start is not None else np.zeros_like(free)
            self._start_window = self._round_start()
            self._changes.clear()
        return self._region

    def _free_in(self, window: Window) -> NDArray[np.bool_]:
        rows, cols = slice(window[0], window[1]), slice(window[2], window[3])
        return ~(self._distance.distance_m[rows, cols] <= self.inflation_m + 1e-9)

    def _round_start(self) -> Window:
        """The cells within the start search (and a change's margin) of the depot start: a change there may
        move the region's seed."""
        row, col = (int(v) for v in self.grid.world_to_cell(np.asarray(self._start, float)))
        half = int(np.ceil(START_SEARCH_M / self.config.resolution_m)) + self._changes.margin
        return (row - half, row + half + 1, col - half, col + half + 1)

    def _keep_region(self, region: NDArray[np.bool_]) -> None:
        """``region`` is the free region again (the grid is back as it was when it was read)."""
        self._region = region
        self._changes.clear()

    def accessible(self, guid: str) -> bool:
        """A robot can stand within reach of ``guid``: at its slot while in the yard, else at its target."""
        cells = self._target_candidates[guid] if guid in self.placed else self._slot_candidates.get(guid)
        return self._any_in_region(cells if cells is not None else self._target_candidates[guid])

    def target_accessible(self, guid: str) -> bool:
        """A robot can stand within reach of ``guid``'s BIM target (to assemble it)."""
        return self._any_in_region(self._target_candidates[guid])

    def slot_accessible(self, guid: str) -> bool:
        cells = self._slot_candidates.get(guid)
        return True if cells is None else self._any_in_region(cells)

    # --- internals ----------------------------------------------------------------------------------------

    def _reach_cells(self, guid: str) -> NDArray[np.int64]:
        slot = self._slot_candidates.get(guid)
        target = self._target_candidates[guid]
        return target if slot is None else np.concatenate([slot, target])

    def _any_in_region(self, cells: NDArray[np.int64]) -> bool:
        if len(cells) == 0:
            return False
        return bool(self.region()[cells[:, 0], cells[:, 1]].any())

    def _candidates(self, footprint: Footprint) -> NDArray[np.int64]:
        """Cells where the robot's centre may stand to reach ``footprint`` (see the module docstring)."""
        poly = footprint.polygon_xy_m
        low, high = poly.min(axis=0) - self._reach_m, poly.max(axis=0) + self._reach_m
        r0, c0 = (max(0, int(v)) for v in self.grid.world_to_cell(low))
        r1, c1 = self.grid.world_to_cell(high)
        rows, cols = self.grid.shape
        r1, c1 = min(rows, int(r1) + 1), min(cols, int(c1) + 1)
        if r0 >= r1 or c0 >= c1:
            return np.zeros((0, 2), np.int64)
        rr, cc = np.mgrid[r0:r1, c0:c1]
        cells = np.stack([rr.ravel(), cc.ravel()], axis=1)
        distance = footprint.distance_m(self.grid.cell_to_world(cells))
        keep = distance <= self._reach_m
        if self._blocks(footprint):
            keep &= distance > self.inflation_m
        return cells[keep]

    def _blocks(self, footprint: Footprint) -> bool:
        return footprint.z_max_m >= self.config.band_min_z_m and footprint.z_min_m <= self.config.band_max_z_m

    def _covered(self, footprint: Footprint) -> NDArray[np.int64] | None:
        """The cells ``footprint`` occupies in the robots' height band (None: none)."""
        outlines = footprint.outlines_meeting(self.config.band_min_z_m, self.config.band_max_z_m)
        cells = covered_cells(self.grid, outlines) if outlines else None
        return cells if cells is not None and len(cells) > 0 else None

    def _occupy(self, guid: str, cells: NDArray[np.int64] | None) -> None:
        if cells is None:
            return
        self._cells[guid] = cells
        self._counts[cells[:, 0], cells[:, 1]] += 1
        self._distance.touch(cells)
        self._changes.add(cells, taken=True)
        self._near.clear()

    def _release(self, guid: str) -> None:
        cells = self._cells.pop(guid, None)
        if cells is not None:
            self._counts[cells[:, 0], cells[:, 1]] -= 1
            self._distance.touch(cells)
            self._changes.add(cells, taken=False)
            self._near.clear()


def check_order(
    access: SiteAccess,
    order: Iterable[str],
    on_step: Callable[[int, int], None] | None = None,
    *,
    earlier: tuple[Sequence[str], AccessCheck] | None = None,
) -> AccessCheck:
    """Place ``order`` one by one on ``access`` (which it changes) and report what each step cuts off.

    Before each placement: is the component accessible at its slot and at its target? If not, it is
    ``inaccessible`` (naming the placed components whose placement cut it off). After it: every remaining
    component that was accessible and no longer is, is cut off by this placement. ``on_step`` hears each
    step (done, total): a check of a large site takes a while.

    ``earlier``: an order of the same components and its check, from the same ``access`` state. The steps
    both orders share from the start have the same answers (what a step cuts off is decided by what stands
    and what is still to come, as sets), so they are taken from it and only placed again; the check goes on
    from the first step that differs. A mended plan moves a few components later: on a 5,743-component
    Revit office each mend had checked the whole order again, about seven minutes a pass.
    """
    remaining = list(dict.fromkeys(order))
    cut_by: dict[str, list[str]] = {}
    inaccessible: dict[str, tuple[str, ...]] = {}
    pairs: list[tuple[str, str]] = []
    start = _shared_start(remaining, earlier[0]) if earlier is not None else 0
    if earlier is not None and start:
        done = set(remaining[:start])
        pairs = [pair for pair in earlier[1].cut_offs if pair[0] in done]
        for placed, cut in pairs:
            cut_by.setdefault(cut, []).append(placed)
        inaccessible = {guid: why for guid, why in earlier[1].inaccessible.items() if guid in done}
        for guid in remaining[:start]:
            access.place(guid)
    before = {guid: _open(access, guid) for guid in remaining[start:]}
    region = access.region()
    # where each component reached from somewhere stands in the order (the order it is asked in), and
    # whether it is still to come
    position = {guid: index for index, guid in enumerate(remaining)}
    positions = np.array([position.get(guid, -1) for guid in access.reach_box_guids], np.int64)
    to_come = positions > start
    for index, guid in enumerate(remaining[start:], start):
        if on_step is not None:
            on_step(index, len(remaining))
        if not before[guid]:
            inaccessible[guid] = tuple(cut_by.get(guid, ()))
        access.place(guid)
        to_come &= positions > index
        changed = _changed_boxes(region, region := access.region())
        if not changed:
            continue  # the free region is as it was: nothing's access changed
        # only those reached from where the region changed (a slot freed in the yard and a part placed
        # in the building are two boxes, not the one box round both)
        asked = np.flatnonzero(access.reached_from(changed) & to_come)
        for other in (access.reach_box_guids[i] for i in asked[np.argsort(positions[asked])]):
            now = _open(access, other)
            if before[other] and not now:
                pairs.append((guid, other))
                cut_by.setdefault(other, []).append(guid)
            before[other] = now
    return AccessCheck(cut_offs=tuple(pairs), inaccessible=inaccessible)


def _shared_start(order: Sequence[str], earlier: Sequence[str]) -> int:
    """How many steps ``order`` shares from its start with ``earlier`` (0 unless both hold the same
    components)."""
    earlier = list(dict.fromkeys(earlier))
    if len(earlier) != len(order) or set(earlier) != set(order):
        return 0
    return next(
        (index for index, (a, b) in enumerate(zip(order, earlier, strict=True)) if a != b), len(order)
    )


def _changed_boxes(before: NDArray[np.bool_], after: NDArray[np.bool_]) -> list[tuple[int, int, int, int]]:
    """Grid boxes (first row, last row, first column, last column) that hold every cell where ``before``
    and ``after`` differ, one per cluster of changed rows and columns; none where they are equal."""
    changed = before != after
    row_runs, col_runs = _runs(changed.any(axis=1)), _runs(changed.any(axis=0))
    if len(row_runs) * len(col_runs) == 1:
        return [(*row_runs[0], *col_runs[0])]
    return [
        (r0, r1, c0, c1)
        for r0, r1 in row_runs
        for c0, c1 in col_runs
        if changed[r0 : r1 + 1, c0 : c1 + 1].any()
    ]


def _runs(flags: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """The (first, last) index of each run of True in ``flags``."""
    edges = np.flatnonzero(np.diff(np.concatenate(([0], flags.view(np.int8), [0]))))
    return [(int(a), int(b) - 1) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def _box_of(cells: NDArray[np.int64] | None) -> tuple[int, int, int, int]:
    """The grid box round ``cells``; a box that meets none (first row after the last) when there are none."""
    if cells is None or len(cells) == 0:
        return (NO_CELL, -1, NO_CELL, -1)  # starts after every grid's last row and column: meets no box
    (r0, c0), (r1, c1) = cells.min(axis=0), cells.max(axis=0)
    return int(r0), int(r1), int(c0), int(c1)


def _open(access: SiteAccess, guid: str, region: NDArray[np.bool_] | None = None) -> bool:
    """Accessible at its yard slot and at its target (in ``region``, else the access's free region)."""
    if region is None:
        return access.open_now(guid)
    slot = access._slot_candidates.get(guid)
    target = access._target_candidates[guid]
    reached = (slot is None or bool(region[slot[:, 0], slot[:, 1]].any())) and len(target) > 0
    return reached and bool(region[target[:, 0], target[:, 1]].any())
