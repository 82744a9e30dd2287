"""How many tower cranes a site erects for its building (pure, part of the site plan).

Why: one crane's jib covers a circle; a building wider than that needs more. The WBDG Medical-Dental
Clinic's structure (Revit 2011, 1,157 components) spans more than one 60 m jib hooks from outside it:
with the one tower crane of the default fleet, 88 of its parts were out of reach ("more tower cranes
round the building"), and with three all could be built; the site's planner should not need telling. A
fleet file's ``[[robots]]`` entry for a crane type may say ``up_to``: the site erects more of that type,
up to that many, where the cranes set up so far leave a part unhooked (the default fleet's tower crane:
``count = 1``, ``up_to = 4``).

The rule, for each crane entry with ``up_to`` above its ``count``, in the file's order:

* the parts that need a crane: lifted or panelised components no ground robot on site sets (too heavy or
  too high for each, :func:`set_by_crane_only`) that the crane type's chart lifts at some radius;
* the site is planned once with the fleet as given (its yard, depot and lane, which the cranes do not
  move), then one crane more is set up at a time by the site plan's rule for a further crane (where it
  hooks the most parts no crane before it hooks: :func:`.site_machines.plan_machines`), while some part
  that needs a crane lies beyond every crane's jib and the new crane's jib covers at least one of them;
  never more than ``up_to``. A part within a jib but too heavy for the chart at its radius is no reason
  for another crane: a precaster cuts it lighter for that radius (the converter's
  :mod:`bimbot.services.converter.crane_reach`), as the Revit office's walls were for its one crane.

Every service that resolves the fleet against the build sizes it the same way (``bimbot run`` passes the
count to physics as ``--cranes``; the converter cuts panels for the cranes so sized; ``bimbot fleet
check`` checks with them). Deterministic: the same components and fleet give the same count.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .construction_methods import ConstructionMethod
from .fleet import Fleet
from .manifest import Component
from .robot_description import Capability, RobotDescription
from .site_plan import SiteLayout

LIFTED_PARTS = frozenset({ConstructionMethod.LIFTED, ConstructionMethod.PANELISED})


def sized_cranes(fleet: Fleet, components: Sequence[Component]) -> Fleet:
    """``fleet`` with each crane entry that may grow (``up_to``) raised by the rule of the module
    docstring; the same fleet when none grows."""
    growing = [
        entry
        for entry in fleet.robots
        if entry.up_to is not None
        and entry.up_to > entry.count > 0
        and fleet.types[entry.type].crane is not None
        and fleet.types[entry.type].can(Capability.HOOK_LIFT)
    ]
    if not growing or not components:
        return fleet
    from .site_layout import lane_for, plan_site  # scipy: only for a fleet that may grow

    crane_set = {id(component) for component in set_by_crane_only(components, fleet.robot_types())}
    if not crane_set:
        return fleet  # the ground robots set everything: no site to plan
    needing = np.array([id(component) in crane_set for component in components], dtype=bool)
    layout = plan_site(components, fleet=fleet.robot_types())
    for entry in growing:
        count, most = entry.count, entry.up_to or entry.count
        left = _unhooked(fleet, components, needing, layout, lane_for(fleet.robot_types()))
        while left and count < most:
            more = fleet.with_counts({entry.type: count + 1})
            still = _unhooked(more, components, needing, layout, lane_for(more.robot_types()))
            if still >= left:
                break  # one more crane would hook none of the parts left
            fleet, count, left = more, count + 1, still
    return fleet


def set_by_crane_only(components: Sequence[Component], fleet: Sequence[RobotDescription]) -> list[Component]:
    """The lifted and panelised components no ground type on site sets (too heavy or too high for each
    that carries and places); ``fleet``: one description per robot."""
    ground = [
        item
        for item in fleet
        if item.can(Capability.DRIVE) and item.can(Capability.CARRY) and item.can(Capability.PLACE)
    ]
    return [
        component
        for component in components
        if component.method in LIFTED_PARTS
        and all(item.refusal(component.mass_kg, component.bbox_world.max_m[2]) is not None for item in ground)
    ]


def _unhooked(
    fleet: Fleet, components: Sequence[Component], needing: np.ndarray, layout: SiteLayout, lane_m: float
) -> int:
    """How many parts that need a crane (and some crane type of ``fleet`` lifts) lie beyond the jib of every
    crane of ``fleet``, set up by the site plan's rule beside ``layout``'s yard and depot."""
    from .site_machines import HookReach, plan_machines

    machines = [item for item in fleet.robot_types() if not item.can(Capability.DRIVE)]
    setups = plan_machines(
        machines, components, building=layout.building, yard=layout.yard, depot=layout.depot, lane_m=lane_m
    )
    liftable = np.zeros(len(components), dtype=bool)
    hooked = np.zeros(len(components), dtype=bool)
    reaches: dict[str, HookReach] = {}
    for machine, setup in zip(machines, setups, strict=True):
        if machine.crane is None or not machine.can(Capability.HOOK_LIFT):
            continue
        reach = reaches.setdefault(machine.name, HookReach.of(machine, components))
        liftable |= reach.radius_m >= 0.0
        distance_m = np.hypot(*(reach.centres_xy_m - np.asarray(setup.pose[:2], float)).T)
        hooked |= (distance_m >= reach.min_radius_m - 1e-9) & (distance_m <= machine.reach_m + 1e-9)
    return int((needing & liftable & ~hooked).sum())


def crane_count_words(before: Fleet, after: Fleet) -> list[str]:
    """One phrase per crane type ``after`` erects more of: ``3 tower_crane for the building's footprint,
    where the fleet file has 1 (up to 4)``."""
    counts = {entry.type: entry.count for entry in before.robots}
    return [
        f"{entry.count} {entry.type} for the building's footprint, where the fleet file has "
        f"{counts[entry.type]} (up to {entry.up_to})"
        for entry in after.robots
        if entry.type in counts and entry.count != counts[entry.type]
    ]
