"""Before the build: which robot types can build each component, how, or why none can (pure).

Why: a component no robot on site can lift or place would otherwise be released, assigned and given back
again and again. The planner fails it at once with the reason a user can act on (another robot type,
another sequence) and builds the rest; ``bimbot fleet check`` prints the same table without building.

A component is buildable by a ground type whose payload and placement height allow it; by a tower crane
whose hook reaches its yard slot and its target with its mass (load chart) and whose jib is high enough;
or by a **hand-off**: a ground type that can carry it to the crane's staging area, then the crane (see
:mod:`.capability`). When nothing can: ``too_heavy`` when it is heavier than every payload on site;
``out_of_reach`` when a crane could lift it but not that far (the numbers of the nearest crane), or when it
is too high for every ground type; else the first type's refusal. Only types that can carry or hook a part
count for this; a site with none says so (``no_capable_robot``).

A component cast in place or laid is built where it stands by a machine that can ``pour`` or ``lay``
(:mod:`.work_in_place`; its mass never matters). When none can: ``no_capable_robot`` when no robot on site
has the capability (add a concrete pump or a block layer); ``out_of_reach`` when every such machine's
boom is too low for its top, or too short to cover its footprint from where it stands, or from any set-up
position of a machine that relocates (the numbers of the nearest one: the footprint's span from its nearest
set-up against its boom's reach).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from bimbot.shared.idle_machines import lifts_parts
from bimbot.shared.manifest import Component, MassSource
from bimbot.shared.reasons import Reason, ReasonCode
from bimbot.shared.robot_description import Capability
from bimbot.shared.site_layout import LANE_M, building_footprint
from bimbot.shared.site_plan import Rect, YardSlot

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
from .work_in_place import (
    WORK_MACHINE,
    WORK_WORDS,
    boom_span_m,
    can_work_on,
    work_capability,
    works_in_place,
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
    component: Component,
    robots: Sequence[SiteRobot],
    slot: YardSlot | None = None,
    building: Rect | None = None,
) -> Feasibility:
    """How ``component`` can be built by ``robots`` from its yard ``slot`` (``building``: the site plan's
    building rectangle, for a reason's advice on cranes)."""
    if works_in_place(component):
        return _in_place_feasibility(component, robots, building)
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
    lifters = [robot for robot in robots if lifts_parts(robot.description)]
    if not lifters:
        return Feasibility(component.guid, (), (), _no_lifter(component, robots))
    return Feasibility(component.guid, (), (), _why_not(component, lifters, where, building))


def _in_place_feasibility(
    component: Component, robots: Sequence[SiteRobot], building: Rect | None = None
) -> Feasibility:
    """A component built where it stands: the machines that can do its work from where they stand."""
    able = [
        robot
        for robot in robots
        if any(can_work_on(robot.description, pose[:2], component) for pose in robot.set_up_at)
    ]
    if able or not robots:
        routes = [
            f"{robot.description.name} ({robot.robot_id})" if robot.stands_fixed else robot.description.name
            for robot in able
        ]
        types = sorted({robot.description.name for robot in able})
        return Feasibility(component.guid, tuple(types), tuple(dict.fromkeys(routes)), None)
    return Feasibility(component.guid, (), (), _why_no_worker(component, robots, building))


#: How a reason names a method of work in place.
METHOD_WORDS = {"cast_in_place": "cast in place", "laid": "laid masonry", "driven": "a driven pile"}


def _why_no_worker(component: Component, robots: Sequence[SiteRobot], building: Rect | None = None) -> Reason:
    capability = work_capability(component)
    assert capability is not None
    words, method = WORK_WORDS[capability], METHOD_WORDS.get(component.method.value, component.method.value)
    workers = [robot for robot in robots if robot.description.can(capability)]
    if not workers:
        kinds = ", ".join(sorted({robot.description.name for robot in robots}))
        return Reason(
            code=ReasonCode.NO_CAPABLE_ROBOT,
            message=(
                f"it is {method}, and no robot on site can {words} (capability {capability.value}; types on "
                f"site: {kinds}): add {WORK_MACHINE[capability]} to the fleet (--fleet FLEET.toml)"
            ),
        )
    top_z = component.bbox_world.max_m[2]
    high = [robot for robot in workers if top_z <= robot.description.max_place_height_m + 1e-9]
    if not high:
        best = max(workers, key=lambda robot: robot.description.max_place_height_m)
        return Reason(
            code=ReasonCode.OUT_OF_REACH,
            message=(
                f"its top at {top_z:.2f} m is above the {best.description.name} {best.robot_id}'s working "
                f"height of {best.description.max_place_height_m:.2f} m, the highest of the robots on site "
                f"that can {words}"
            ),
            robot_id=best.robot_id,
        )
    spans = {robot.robot_id: _nearest_setup_span(robot, component) for robot in high}
    nearest = min(
        high, key=lambda robot: (spans[robot.robot_id][1] - robot.description.reach_m, robot.robot_id)
    )
    near, far, count = spans[nearest.robot_id]
    others = f" (the nearest of {len(high)} robots that can {words})" if len(high) > 1 else ""
    where = f" at the nearest of its {count} set-up positions" if count > 1 else ""
    return Reason(
        code=ReasonCode.OUT_OF_REACH,
        message=(
            f"its footprint spans {near:.1f}–{far:.1f} m from {nearest.description.name} {nearest.robot_id}"
            f"{where}, whose boom reaches {nearest.description.reach_m:.1f} m{others}"
            f"{_boom_advice(nearest, component, building, method)}"
        ),
        robot_id=nearest.robot_id,
    )


def _boom_advice(robot: SiteRobot, component: Component, building: Rect | None, method: str) -> str:
    """What a user can do about work in place beyond a boom: a longer boom, unless the component lies
    deeper inside the building than the boom reaches from any set-up round it (a lane and half the
    machine outside its edge); a site does such work from inside the building, which bimbot does not."""
    longer = f": {LONGER_BOOM} (reach_m in the fleet file) would cover it"
    if building is None or not robot.description.relocates:
        return longer
    inside_m, nearest_m = _inside_the_edge_m(robot, component, building)
    if nearest_m <= robot.description.reach_m:
        return longer
    return (
        f"; it lies {inside_m:.0f} m inside the building's edge, so no set-up round the building reaches it "
        f"(the nearest would stand {nearest_m:.0f} m away): a site does such work ({method}) {FROM_INSIDE}; "
        "a methods file can make it precast instead (bimbot methods show)"
    )


def _inside_the_edge_m(robot: SiteRobot, component: Component, building: Rect) -> tuple[float, float]:
    """(how far the component's target centre lies inside the building's edge, how far from it the
    nearest set-up of ``robot`` round the building could stand: a lane and half the machine further), m."""
    x, y = target_centre_xy(component)
    (x0, y0), (x1, y1) = building.min_xy, building.max_xy
    inside_m = min(x - x0, x1 - x, y - y0, y1 - y)
    return inside_m, inside_m + LANE_M + robot.description.length_m / 2.0


def _nearest_setup_span(robot: SiteRobot, component: Component) -> tuple[float, float, int]:
    """(nearest, farthest) distance from the robot's set-up whose boom comes nearest to covering the
    component (the smallest farthest distance) to its footprint, and how many set-ups it has."""
    spans = [boom_span_m(pose[:2], component) for pose in robot.set_up_at]
    near, far = min(spans, key=lambda span: span[1])
    return near, far, len(spans)


def _no_lifter(component: Component, robots: Sequence[SiteRobot]) -> Reason:
    kinds = ", ".join(sorted({robot.description.name for robot in robots}))
    method = component.method.value
    return Reason(
        code=ReasonCode.NO_CAPABLE_ROBOT,
        message=(
            f"it is {method} (a prefabricated part), and no robot on site can carry or lift it (capabilities "
            f"carry, hook_lift; types on site: {kinds}): add a ground robot or a tower crane to the fleet "
            "(--fleet FLEET.toml)"
        ),
    )


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


def _why_not(
    component: Component, robots: Sequence[SiteRobot], where: Where, building: Rect | None = None
) -> Reason:
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
    for robot in sorted(robots, key=lambda item: _hook_m(item, component)):  # the nearest crane first
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
                else f"whose load chart lifts its {mass:,.0f} kg out to a radius of {radius:.1f} m at most"
                + mass_note(component)
                + (_beyond_the_jib(robot, component, building) if far > spec.max_radius_m else "")
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
                f"its yard slot is {far:.1f} m from {robot.description.name} {robot.robot_id}, whose load "
                f"chart lifts its {mass:,.0f} kg out to a radius of {radius:.1f} m at most, and {hand_off}"
                + mass_note(component)
            ),
            robot_id=robot.robot_id,
        )
    # the refusal of the strongest robot that refuses: a crane's (its jib's height), not a Husky's payload
    refusals = [robot.description.refusal(mass, top_z) for robot in robots]
    _, refusal = max(
        ((robot, why) for robot, why in zip(robots, refusals, strict=True) if why is not None),
        key=lambda item: item[0].description.payload_kg,
    )
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


#: What a reason advises, as its words say it (and :func:`advice_tally` counts them).
LONGER_BOOM = "a longer boom"
FROM_INSIDE = "from inside the building, which bimbot does not"
CRANE_INSIDE = "a tower crane inside the footprint, which bimbot's site plan does not do"
MORE_CRANES = "a building this size takes more tower cranes"
ADVICE: tuple[tuple[str, str], ...] = (
    (MORE_CRANES, "more tower cranes round the building (a fleet file's tower_crane up_to)"),
    (CRANE_INSIDE, "a tower crane inside the footprint (not simulated)"),
    (
        FROM_INSIDE,
        "work in place from inside the building (not simulated), or a methods file making it precast",
    ),
    (LONGER_BOOM, "a longer boom"),
)

SEE_ITS_ROWS = " (see its rows)"  # a tally's label for the reasons that advise none of ADVICE

#: What a user can do about a target beyond the jib of every crane on site (a building wider than a jib
#: covers: a site erects more cranes round it).
BEYOND_THE_JIB_HINT = (
    f"; it lies beyond the jib: {MORE_CRANES} (the site erects them up to the tower_crane entry's up_to: "
    "raise it in a fleet file given with --fleet; each further crane is set up where it hooks what those "
    "before it do not)"
)


def _hook_m(robot: SiteRobot, component: Component) -> float:
    """A crane's hook radius over ``component``'s target; infinite for a robot without a hook."""
    return math.inf if robot.description.crane is None else target_hook_radius_m(robot, component)


def _beyond_the_jib(robot: SiteRobot, component: Component, building: Rect | None) -> str:
    """The advice for a target beyond ``robot``'s jib: more cranes round the building, unless the target
    lies deeper inside the building than any crane set up round it hooks (at least a lane and half the
    crane's base outside its edge); a site puts a crane inside such a footprint, which the plan does not."""
    spec = robot.description.crane
    assert spec is not None
    if building is None:
        return BEYOND_THE_JIB_HINT
    inside_m, nearest_m = _inside_the_edge_m(robot, component, building)
    if nearest_m <= spec.max_radius_m:
        return BEYOND_THE_JIB_HINT
    return (
        f"; it lies {inside_m:.0f} m inside the building's edge, so no crane set up round the building "
        f"hooks it (the nearest would stand {nearest_m:.0f} m away, beyond a {spec.max_radius_m:.0f} m jib): "
        f"a site this wide stands {CRANE_INSIDE}"
    )


def feasibility_table(
    components: Sequence[Component], robots: Sequence[SiteRobot], slots: dict[str, YardSlot]
) -> list[Feasibility]:
    """One row per component, in manifest order."""
    building = building_footprint(components) if components else None
    return [component_feasibility(item, robots, slots.get(item.guid), building) for item in components]


def infeasible(
    components: Sequence[Component], robots: Sequence[SiteRobot], slots: dict[str, YardSlot]
) -> dict[str, Reason]:
    """GUID → reason for every component that no robot on site can build."""
    return {
        row.guid: row.reason for row in feasibility_table(components, robots, slots) if row.reason is not None
    }


def advice_tally(reasons: Sequence[Reason]) -> list[tuple[str, int]]:
    """How many of ``reasons`` advise each fix of :data:`ADVICE` (by the words the reason carries), most
    first; a reason that advises none counts under its code. For ``fleet check --summary``'s last word: the
    Revit office's 4,105 rows of reasons, in 150 lines, left a new user asking what would build the rest."""
    tally: dict[str, int] = {}
    for reason in reasons:
        label = next((label for words, label in ADVICE if words in reason.message), None)
        label = label or f"{reason.code.value}{SEE_ITS_ROWS}"
        tally[label] = tally.get(label, 0) + 1
    return sorted(tally.items(), key=lambda item: (-item[1], item[0]))
