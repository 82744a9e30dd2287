"""Work in place: which robot type can cast, lay or drive a component, and how long the work takes (pure).

Why apart from :mod:`.capability`: a cast-in-place, laid or driven component is never carried. It is built
where it stands by a machine that can do its method's work (the shared ``WORK_CAPABILITY``: ``pour``
for cast in place, ``lay`` for laid, ``pile`` for a driven pile); its mass does not matter. A machine
that stands fixed (a boom pump, a block layer, a piling rig) builds it when its boom covers the whole
target footprint from where it stands (the shared reach rule,
:meth:`~bimbot.shared.robot_description.RobotDescription.reaches`); a machine that drives goes there. In
both cases the target's top must lie within the machine's ``max_place_height_m``.

Durations (sim seconds): a cast element's own work record (``Component.cast``: formwork, then pour; the
cure is not the crew's time, it holds what rests on it); a laid element's blocks
(``ceil(volume / block volume)``, at least one a course, the block of the machine's ``laying`` spec) at
its ``blocks_per_h``: the counts the robot's own executor works by; a driven pile's pitch and its length
(its height) at the rig's rate of penetration (its ``piling`` spec).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from bimbot.shared.construction_methods import ConstructionMethod
from bimbot.shared.footprint import Footprint, footprint_distance_m, posed_footprint
from bimbot.shared.manifest import Component
from bimbot.shared.robot_description import Capability, RobotDescription
from bimbot.shared.work_methods import WORK_CAPABILITY, pile_length_m

#: How a reason names the work a capability does.
WORK_WORDS: dict[Capability, str] = {
    Capability.POUR: "pour concrete",
    Capability.LAY: "lay masonry",
    Capability.PILE: "drive piles",
}

#: What a user adds to the fleet for it.
WORK_MACHINE: dict[Capability, str] = {
    Capability.POUR: "a concrete pump",
    Capability.LAY: "a block-laying robot",
    Capability.PILE: "a piling rig",
}


def work_capability(component: Component) -> Capability | None:
    """The capability ``component``'s method needs (None: it is carried and placed, lifted or panelised)."""
    return WORK_CAPABILITY.get(component.method)


def works_in_place(component: Component) -> bool:
    """Built where it stands (cast in place, laid, driven), not carried."""
    return component.method in WORK_CAPABILITY


_FOOTPRINTS: dict[int, tuple[Component, Footprint]] = {}  # id → (the component, kept alive; its footprint)
_FOOTPRINTS_MAX = 50_000


def target_footprint(component: Component) -> Footprint:
    """``component``'s footprint at its BIM target, computed once per component (a component is frozen):
    the planner asks for it for every released task and robot at every step. The footprint is shared:
    callers must not change its arrays."""
    entry = _FOOTPRINTS.get(id(component))
    if entry is not None and entry[0] is component:
        return entry[1]
    pose = component.target_pose_world
    footprint = posed_footprint(component, pose.position_m, pose.quat_xyzw)
    if len(_FOOTPRINTS) >= _FOOTPRINTS_MAX:
        _FOOTPRINTS.clear()
    _FOOTPRINTS[id(component)] = (component, footprint)
    return footprint


def boom_span_m(base_xy_m: Sequence[float], component: Component) -> tuple[float, float]:
    """(nearest, farthest) horizontal distance from ``base_xy_m`` to the target footprint (m)."""
    polygon = target_footprint(component).polygon_xy_m
    near = float(footprint_distance_m(polygon, [base_xy_m[:2]])[0])
    far = max(math.dist(base_xy_m[:2], corner) for corner in polygon.tolist())
    return near, far


def can_work_on(description: RobotDescription, base_xy_m: Sequence[float], component: Component) -> bool:
    """``description`` (standing at ``base_xy_m`` when it stands fixed) can do ``component``'s work."""
    capability = work_capability(component)
    if capability is None or not description.can(capability):
        return False
    if component.bbox_world.max_m[2] > description.max_place_height_m + 1e-9:
        return False
    if not description.can(Capability.STAND_FIXED):
        return True  # it drives to the component
    return description.reaches(base_xy_m[:2], target_footprint(component).polygon_xy_m)


def blocks_needed(component: Component, description: RobotDescription) -> int:
    """Blocks of ``description``'s laying spec in ``component``: its volume in blocks, at least one a course
    (the robot's own count, :mod:`bimbot.services.robot.site_work`)."""
    laying = description.laying
    if laying is None:
        return 0
    height_m = max(component.bbox_world.max_m[2] - component.bbox_world.min_m[2], laying.block_height_m)
    courses = max(1, math.ceil(height_m / laying.block_height_m - 1e-6))
    block_m3 = laying.block_length_m * laying.block_height_m * laying.block_width_m
    return max(courses, math.ceil(component.volume_m3 / block_m3))


def work_s(component: Component, description: RobotDescription | None) -> float:
    """Sim seconds of ``component``'s work in place by ``description``: formwork + pour for a cast one (its
    ``cast`` record; 0 when the converter gave none), the blocks at the machine's rate for a laid one (0
    without a machine that lays), the pitch and the drive for a driven pile; 0 for anything carried."""
    if component.method is ConstructionMethod.CAST_IN_PLACE:
        cast = component.cast
        return cast.formwork_s + cast.pour_s if cast is not None else 0.0
    if component.method is ConstructionMethod.LAID and description is not None:
        laying = description.laying
        if laying is not None:
            return 3600.0 * blocks_needed(component, description) / laying.blocks_per_h
    if component.method is ConstructionMethod.DRIVEN and description is not None:
        piling = description.piling
        if piling is not None:
            return piling.drive_s(pile_length_m(component))
    return 0.0


def cure_s(component: Component) -> float:
    """Sim seconds after a cast element is constructed before what rests on it may be placed (0: none)."""
    if component.method is ConstructionMethod.CAST_IN_PLACE and component.cast is not None:
        return component.cast.cure_s
    return 0.0
