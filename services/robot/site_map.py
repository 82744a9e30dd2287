"""The robot's map of the site: fence, components lying in the yard, the built part of the structure.

Why: the global planner, the local planner's static obstacles and the localiser all need one occupancy grid of
what stands on the site, kept current as components leave the yard and join the structure (the static layer
of a move_base costmap). Pure: it is fed component poses and states and answers grids and points.

What occupies the grid:

* what is **in place before the robots come** (``Manifest.in_place``: existing work), where the model puts it;
* the **fence** (site hoarding around everything, :mod:`bimbot.shared.site_layout`) and the set-ups of the
  machines that stand fixed (cranes, pumps, block layers: ``SiteLayout.machines``, each filled by its
  URDF's collision box up to ``MACHINE_BOX_HEIGHT_M``), always;
* every **component that is not carried**, at its current pose (its yard slot until physics says otherwise),
  when its posed bounding box meets the robot's height band (``band_min_z_m``–``band_max_z_m`` above the
  ground): components lying in the yard and built columns block, beams at 3 m and footings whose tops are
  at z ≈ 0 do not. A component carried by a robot (``attached_to``) leaves the map; when physics fixes it
  into the structure (``fixed``) it comes back at its placed pose;
* except a **floor driven on** (:mod:`bimbot.shared.floors`): a slab, covering or ramp constructed at its
  place whose top is no higher than the robot's step (``step_m``, its type's ``max_step_m``) is driven
  onto, as the trades drive onto a slab on site, not round. While it is being built or settling it
  blocks like anything else, and a cast floor until it has cured (its ``cast.cure_s`` after it was
  constructed: :meth:`SiteMap.advance` lets it in). The laser sees its edge where it reaches the laser's
  height, so its edge is in the localiser's map and is no surprise.

Laser hits are not stored here (they are transient); :meth:`SiteMap.planning_grid` adds the current ones.
What the laser sees is :meth:`SiteMap.laser_grid`: only what reaches up to the laser's height. The
localiser's map is that at a finer resolution (:mod:`.laser_layer`), made when a robot first localises.

Cost: one count per cell, and each component keeps the cells it covers, so a change touches only that
component's cells; the inflated grid and distance fields are recomputed lazily, once per change
(one Euclidean distance transform, ~1 ms on a 250×300 grid at 0.1 m).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bimbot.shared.clipped_distance import ClippedDistanceField
from bimbot.shared.floors import drives_onto
from bimbot.shared.footprint import Footprint, posed_footprint
from bimbot.shared.manifest import Component
from bimbot.shared.messages import ComponentPoseMsg, ComponentState
from bimbot.shared.occupancy_grid import OccupancyGrid, covered_cells, empty_grid, from_footprints, inflate
from bimbot.shared.site_plan import (
    FENCE_HEIGHT_M,
    GRID_MARGIN_M,
    MACHINE_BOX_HEIGHT_M,
    SiteLayout,
    fence_boxes,
    machine_boxes,
)

from .fine_alignment import outline_edges
from .laser_layer import LaserLayer, outline_cells

_log = logging.getLogger(__name__)

# Distances are kept up to these bounds (farther reads the bound), so a change recomputes only around itself
# (:mod:`bimbot.shared.clipped_distance`): every question asked of the static distance is about less than a
# metre (inflation, sight, a laser point unexplained), and the likelihood field was always clipped at 2 m.
STATIC_DISTANCE_MAX_M = 2.0


@dataclass(frozen=True)
class MapConfig:
    """Grid resolution, the robot's footprint and the height bands that decide what blocks."""

    resolution_m: float = 0.1
    robot_radius_m: float = 0.6  # circumscribed radius of a Husky (0.99 m × 0.67 m)
    inflation_margin_m: float = 0.15  # beyond the radius: room for localisation error and the local planner
    band_min_z_m: float = 0.02  # things entirely below this (footings flush with the ground) don't block
    band_max_z_m: float = 1.0  # things entirely above this (beams) don't block
    step_m: float = 0.0  # a constructed floor no higher than this is driven on (the robot's max_step_m)
    laser_height_m: float = 0.06  # physics' laser: things whose z range contains this height (yard items)
    laser_resolution_m: float = 0.05  # the localiser's map (see SiteMap.laser_field_grid)
    # The localiser's map may leave out what is flatter than this. 0: it keeps every item the laser can see.
    # A laser 6 cm above the ground passes over a 10 cm high item a few metres away once the chassis pitches
    # half a degree, but the likelihood field scores beam endpoints only, so a mapped item the beam passes
    # over costs nothing, while an item hit and missing from the map pulls the estimate. Measured: with
    # 0.25 m (flat yard stacks left out) the robot on the structural hub's 94 m long yard lost itself by up
    # to 49 m (2/115 built); with 0, 2.8 m at most (42/115, the rest too heavy or resting on those), and the
    # bundled frame with 3 robots took 437 s of sim time instead of 1,124 s (bench/build.py).
    localise_min_top_m: float = 0.0

    @property
    def inflation_m(self) -> float:
        return self.robot_radius_m + self.inflation_margin_m


class SiteMap:
    """Occupancy of the site from the layout and what is known about every component (see module doc)."""

    def __init__(
        self,
        layout: SiteLayout,
        components: Sequence[Component],
        config: MapConfig = MapConfig(),
        in_place: Sequence[Component] = (),
    ):
        self.layout = layout
        self.config = config
        self._components = {component.guid: component for component in components}
        bounds = layout.bounds.grown(GRID_MARGIN_M)
        self._geometry = empty_grid((*bounds.min_xy, *bounds.max_xy), config.resolution_m)
        # the fence and the machines set up on site (cranes, pumps, block layers): they block driving, and
        # the laser sees those that reach its height
        self._fence = from_footprints(
            self._geometry.bounds_xy_m,
            config.resolution_m,
            boxes_xy_m=fence_boxes(layout) + machine_boxes(layout),
        )
        self._walls_seen = (fence_boxes(layout) if config.laser_height_m <= FENCE_HEIGHT_M else []) + (
            machine_boxes(layout) if config.laser_height_m <= MACHINE_BOX_HEIGHT_M else []
        )
        self._seen_cells = from_footprints(
            self._geometry.bounds_xy_m, config.resolution_m, boxes_xy_m=self._walls_seen
        ).occupied
        self._counts = np.zeros(self._geometry.shape, np.int32)  # components covering each cell (band)
        self._laser_counts = np.zeros(self._geometry.shape, np.int32)  # components seen by the laser
        self._static_distance = ClippedDistanceField(
            self._geometry.shape, config.resolution_m, STATIC_DISTANCE_MAX_M, self._static_window
        )
        # The localiser's map, at its finer resolution: made when first asked (a robot without a laser
        # never asks), then kept current like the rest
        self._laser_layer: LaserLayer | None = None
        self._cells: dict[str, NDArray[np.int64]] = {}  # guid → (n, 2) cells it covers now
        self._posed_at: dict[str, tuple] = {}  # guid: the pose its footprint was drawn at (position, quat)
        self._in_band: set[str] = set()  # of those, the ones that block
        self._floors_seen: set[str] = set()  # the others: floors driven on whose edge the laser sees
        self._driven_from_s: dict[str, float] = {}  # constructed: from when it may be driven on (cured)
        self._curing: set[str] = set()  # constructed, driven on only once cured (sim time not reached)
        self._now_s = 0.0
        # floors driven on whose edge the laser sees (laser hits near them are no surprise): made at the
        # first such floor, so a site without one keeps no grid-sized count or field for them
        self._floor_counts: NDArray[np.int32] | None = None
        self._floor_distance: ClippedDistanceField | None = None
        self._sees: dict[str, bool] = {}
        self.footprints: dict[str, Footprint] = {}  # not carried, wherever they are (any height)
        self.carried: dict[str, str] = {}  # guid → robot id
        self._placed: set[str] = set()  # guids that left their yard slot for the structure
        self._applied: dict[str, tuple[object, ...]] = {}  # guid → the last pose message applied (its facts)
        self._settling: set[str] = set()  # placed, not yet joined: blocking whatever their height
        self.loose: set[str] = set()  # judged misplaced: lying where they are to be taken up for a retry
        self._without: tuple[tuple[object, ...], OccupancyGrid] | None = None  # inflated_grid_without's last
        self.version = 0
        self._cache: dict[str, object] = {}
        for guid, slot in layout.slots.items():
            if guid in self._components:
                self._set_footprint(
                    guid, posed_footprint(self._components[guid], slot.position_m, slot.quat_xyzw)
                )
        for component in in_place:  # built before the robots came: where the model puts it, from the start
            guid = component.guid
            self._components[guid] = component
            self._placed.add(guid)
            self._driven_from_s[guid] = -math.inf
            target = component.target_pose_world
            self._set_footprint(guid, posed_footprint(component, target.position_m, target.quat_xyzw))

    # --- updates ------------------------------------------------------------------------------------------

    def observe_pose(self, message: ComponentPoseMsg) -> bool:
        """Apply a component pose from physics; True when the map changed. Physics repeats the poses of
        components at rest: a pose equal to the last one applied changes nothing and costs a lookup."""
        guid = message.guid
        if guid not in self._components:
            return False
        seen = (
            message.pose.position_m,
            message.pose.quat_xyzw,
            message.attached_to,
            message.fixed,
            message.joined,
        )
        if self._applied.get(guid) == seen:
            return False
        self._applied[guid] = seen
        if message.attached_to is not None:
            self.carried[guid] = message.attached_to
            return self._clear(guid)
        self.carried.pop(guid, None)
        footprint = posed_footprint(self._components[guid], message.pose.position_m, message.pose.quat_xyzw)
        if message.fixed:
            self._placed.add(guid)
        was_settling = guid in self._settling
        if message.fixed and not message.joined:  # placed, not yet verified: keep off it (it may still move)
            self._settling.add(guid)
        else:
            self._settling.discard(guid)
        old = self.footprints.get(guid)
        if old is not None and _same_footprint(old, footprint) and was_settling == (guid in self._settling):
            return False
        posed_at = (message.pose.position_m, message.pose.quat_xyzw)
        if old is not None and self._posed_at.get(guid) == posed_at:
            footprint = old  # the very pose it was drawn at (only settled, or joined): the cells it covered
        self._posed_at[guid] = posed_at
        return self._set_footprint(guid, footprint)

    def observe_state(self, guid: str, state: ComponentState, sim_s: float = 0.0) -> bool:
        """A constructed component never placed on the bus so far is assumed at its BIM target; a floor
        constructed (or no longer) is driven on (or no longer), a cast one once it has cured; a part judged
        misplaced no longer settles."""
        if guid not in self._components:
            return False
        if state is ComponentState.MISPLACED:
            self.loose.add(guid)
        else:
            self.loose.discard(guid)
        if state is ComponentState.MISPLACED and guid in self._settling and guid in self.footprints:
            # judged where it came to rest: no longer settling, it blocks by its height as any part (a
            # misplaced flush footing walled in the robot that had set it, standing over its edge)
            self._settling.discard(guid)
            return self._set_footprint(guid, self.footprints[guid])
        constructed = state is ComponentState.CONSTRUCTED
        if constructed == (guid in self._driven_from_s) and (not constructed or guid in self._placed):
            return False
        if constructed:
            cast = self._components[guid].cast
            self._driven_from_s[guid] = sim_s + (cast.cure_s if cast is not None else 0.0)
            if self._driven_from_s[guid] > self._now_s:
                self._curing.add(guid)
        else:
            self._driven_from_s.pop(guid, None)
            self._curing.discard(guid)
        if guid in self._placed or not constructed:
            footprint = self.footprints.get(guid)
            return footprint is not None and self._set_footprint(guid, footprint)
        component = self._components[guid]
        self._placed.add(guid)
        self.carried.pop(guid, None)
        self._applied.pop(guid, None)
        pose = component.target_pose_world
        self._posed_at[guid] = (pose.position_m, pose.quat_xyzw)
        return self._set_footprint(guid, posed_footprint(component, pose.position_m, pose.quat_xyzw))

    def advance(self, sim_s: float) -> bool:
        """Sim time is ``sim_s``: a cast floor cured by now is driven on (True when the map changed)."""
        self._now_s = sim_s
        cured = [guid for guid in self._curing if self._driven_from_s[guid] <= sim_s]
        changed = False
        for guid in cured:
            self._curing.discard(guid)
            footprint = self.footprints.get(guid)
            if footprint is not None and guid in self._placed:
                changed |= self._set_footprint(guid, footprint)
        return changed

    def component_xy(self, guid: str) -> NDArray[np.float64] | None:
        """Centre of the component's footprint, None while carried."""
        footprint = self.footprints.get(guid)
        return None if footprint is None else footprint.centre_xy_m

    def components_near(self, xy_m: ArrayLike, within_m: float) -> list[tuple[str, float]]:
        """(name, distance) of the components that occupy the grid (in the robot's height band, or placed
        and not yet joined) within ``within_m`` of ``xy_m``, nearest first: what a robot that cannot get on
        has beside it (a fallen beam, a column), not a floor it drives on nor a slab a storey above it."""
        point = np.asarray(xy_m, float).reshape(1, 2)
        near = []
        for guid in self._in_band:
            footprint = self.footprints[guid]
            distance = float(footprint.distance_m(point)[0])
            if distance <= within_m:
                component = self._components[guid]
                near.append((component.name or guid, distance))
        return sorted(near, key=lambda item: (item[1], item[0]))

    def set_down(self, guid: str) -> bool:
        """Set down by physics where it was placed (fixed, or built), not carried."""
        return guid in self._placed and guid not in self.carried

    def in_yard(self, guid: str) -> bool:
        """Still at its yard slot (not carried, never placed)."""
        return guid in self.footprints and guid not in self._placed and guid not in self.carried

    # --- grids --------------------------------------------------------------------------------------------

    @property
    def geometry(self) -> OccupancyGrid:
        """An empty grid with the map's geometry (origin, resolution, shape)."""
        return self._geometry

    def static_grid(self) -> OccupancyGrid:
        """Fence, machines' set-ups and components in the robot's height band, not inflated."""
        return self._cached(
            "static", lambda: self._fence.with_occupied(self._fence.occupied | (self._counts > 0))
        )

    def inflated_grid(self, radius_m: float | None = None) -> OccupancyGrid:
        """:meth:`static_grid` inflated by ``radius_m`` (default: the robot radius plus margin, which is
        where the robot's centre may go), from the distance field."""
        radius = self.config.inflation_m if radius_m is None else radius_m
        self._inflated_within(radius)  # a radius beyond the distance bound is refused before the cache
        return self._cached(
            f"inflated:{radius:.4f}",
            lambda: self._geometry.with_occupied(self.static_distance_m() <= self._inflated_within(radius)),
        )

    def inflated_grid_without(self, guids: Sequence[str], radius_m: float) -> OccupancyGrid:
        """:meth:`inflated_grid` as if the components ``guids`` were not where they are (taken up): what a
        robot's check of a room's way out sees past parts lying there loose. The whole grid inflated
        again (kept until the map changes), so asked only when there are such parts."""

        def build() -> OccupancyGrid:
            counts = self._counts.copy()
            for guid in guids:
                cells = self._cells.get(guid)
                if cells is not None and guid in self._in_band:
                    counts[cells[:, 0], cells[:, 1]] -= 1  # as it was counted (_set_footprint)
            return inflate(self._fence.with_occupied(self._fence.occupied | (counts > 0)), radius_m)

        key = (self.version, radius_m, tuple(sorted(guids)))
        if self._without is None or self._without[0] != key:  # one kept: a key per set of parts would pile up
            self._without = (key, build())
        return self._without[1]

    def loose_targets(self, but: str | None = None) -> tuple[list[str], list[NDArray[np.float64]]]:
        """The parts set down and not joined to the structure (still settling, or judged misplaced:
        :attr:`loose`), in the band where they lie, other than ``but``; and the band outlines of their BIM
        targets, where they stand once joined or their retry sets them."""
        band_min, band_max = self.config.band_min_z_m, self.config.band_max_z_m
        lying = self.loose | self._settling
        guids = sorted(guid for guid in lying if guid != but and guid in self._in_band)
        outlines = []
        for guid in guids:
            target = self._components[guid].target_pose_world
            footprint = posed_footprint(self._components[guid], target.position_m, target.quat_xyzw)
            outlines.extend(footprint.outlines_meeting(band_min, band_max))
        return guids, outlines

    def free_at(self, xy_m: ArrayLike, radius_m: float | None = None) -> NDArray[np.bool_]:
        """Whether each point ``(n, 2)`` lies in a free cell of :meth:`inflated_grid` (outside the grid: not
        free), read from the distance field at those cells only: a robot on its way asks it of the rest of
        its path whenever the map changed, which must not cost a whole grid each time."""
        radius = self.config.inflation_m if radius_m is None else radius_m
        rc = self._geometry.world_to_cell(np.asarray(xy_m, float).reshape(-1, 2))
        inside = self._geometry.in_bounds(rc)
        free = np.zeros(len(rc), bool)
        distance = self.static_distance_m()[rc[inside, 0], rc[inside, 1]]
        free[inside] = distance > self._inflated_within(radius)
        return free

    def _inflated_within(self, radius_m: float) -> float:
        """The distance (m) up to which a cell lies in the inflation of ``radius_m`` (a hair more: cell
        centres exactly at the radius are in it)."""
        if radius_m >= STATIC_DISTANCE_MAX_M:
            raise ValueError(f"inflation {radius_m} m reaches the distance bound {STATIC_DISTANCE_MAX_M} m")
        return radius_m + 1e-9 * self.config.resolution_m

    def static_distance_m(self) -> NDArray[np.float64]:
        """Distance from every cell centre to the nearest cell of :meth:`static_grid` (m), up to
        ``STATIC_DISTANCE_MAX_M`` (farther reads that bound); read-only, kept current around each change."""
        return self._static_distance.distance_m

    def laser_grid(self) -> OccupancyGrid:
        """What the laser can see: the fence and the machines' set-ups (if they reach the laser's height) and
        tall enough components."""

        def build() -> OccupancyGrid:
            return self._geometry.with_occupied(self._seen_cells | (self._laser_counts > 0))

        return self._cached("laser", build)

    def laser_field_grid(self) -> OccupancyGrid:
        """The localiser's map: :meth:`laser_grid` without what is flatter than ``localise_min_top_m``,
        rasterised again at ``laser_resolution_m`` from the exact outlines (at the planning grid's 0.1 m,
        outlines lying on cell borders grow objects by a cell on one side: half a cell of bias)."""
        return self._cached("laser_fine", lambda: self._laser().grid())

    def laser_distance_m(self) -> NDArray[np.float64]:
        """The localiser's likelihood field: from every cell of :meth:`laser_field_grid` to the nearest
        surface (an occupied cell bordering a free one: inside a thick wall the distance grows again, so
        the likelihood peaks where the laser really hits), up to ``LASER_FIELD_MAX_M``; read-only, kept
        current around each change."""
        return self._laser().distance_m

    @property
    def laser_field_geometry(self) -> OccupancyGrid:
        """An empty grid with the geometry of :meth:`laser_field_grid` and :meth:`laser_distance_m`."""
        return self._laser().geometry

    def laser_segments(self) -> NDArray[np.float64]:
        """The exact outlines the laser can see, as segments ``(m, 2, 2)`` (world, m): the fence, the
        machines' set-ups and every component at the laser's height (the fine alignment before a
        placement, :mod:`.fine_alignment`), each with its outside on its right
        (:func:`.fine_alignment.outline_edges`)."""

        def build() -> NDArray[np.float64]:
            height = self.config.laser_height_m
            outlines = [
                outline
                for guid, seen in self._sees.items()
                if seen
                for outline in self.footprints[guid].outlines_meeting(height, height)
            ]
            outlines += [
                np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=float)
                for x0, y0, x1, y1 in self._walls_seen
            ]
            return outline_edges(outlines)

        return self._cached("laser_segments", build)

    def obstacle_points_xy_m(self) -> NDArray[np.float64]:
        """Centres of the static grid's occupied cells that border free space, ``(n, 2)`` (for the DWA)."""

        def build() -> NDArray[np.float64]:
            return self._geometry.cell_to_world(np.argwhere(outline(self.static_grid()).occupied))

        return self._cached("points", build)

    def unexplained_mask(self, points_xy_m: ArrayLike, beyond_m: float = 0.3) -> NDArray[np.bool_]:
        """Which points lie farther than ``beyond_m`` from anything in the static grid (inside the grid)."""
        pts = np.asarray(points_xy_m, float).reshape(-1, 2)
        rc = self._geometry.world_to_cell(pts)
        inside = self._geometry.in_bounds(rc)
        far = np.zeros(len(pts), bool)
        if len(pts):
            rows, cols = rc[inside, 0], rc[inside, 1]
            far[inside] = self.static_distance_m()[rows, cols] > beyond_m
            if self._floors_seen:
                far[inside] &= self._floor_layer()[1].distance_m[rows, cols] > beyond_m
        return far

    def unexplained(self, points_xy_m: ArrayLike, beyond_m: float = 0.3) -> NDArray[np.float64]:
        """The points farther than ``beyond_m`` from anything in the static grid (other robots, surprises)."""
        pts = np.asarray(points_xy_m, float).reshape(-1, 2)
        return pts[self.unexplained_mask(pts, beyond_m)]

    def planning_grid(self, marks_xy_m: ArrayLike = (), marks_extra_m: float = 0.0) -> OccupancyGrid:
        """The inflated grid plus the laser marks ``(n, 2)``, inflated ``marks_extra_m`` more (for A*)."""
        marks = np.asarray(marks_xy_m, float).reshape(-1, 2)
        if len(marks) == 0:
            return self.inflated_grid()
        rc = self._geometry.world_to_cell(marks)
        rc = rc[self._geometry.in_bounds(rc)]
        occupied = self.inflated_grid().occupied.copy()
        if len(rc) == 0:
            return self._geometry.with_occupied(occupied)
        # The marks are inflated in the window they can reach only (the whole grid of a large site is
        # millions of cells).
        radius = self.config.inflation_m + marks_extra_m
        reach = math.ceil(radius / self.config.resolution_m) + 1
        rows, cols = self._geometry.shape
        r0, c0 = (max(0, int(v) - reach) for v in rc.min(axis=0))
        r1, c1 = (min(n, int(v) + reach + 1) for v, n in zip(rc.max(axis=0), (rows, cols), strict=True))
        cells = np.zeros((r1 - r0, c1 - c0), bool)
        cells[rc[:, 0] - r0, rc[:, 1] - c0] = True
        marked = inflate(OccupancyGrid(cells, self.config.resolution_m, (0.0, 0.0)), radius)
        occupied[r0:r1, c0:c1] |= marked.occupied
        return self._geometry.with_occupied(occupied)

    # --- internals ----------------------------------------------------------------------------------------

    def _cached(self, name: str, build):
        entry = self._cache.get(name)
        if entry is None or entry[0] != self.version:  # type: ignore[index]
            entry = (self.version, build())
            self._cache[name] = entry
        return entry[1]  # type: ignore[index]

    def blocks(self, footprint: Footprint, guid: str | None = None) -> bool:
        """Whether a footprint occupies the grid: it meets the robot's height band, or it is a component
        placed and not yet joined to the structure (a footing flush with the ground, still settling, is not
        driven over)."""
        if guid is not None and guid in self._settling:
            return True
        if guid is not None and self.driven_on(guid, footprint):
            return False
        return footprint.z_max_m >= self.config.band_min_z_m and footprint.z_min_m <= self.config.band_max_z_m

    def driven_on(self, guid: str, footprint: Footprint) -> bool:
        """A floor the robot drives on: constructed at its place (cured), its top within the robot's step."""
        return (
            self._driven_from_s.get(guid, math.inf) <= self._now_s
            and guid in self._placed
            and guid not in self._settling
            and guid not in self.carried
            and drives_onto(self._components[guid], footprint.z_max_m, self.config.step_m)
        )

    def _seen(self, footprint: Footprint) -> bool:
        height = self.config.laser_height_m
        return bool(footprint.outlines_meeting(height, height))

    def _clear(self, guid: str) -> bool:
        self.footprints.pop(guid, None)
        cells = self._cells.pop(guid, None)
        if cells is None:
            return False
        if guid in self._in_band:
            self._in_band.discard(guid)
            self._counts[cells[:, 0], cells[:, 1]] -= 1
            self._static_distance.touch(cells)
        else:
            self._floors_seen.discard(guid)
            counts, field = self._floor_layer()
            counts[cells[:, 0], cells[:, 1]] -= 1
            field.touch(cells)
        if self._sees.pop(guid, False):
            self._laser_counts[cells[:, 0], cells[:, 1]] -= 1
        if self._laser_layer is not None:
            self._laser_layer.remove(guid)
        self.version += 1
        return True

    def _set_footprint(self, guid: str, footprint: Footprint) -> bool:
        # the same footprint again in the same layer (placed, then joined, then constructed): the cells it
        # covered, not rasterised again (every robot does it for every component, several times)
        same = self.footprints.get(guid) is footprint
        covered, covered_in_band = self._cells.get(guid), guid in self._in_band
        changed = self._clear(guid)
        self.footprints[guid] = footprint
        band = self.blocks(footprint, guid)
        seen = self._seen(footprint)
        if not (band or seen) or len(footprint.polygon_xy_m) < 3:
            return changed
        outlines = self._outlines(footprint, band)
        if same and covered is not None and covered_in_band == band:
            cells = covered
        else:
            cells = covered_cells(self._geometry, outlines)
        self._cells[guid] = cells
        if band:
            self._in_band.add(guid)
            self._counts[cells[:, 0], cells[:, 1]] += 1
            self._static_distance.touch(cells)
        else:  # a floor driven on that the laser sees
            self._floors_seen.add(guid)
            counts, field = self._floor_layer()
            counts[cells[:, 0], cells[:, 1]] += 1
            field.touch(cells)
        if seen:
            self._sees[guid] = True
            self._laser_counts[cells[:, 0], cells[:, 1]] += 1
            if self._laser_layer is not None and self._localised_on(footprint):
                self._laser_layer.add(guid, outlines)
        self.version += 1
        return True

    def _outlines(self, footprint: Footprint, band: bool) -> list[NDArray[np.float64]]:
        """What a footprint occupies on the grid: in the band, its parts that meet the band (a doorway under
        its lintel stays free), or its whole outline when none does (a part still settling blocks whatever
        its height); a floor driven on that the laser sees, its whole outline."""
        if not band:
            return [footprint.polygon_xy_m]
        return footprint.outlines_meeting(self.config.band_min_z_m, self.config.band_max_z_m) or [
            footprint.polygon_xy_m
        ]

    def _floor_layer(self) -> tuple[NDArray[np.int32], ClippedDistanceField]:
        """The counts and distance field of the floors driven on that the laser sees."""
        if self._floor_counts is None or self._floor_distance is None:
            counts = np.zeros(self._geometry.shape, np.int32)
            self._floor_counts = counts
            self._floor_distance = ClippedDistanceField(
                self._geometry.shape,
                self.config.resolution_m,
                STATIC_DISTANCE_MAX_M,
                lambda rows, cols: counts[rows, cols] > 0,
            )
        return self._floor_counts, self._floor_distance

    def _static_window(self, rows: slice, cols: slice) -> NDArray[np.bool_]:
        return self._fence.occupied[rows, cols] | (self._counts[rows, cols] > 0)

    def _localised_on(self, footprint: Footprint) -> bool:
        """Whether a footprint the laser sees is in the localiser's map (not flatter than its bound)."""
        return footprint.z_max_m >= self.config.localise_min_top_m

    def _laser(self) -> LaserLayer:
        """The localiser's map, made from what the map holds now when first asked (see
        :mod:`.laser_layer`), then kept current by :meth:`_set_footprint` and :meth:`_clear`."""
        if self._laser_layer is None:
            layer = LaserLayer(self._geometry.bounds_xy_m, self.config.laser_resolution_m, self._walls_seen)
            for guid, seen in self._sees.items():
                footprint = self.footprints[guid]
                if seen and self._localised_on(footprint):
                    layer.add(guid, self._outlines(footprint, guid in self._in_band))
            self._laser_layer = layer
        return self._laser_layer


def outline(grid: OccupancyGrid) -> OccupancyGrid:
    """Only the occupied cells that border a free cell (4-neighbourhood): the surfaces a laser can hit."""
    return grid.with_occupied(outline_cells(grid.occupied))


def _same_footprint(a: Footprint, b: Footprint, tolerance_m: float = 0.01) -> bool:
    if a.polygon_xy_m.shape != b.polygon_xy_m.shape:
        return False
    return bool(
        np.abs(a.polygon_xy_m - b.polygon_xy_m).max() < tolerance_m
        and abs(a.z_min_m - b.z_min_m) < tolerance_m
        and abs(a.z_max_m - b.z_max_m) < tolerance_m
    )


def heading_to(from_xy_m: ArrayLike, to_xy_m: ArrayLike) -> float:
    """Yaw (rad) of the direction from one point to another."""
    d = np.asarray(to_xy_m, float) - np.asarray(from_xy_m, float)
    return math.atan2(float(d[1]), float(d[0]))
