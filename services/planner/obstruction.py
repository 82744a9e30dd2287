"""Which failed components lie in the robots' way, who can clear one away, and to where (pure).

Why: a component that failed for good (it fell, slid, or was put down on the way and given back too often)
keeps its body where it came to rest. Lying across a doorway it cuts the robots off from the work behind
it, which then fails ``unreachable`` one component after the other. A site slings such a part and carries
it out of the way before it goes on; the planner does the same (:mod:`.clear_away`) for the bodies this
module says obstruct:

* its footprint in the robots' height band (``band_min_z_m`` .. ``band_max_z_m``, as the robots' site map
  and :mod:`bimbot.shared.site_access`: a beam resting at 3 m does not, a part lying on the ground does)
  covers ground, on the map's cells, that its BIM target does not, farther than ``margin_m`` from the
  target's outline (a part set 12 mm off its target is in nobody's way) and at least ``min_area_m2`` of it;
* it does not lie in its own yard slot or in a crane's staging area (loads lie there anyway).

A robot can clear it away when its type drives and carries (capabilities, never a kind) and its payload
takes the mass. It goes back to its own yard slot, the one place on site kept free for it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from bimbot.shared.footprint import footprint_distance_m, posed_footprint
from bimbot.shared.manifest import Component
from bimbot.shared.occupancy_grid import covered_cells, empty_grid
from bimbot.shared.robot_description import Capability, RobotDescription
from bimbot.shared.site_plan import Rect, YardSlot

Pose = tuple[tuple[float, float, float], tuple[float, float, float, float]]  # position (m), quat xyzw


@dataclass(frozen=True)
class ObstructionConfig:
    """The robots' map as the decision sees it (:class:`bimbot.services.robot.site_map.MapConfig`)."""

    resolution_m: float = 0.1  # the robots' map cells
    band_min_z_m: float = 0.02  # things entirely below this don't block
    band_max_z_m: float = 1.0  # things entirely above this don't block
    margin_m: float = 0.3  # ground this close to the target's outline is the target's own
    min_area_m2: float = 0.05  # less new ground than this is no obstruction
    in_place_margin_m: float = 0.5  # a body whose centre lies this close to its slot or a staging area


@dataclass(frozen=True)
class Obstruction:
    """A failed body in the robots' way: where its centre lies and how much new ground it covers."""

    centre_xy_m: tuple[float, float]
    area_m2: float


def obstruction(
    component: Component,
    pose: Pose,
    *,
    slot: YardSlot | None,
    staging: Sequence[Rect] = (),
    config: ObstructionConfig = ObstructionConfig(),
) -> Obstruction | None:
    """Whether ``component``'s body at ``pose`` obstructs the robots (see the module doc), or None."""
    footprint = posed_footprint(component, *pose)
    centre = footprint.centre_xy_m
    centre_xy = (float(centre[0]), float(centre[1]))
    areas = [*staging, *([slot.footprint] if slot is not None else [])]
    if any(_inside(area.grown(config.in_place_margin_m), centre_xy) for area in areas):
        return None
    outlines = footprint.outlines_meeting(config.band_min_z_m, config.band_max_z_m)
    if not outlines:
        return None
    points = np.concatenate(outlines)
    low, high = points.min(axis=0) - config.resolution_m, points.max(axis=0) + config.resolution_m
    grid = empty_grid((low[0], low[1], high[0], high[1]), config.resolution_m)
    cells = covered_cells(grid, outlines)
    if len(cells) == 0:
        return None
    centres = grid.cell_to_world(cells)
    target = component.target_pose_world
    target_outlines = posed_footprint(component, target.position_m, target.quat_xyzw).outlines_meeting(
        config.band_min_z_m, config.band_max_z_m
    )
    distance = np.full(len(centres), np.inf)
    for polygon in target_outlines:
        distance = np.minimum(distance, footprint_distance_m(polygon, centres))
    area_m2 = float(np.count_nonzero(distance > config.margin_m)) * config.resolution_m**2
    if area_m2 < config.min_area_m2:
        return None
    return Obstruction(centre_xy, area_m2)


def drives_and_carries(description: RobotDescription) -> bool:
    """A robot of this type could carry a body away, if its payload takes it."""
    return description.can(Capability.DRIVE) and description.can(Capability.CARRY)


def can_clear(description: RobotDescription, component: Component) -> bool:
    """A robot of this type can carry the body away: it drives and carries, and its payload takes it."""
    return drives_and_carries(description) and component.mass_kg <= description.payload_kg


def put_down_xy(slot: YardSlot | None) -> tuple[float, float] | None:
    """Where a cleared body goes: the centre of its own yard slot (None: it has none)."""
    if slot is None:
        return None
    area = slot.footprint
    return ((area.min_xy[0] + area.max_xy[0]) / 2.0, (area.min_xy[1] + area.max_xy[1]) / 2.0)


def _inside(area: Rect, xy: tuple[float, float]) -> bool:
    return area.min_xy[0] <= xy[0] <= area.max_xy[0] and area.min_xy[1] <= xy[1] <= area.max_xy[1]
