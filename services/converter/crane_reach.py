"""Precast parts a crane can set where they go: an element's lift from the crane's chart at its radius.

Why: the converter panelises an element heavier than the fleet's largest lift, a tower crane's chart at
its shortest radius (8 t at 15 m for the default one), but a crane lifts that only near its mast. The
Revit restaurant's 5.2 t infill slab lies 46 m from where the site plan sets the crane up, where its chart
lifts 2.3 t: lifted whole, it was out of reach. A precaster sizes the parts for the crane's lift at the
radius they are set at. So once every element is converted, the site is planned as physics will plan it
(:func:`bimbot.shared.site_layout.plan_site`, the same components, and the fleet the run puts on site: a
pump, block layer or piling rig with no work in the model stays off it, as ``bimbot run`` leaves it) and
every lifted or panelised component that no ground robot can set (too heavy or too high) and no crane on
site lifts at its target's hook radius gives its element a **lift limit**: the most a crane on site lifts
at the radius of the element's farthest target corner (so every part cut from it, wherever it lies in the
element, is within the chart). A part must also be picked where it starts: from its yard slot, or from the
crane's staging area after a ground robot carried it there; so the limit is no more than the larger of the
crane's lift at the part's yard slot and the largest ground payload that hands a part off. The converter
converts those elements again with that limit (:func:`.final_method.final_method`, :mod:`.panelise`): a
lifted wall, slab or ceiling becomes panelised, a panelised one is cut finer. An element no crane reaches
at all (beyond every chart's last radius) gets no limit; nor does one whose parts could not be cut: a run
gives their reason.

Pure: components and robot descriptions in, limits out.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from bimbot.shared.construction_methods import MethodLimits
from bimbot.shared.crane_count import set_by_crane_only
from bimbot.shared.manifest import Component
from bimbot.shared.robot_description import Capability, RobotDescription
from bimbot.shared.site_plan import Rect


@dataclass(frozen=True)
class LiftLimit:
    """What a part of one element may weigh, and why (for the method notes)."""

    lift_kg: float
    lifted_by: str  # "tower_crane r3 at 47.9 m from where the site plan sets it up"

    def applied(self, limits: MethodLimits) -> MethodLimits:
        """``limits`` with this lift, when it is the smaller."""
        if self.lift_kg >= limits.lift_capacity_kg:
            return limits
        return limits.model_copy(update={"lift_capacity_kg": self.lift_kg, "lifted_by": self.lifted_by})


def crane_lift_limits(
    components: Sequence[Component], fleet: Sequence[RobotDescription]
) -> dict[str, LiftLimit]:
    """Element GlobalId (a panel's parent) → its :class:`LiftLimit`, for the elements some part of which
    only a crane can set and no crane lifts at its target (see the module docstring); ``fleet``: one
    description per robot, in robot id order (:meth:`bimbot.shared.fleet.Fleet.robot_types`). The site is
    planned only when some part needs a crane."""
    needing = set_by_crane_only(components, fleet)
    if not needing or not any(item.can(Capability.HOOK_LIFT) for item in fleet):
        return {}
    from bimbot.shared.site_layout import plan_site  # scipy: only for a conversion that needs the plan

    layout = plan_site(components, fleet=fleet)
    cranes = [
        (f"{item.name} r{index + 1}", item, layout.robot_starts[index][:2])
        for index, item in enumerate(fleet)
        if item.crane is not None and item.can(Capability.HOOK_LIFT)
    ]
    boxes = element_boxes(components)
    carried_kg = max(
        (item.payload_kg for item in fleet if item.can(Capability.CARRY) and item.can(Capability.HAND_OFF)),
        default=0.0,
    )
    limits: dict[str, LiftLimit] = {}
    for component in needing:
        centre = _centre(component)
        slot = layout.slots.get(component.guid)
        pick = _rect_centre(slot.footprint) if slot is not None else None
        mass_kg = component.mass_kg
        if any(
            _lifts_at(item, math.dist(mast, centre), mass_kg)
            and (pick is None or mass_kg <= carried_kg or _lifts_at(item, math.dist(mast, pick), mass_kg))
            for _, item, mast in cranes
        ):
            continue  # a crane sets it, picked from its yard slot or from a hand-off beside the crane
        element = component.parent_guid or component.guid
        best = _best_lift(cranes, boxes[element])
        if best is not None and pick is not None and best.lift_kg > carried_kg:
            best = _picked_limit(cranes, pick, best, carried_kg)
        if best is None or best.lift_kg >= mass_kg:
            continue
        if element not in limits or best.lift_kg < limits[element].lift_kg:
            limits[element] = best
    return limits


def element_boxes(components: Sequence[Component]) -> dict[str, tuple[float, float, float, float]]:
    """Element GlobalId → its target's plan box (x0, y0, x1, y1): its own, or its panels' together."""
    boxes: dict[str, tuple[float, float, float, float]] = {}
    for component in components:
        key = component.parent_guid or component.guid
        low, high = component.bbox_world.min_m, component.bbox_world.max_m
        box = (low[0], low[1], high[0], high[1])
        if key in boxes:
            old = boxes[key]
            box = (min(old[0], box[0]), min(old[1], box[1]), max(old[2], box[2]), max(old[3], box[3]))
        boxes[key] = box
    return boxes


def _best_lift(
    cranes: Sequence[tuple[str, RobotDescription, Sequence[float]]], box: tuple[float, float, float, float]
) -> LiftLimit | None:
    """The most a crane lifts at the radius of the box's farthest corner from its mast; None when none
    lifts anything there."""
    best: LiftLimit | None = None
    for label, item, mast in cranes:
        assert item.crane is not None
        far_m = max(math.dist(mast, (x, y)) for x in (box[0], box[2]) for y in (box[1], box[3]))
        lift_kg = min(item.crane.payload_at(far_m), item.payload_kg)
        if lift_kg > 0 and (best is None or lift_kg > best.lift_kg):
            best = LiftLimit(lift_kg, f"{label} at {far_m:.1f} m, where the site plan sets it up")
    return best


def _picked_limit(
    cranes: Sequence[tuple[str, RobotDescription, Sequence[float]]],
    pick_xy_m: tuple[float, float],
    at_target: LiftLimit,
    carried_kg: float,
) -> LiftLimit:
    """``at_target`` no more than a part can be picked at: what a crane lifts at ``pick_xy_m`` (its yard
    slot) or, where that is less, what a ground robot carries to a crane's staging area."""
    lift_kg, label = carried_kg, "the largest ground payload that hands a part off to a crane"
    for name, item, mast in cranes:
        assert item.crane is not None
        radius_m = math.dist(mast, pick_xy_m)
        at_pick_kg = min(item.crane.payload_at(radius_m), item.payload_kg)
        if at_pick_kg > lift_kg:
            lift_kg, label = at_pick_kg, f"{name} at its yard slot, {radius_m:.1f} m from where it stands"
    return at_target if at_target.lift_kg <= lift_kg else LiftLimit(lift_kg, label)


def _rect_centre(rect: Rect) -> tuple[float, float]:
    return ((rect.min_xy[0] + rect.max_xy[0]) / 2.0, (rect.min_xy[1] + rect.max_xy[1]) / 2.0)


def _lifts_at(item: RobotDescription, radius_m: float, mass_kg: float) -> bool:
    assert item.crane is not None
    return item.crane.min_radius_m - 1e-9 <= radius_m <= item.crane.radius_for(mass_kg) + 1e-9


def _centre(component: Component) -> tuple[float, float]:
    low, high = component.bbox_world.min_m, component.bbox_world.max_m
    return ((low[0] + high[0]) / 2.0, (low[1] + high[1]) / 2.0)


def tightened(old: Mapping[str, LiftLimit], new: Mapping[str, LiftLimit]) -> dict[str, LiftLimit]:
    """``old`` and ``new`` together, the smaller lift where both name an element."""
    merged = dict(old)
    for key, limit in new.items():
        if key not in merged or limit.lift_kg < merged[key].lift_kg:
            merged[key] = limit
    return merged
