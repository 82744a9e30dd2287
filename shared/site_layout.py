"""The construction site around the building, as in the paper's Fig. 10: a yard, a robot depot and a fence.

Pure and deterministic, so physics (which builds it), robots (which navigate it) and the observer (which
draws it) compute the same site from the same manifest:

* **building** — the footprint of the target structure (its components' world bounding boxes, grown by a
  margin): where the BIM places it.
* **yard** — south of the building (−y), beyond a driving lane: every component lies flat on the ground,
  its longest extent along x and its shortest vertical, in rows one component deep. Rows come in
  back-to-back pairs with an aisle on each side of a pair, so every component faces an aisle from where a
  robot can reach it. Nothing overlaps and nothing lies on the building footprint.
* **depot** — west of the yard (−x): the robots' start poses, side by side, facing +x.
* **fence** — a rectangle around all of it (site hoarding), which also gives the robots' lasers something to
  localise against on an otherwise empty site.

Frames: the simulation world frame of :mod:`bimbot.shared.manifest` (metres, Z up).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from .manifest import Component

GROUND_CLEARANCE_M = 0.001  # yard components rest this far above the ground plane
LANE_M = 3.0  # driving lane between the building footprint and the yard, and around the site
AISLE_M = 2.0  # in front of every yard row
GAP_M = 0.4  # between components in a row
BUILDING_MARGIN_M = 1.0
MIN_ROW_LENGTH_M = 12.0
ROBOT_SPACING_M = 1.6
FENCE_THICKNESS_M = 0.2
FENCE_HEIGHT_M = 1.2


@dataclass(frozen=True)
class Rect:
    """Axis-aligned rectangle in the xy plane, metres."""

    min_xy: tuple[float, float]
    max_xy: tuple[float, float]

    @property
    def size(self) -> tuple[float, float]:
        return (self.max_xy[0] - self.min_xy[0], self.max_xy[1] - self.min_xy[1])

    def overlaps(self, other: Rect) -> bool:
        return (
            self.min_xy[0] < other.max_xy[0]
            and other.min_xy[0] < self.max_xy[0]
            and self.min_xy[1] < other.max_xy[1]
            and other.min_xy[1] < self.max_xy[1]
        )

    def grown(self, margin_m: float) -> Rect:
        return Rect(
            (self.min_xy[0] - margin_m, self.min_xy[1] - margin_m),
            (self.max_xy[0] + margin_m, self.max_xy[1] + margin_m),
        )


@dataclass(frozen=True)
class YardSlot:
    """Where a component starts: its frame's pose in the world, and the footprint it covers."""

    guid: str
    position_m: tuple[float, float, float]
    quat_xyzw: tuple[float, float, float, float]
    footprint: Rect
    height_m: float


@dataclass(frozen=True)
class SiteLayout:
    building: Rect
    yard: Rect
    depot: Rect
    fence: Rect  # inner edge of the fence
    slots: dict[str, YardSlot]
    robot_starts: tuple[tuple[float, float, float], ...]  # x, y, yaw

    @property
    def bounds(self) -> Rect:
        """Everything, the fence included."""
        return self.fence.grown(FENCE_THICKNESS_M)


def lying_rotation(extents_local_m: Sequence[float]) -> np.ndarray:
    """A proper rotation that lays a box flat: longest local extent along world x, shortest along z."""
    order = np.argsort(-np.asarray(extents_local_m, dtype=float), kind="stable")  # longest first
    matrix = np.zeros((3, 3))
    for world_axis, local_axis in enumerate(order):
        matrix[world_axis, local_axis] = 1.0
    if np.linalg.det(matrix) < 0:
        matrix[1] *= -1.0  # flip the middle axis: still flat, now right-handed
    return matrix


def laid_slot(component: Component, min_x: float, min_y: float) -> YardSlot:
    """``component`` lying flat with its footprint's corner at (min_x, min_y), resting on the ground."""
    low = np.array(component.bbox_local.min_m)
    high = np.array(component.bbox_local.max_m)
    rotation = lying_rotation(high - low)
    corners = np.array(
        [[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])]
    )
    turned = corners @ rotation.T
    t_min = turned.min(axis=0)
    size = turned.max(axis=0) - t_min
    translation = np.array([min_x, min_y, GROUND_CLEARANCE_M]) - t_min
    quat = Rotation.from_matrix(rotation).as_quat()
    return YardSlot(
        guid=component.guid,
        position_m=(float(translation[0]), float(translation[1]), float(translation[2])),
        quat_xyzw=(float(quat[0]), float(quat[1]), float(quat[2]), float(quat[3])),
        footprint=Rect((min_x, min_y), (min_x + float(size[0]), min_y + float(size[1]))),
        height_m=float(size[2]),
    )


def building_footprint(components: Sequence[Component]) -> Rect:
    low = np.min([c.bbox_world.min_m for c in components], axis=0)
    high = np.max([c.bbox_world.max_m for c in components], axis=0)
    return Rect((float(low[0]), float(low[1])), (float(high[0]), float(high[1]))).grown(BUILDING_MARGIN_M)


def plan_site(components: Sequence[Component], robots: int = 1) -> SiteLayout:
    """The site for ``components`` (in manifest order) and ``robots`` robots."""
    if not components:
        raise ValueError("a site needs at least one component")
    building = building_footprint(components)
    laid = [laid_slot(component, 0.0, 0.0) for component in components]
    row_length = max(building.size[0], *(slot.footprint.size[0] for slot in laid), MIN_ROW_LENGTH_M)
    rows = _fill_rows(laid, row_length)
    yard_min_x = building.min_xy[0]
    top_y = building.min_xy[1] - LANE_M  # the yard's north edge
    slots: dict[str, YardSlot] = {}
    cursor_y = top_y - AISLE_M
    for number, row in enumerate(rows):
        depth = max(laid[index].footprint.size[1] for index in row)
        cursor_x = yard_min_x
        for index in row:
            width, item_depth = laid[index].footprint.size
            # rows come in back-to-back pairs: the first faces the aisle north of it, the second the one south
            min_y = cursor_y - item_depth if number % 2 == 0 else cursor_y - depth
            slot = laid_slot(components[index], cursor_x, min_y)
            slots[slot.guid] = slot
            cursor_x += width + GAP_M
        cursor_y -= depth + (GAP_M if number % 2 == 0 else AISLE_M)
    yard_bottom = cursor_y if len(rows) % 2 == 0 else cursor_y - AISLE_M + GAP_M
    yard = Rect((yard_min_x, yard_bottom), (yard_min_x + row_length, top_y))
    depot_width = 2.0 * ROBOT_SPACING_M
    depot_height = max(1, robots) * ROBOT_SPACING_M
    depot = Rect(
        (yard.min_xy[0] - LANE_M - depot_width, top_y - depot_height), (yard.min_xy[0] - LANE_M, top_y)
    )
    starts = tuple(
        (depot.min_xy[0] + depot_width / 2.0, top_y - (i + 0.5) * ROBOT_SPACING_M, 0.0) for i in range(robots)
    )
    union = Rect(
        (min(building.min_xy[0], depot.min_xy[0]), min(yard.min_xy[1], depot.min_xy[1])),
        (max(building.max_xy[0], yard.max_xy[0]), building.max_xy[1]),
    )
    return SiteLayout(building, yard, depot, union.grown(LANE_M), slots, starts)


def _fill_rows(laid: list[YardSlot], row_length: float) -> list[list[int]]:
    """Indices of ``laid`` in rows no longer than ``row_length``, longest components first."""
    order = sorted(range(len(laid)), key=lambda index: (-laid[index].footprint.size[0], index))
    rows: list[list[int]] = []
    used = row_length + 1.0
    for index in order:
        width = laid[index].footprint.size[0]
        if rows and used + width <= row_length:
            rows[-1].append(index)
            used += width + GAP_M
        else:
            rows.append([index])
            used = width + GAP_M
    return rows
