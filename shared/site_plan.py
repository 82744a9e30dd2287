"""The site plan as data: rectangles, yard slots and the layout physics serves (``SiteInfoMsg.layout``).

Apart from :mod:`.site_layout` (which plans a site with numpy and scipy) so that the bus messages, which
every process imports, carry a plan without loading numpy (the agents' processes stay small). Frames: the
simulation world frame of :mod:`bimbot.shared.manifest` (metres, Z up).
"""

from __future__ import annotations

from dataclasses import dataclass

BUILDING_MARGIN_M = 1.0  # the building rectangle is its components' bounding boxes grown by this
FENCE_THICKNESS_M = 0.2
FENCE_HEIGHT_M = 1.2
# every machine that stands fixed fills its set-up rectangle (``SiteLayout.machines``) with a collision box
# from the ground up to at least this height (a crane's base, a truck's outriggers and the barrier around
# them, a crawler's tracks): what ground robots drive around and their lasers see, as they see the fence
MACHINE_BOX_HEIGHT_M = 1.0


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
    aisle_side: int = 0  # the side its aisle (or lane) is on: -1 west, +1 east (0: not in the yard)


@dataclass(frozen=True)
class SiteLayout:
    building: Rect
    yard: Rect
    depot: Rect
    fence: Rect  # inner edge of the fence
    slots: dict[str, YardSlot]
    robot_starts: tuple[tuple[float, float, float], ...]  # x, y, yaw
    aisles: tuple[Rect, ...] = ()  # between the pairs of rows, north–south across the yard
    staging: tuple[Rect, ...] = ()  # one per hook-lifting machine (robot id order): hand-offs put loads here
    machines: tuple[Rect, ...] = ()  # the base of each machine that stands fixed (robot id order)
    # the set-up positions (x, y, yaw) of each machine that stands fixed (robot id order, as ``machines``):
    # its main one first (its start), then those a truck-mounted machine that relocates may drive to
    setups: tuple[tuple[tuple[float, float, float], ...], ...] = ()

    @property
    def bounds(self) -> Rect:
        """Everything, the fence included."""
        return self.fence.grown(FENCE_THICKNESS_M)

    @property
    def structure(self) -> Rect:
        """The structure's own footprint (its components' bounding boxes): ``building`` less its margin."""
        return self.building.grown(-BUILDING_MARGIN_M)


GRID_MARGIN_M = 0.5  # site grids (robots' map, access check) reach this far beyond the fence's outer edge


def machine_setups(
    layout: SiteLayout, machine_index: int, start: tuple[float, float, float]
) -> tuple[tuple[float, float, float], ...]:
    """The set-up positions of the ``machine_index``-th machine that stands fixed (robot id order) whose
    start is ``start``: the plan's (its start first), or its start alone when the plan has none for it."""
    if machine_index < len(layout.setups):
        return tuple((float(x), float(y), float(yaw)) for x, y, yaw in layout.setups[machine_index])
    return (start,)


def machine_boxes(layout: SiteLayout) -> list[tuple[float, float, float, float]]:
    """The bases of the machines that stand fixed (cranes, pumps, block layers) as ``(x_min, y_min, x_max,
    y_max)`` boxes: obstacles a ground robot plans around, as it does around the fence."""
    return [(*rect.min_xy, *rect.max_xy) for rect in layout.machines]


def fence_boxes(layout: SiteLayout) -> list[tuple[float, float, float, float]]:
    """The four fence walls as ``(x_min, y_min, x_max, y_max)`` boxes outside the fence's inner edge."""
    (x0, y0), (x1, y1) = layout.fence.min_xy, layout.fence.max_xy
    t = FENCE_THICKNESS_M
    return [
        (x0 - t, y0 - t, x1 + t, y0),
        (x0 - t, y1, x1 + t, y1 + t),
        (x0 - t, y0, x0, y1),
        (x1, y0, x1 + t, y1),
    ]
