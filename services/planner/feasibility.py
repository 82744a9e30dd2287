"""Before the build: which robot types can build each component, how, or why none can (pure).

Why: a component no robot on site can lift or place would otherwise be released, assigned and given back
again and again. The planner fails it at once with the reason a user can act on (another robot type,
another sequence) and builds the rest; ``bimbot fleet check`` prints the same table without building.

A component is buildable by a ground type whose payload and placement height allow it; by a tower crane
whose hook reaches its yard slot and its target with its mass (load chart) and whose jib is high enough;
or by a **hand-off**: a ground type that can carry it to the crane's staging area, then the crane (see
:mod:`.capability`). When nothing can: ``too_heavy`` when it is heavier than every payload on site;
``out_of_reach`` when a crane could lift it but not that far (the numbers of the nearest crane), or when it
is too high for every ground type; else the first type's refusal.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from bimbot.shared.manifest import Component, MassSource
from bimbot.shared.reasons import Reason, ReasonCode
from bimbot.shared.robot_description import Capability
from bimbot.shared.site_plan import YardSlot

from .capability import (
    SiteRobot,
    Where,
    can_build_from,
    can_carry,
    can_place,
    staging_reached,
    target_centre_xy,
    target_hook_radius_m,
)


@dataclass(frozen=True)
class Feasibility:
    """One component: how it can be built (``routes``: "carrier", "carrier → tower_crane (hand-off)"), the
    robot types involved, or the reason none can."""

    guid: str
    capable_types: tuple[str, ...]
    routes: tuple[str, ...]
    reason: Reason | None  # None when some route exists


def slot_where(component: Component, slot: YardSlot | None) -> Where:
    """The component lying in its yard slot (or at its target when it has no slot)."""
    if slot is None:
        return Where(target_centre_xy(component), component.bbox_world.max_m[2])
    centre = (
        (slot.footprint.min_xy[0] + slot.footprint.max_xy[0]) / 2.0,
        (slot.footprint.min_xy[1] + slot.footprint.max_xy[1]) / 2.0,
    )
    return Where(centre, slot.height_m)


def component_feasibility(
    component: Component, robots: Sequence[SiteRobot], slot: YardSlot | None = None
) -> Feasibility:
    """How ``component`` can be built by ``robots`` from its yard ``slot``."""
    where = slot_where(component, slot)
    routes: list[str] = []
    types: set[str] = set()
    for robot in robots:
        name = robot.description.name
        if can_build_from(robot, component, where):
            routes.append(f"{name} ({robot.robot_id})" if robot.stands_fixed else name)
            types.add(name)
        elif (
            robot.description.can(Capability.HOOK_LIFT)
            and can_place(robot, component)
            and staging_reached(robot, component)
        ):
            carriers = sorted({r.description.name for r in robots if can_carry(r, component)})
            for carrier in carriers:
                routes.append(f"{carrier} → {name} ({robot.robot_id}, hand-off)")
                types.update((carrier, name))
    routes = list(dict.fromkeys(routes))
    if routes or not robots:
        return Feasibility(component.guid, tuple(sorted(types)), tuple(routes), None)
    return Feasibility(component.guid, (), (), _why_not(component, robots, where))


#: How a mass the IFC does not state was estimated (the converter's chain, ``mass.py``): a reason that turns
#: on the mass says so, since a user may know better (a hollow-core slab, a lighter material).
ESTIMATED_MASS = {
    MassSource.MATERIAL_DENSITY_PROPERTY: "its mesh volume × its material's MassDensity",
    MassSource.MATERIAL_DENSITY_TABLE: "its mesh volume × a typical density for its material's name",
    MassSource.DEFAULT_DENSITY: "its mesh volume × a default density (no material the converter knows)",
}


def mass_note(component: Component) -> str:
    """``"; the mass is an estimate, <how>: …"`` when the IFC states no weight for it, else ``""``."""
    how = ESTIMATED_MASS.get(component.mass_source)
    return f"; the mass is an estimate, {how}: the IFC states no weight for it" if how else ""


def _why_not(component: Component, robots: Sequence[SiteRobot], where: Where) -> Reason:
    mass, top_z = component.mass_kg, component.bbox_world.max_m[2]
    kinds = ", ".join(sorted({robot.description.name for robot in robots}))
    heaviest = max((robot.description for robot in robots), key=lambda item: item.payload_kg)
    if mass > heaviest.payload_kg:
        return Reason(
            code=ReasonCode.TOO_HEAVY,
            message=(
                f"{mass:,.0f} kg exceeds the largest payload on site "
                f"({heaviest.payload_kg:,.0f} kg, robot type {heaviest.name}; types on site: {kinds})"
                + mass_note(component)
            ),
        )
    for robot in robots:
        spec = robot.description.crane
        if spec is None or robot.description.refusal(mass, top_z) is not None:
            continue  # only a hook's load chart turns on the distance
        base = robot.home_xy_yaw[:2]
        radius = spec.radius_for(mass)
        if not can_place(robot, component):
            far = target_hook_radius_m(robot, component)
            limit = (
                f"whose trolley comes no nearer than {spec.min_radius_m:.1f} m"
                if far < spec.min_radius_m
                else f"whose load chart lifts {mass:,.0f} kg to {radius:.1f} m at most{mass_note(component)}"
            )
            return Reason(
                code=ReasonCode.OUT_OF_REACH,
                message=(
                    f"its target (the centre of its footprint) is {far:.1f} m from "
                    f"{robot.description.name} {robot.robot_id}, {limit}"
                ),
                robot_id=robot.robot_id,
            )
        far = math.dist(base, where.xy_m)
        carriers = [r.description for r in robots if r.description.can(Capability.HAND_OFF)]
        strongest = max((item.payload_kg for item in carriers), default=0.0)
        if mass > strongest:
            hand_off = (
                f"no ground robot can carry it to the crane (largest ground payload {strongest:,.0f} kg; a "
                f"ground robot type that carries {mass:,.0f} kg, in a fleet file given with --fleet, could "
                "bring it to the crane's staging area)"
            )
        else:
            hand_off = f"its staging area is not within {radius:.1f} m of it either"
        return Reason(
            code=ReasonCode.OUT_OF_REACH,
            message=(
                f"its yard slot is {far:.1f} m from {robot.description.name} {robot.robot_id}, whose "
                f"load chart lifts {mass:,.0f} kg to {radius:.1f} m at most, and {hand_off}"
                + mass_note(component)
            ),
            robot_id=robot.robot_id,
        )
    refusals = [robot.description.refusal(mass, top_z) for robot in robots]
    refusal = next(refusal for refusal in refusals if refusal is not None)
    if refusal.code is ReasonCode.OUT_OF_REACH and not any(
        robot.description.can(Capability.HOOK_LIFT) for robot in robots
    ):
        return refusal.model_copy(update={"message": refusal.message + NO_CRANE_HINT})
    return refusal


#: What a user can do about a component too high for every ground robot when no crane is on site.
NO_CRANE_HINT = (
    "; no tower crane is on site to place it higher (the default fleet has one: run without --robots, "
    "or give --fleet a fleet file with a tower_crane)"
)


def feasibility_table(
    components: Sequence[Component], robots: Sequence[SiteRobot], slots: dict[str, YardSlot]
) -> list[Feasibility]:
    """One row per component, in manifest order."""
    return [component_feasibility(item, robots, slots.get(item.guid)) for item in components]


def infeasible(
    components: Sequence[Component], robots: Sequence[SiteRobot], slots: dict[str, YardSlot]
) -> dict[str, Reason]:
    """GUID → reason for every component that no robot on site can build."""
    return {
        row.guid: row.reason for row in feasibility_table(components, robots, slots) if row.reason is not None
    }
