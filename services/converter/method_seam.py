"""Stand-in for the method decision until it lands in main: the three names the panel writer calls.

The method decision (which element is lifted, panelised, cast…) is written on another branch; the panel
writer needs only this much of it: a decision per GlobalId (given through ``ShardContext.decisions``), the
limits a panel must keep (``ShardContext.limits``) and ``final_method(decision, mass_kg, size, ifc_class,
limits)``, asked once the element's mass is known. Here a decision is taken as given and no rule decides:
an element with no decision is lifted. When the real decision lands, this module becomes its imports.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

from bimbot.shared.construction_methods import ConstructionMethod, MethodSource
from bimbot.shared.fleet import default_fleet

# a semitrailer's deck (13.6 m × 2.55 m); wall panels stand upright on an inloader, up to 3.6 m high
TRANSPORT_SIZE_M = (13.6, 2.55, 3.6)


@dataclass(frozen=True)
class MethodDecision:
    method: ConstructionMethod
    source: MethodSource = MethodSource.RULE
    note: str = ""
    host_guid: str | None = None


@dataclass(frozen=True)
class MethodLimits:
    """What one piece may be: the heaviest lift of the fleet and the load a truck carries (l × w × h)."""

    lift_capacity_kg: float
    transport_size_m: tuple[float, float, float] = TRANSPORT_SIZE_M


@cache
def default_limits() -> MethodLimits:
    """The default fleet's largest payload on site (its tower crane's load chart: 4,000 kg) and a truck."""
    return MethodLimits(max(robot.payload_kg for robot in default_fleet().on_site().values()))


def final_method(
    decision: MethodDecision | None,
    mass_kg: float,
    size: tuple[float, float, float],
    ifc_class: str,
    limits: MethodLimits,
) -> MethodDecision:
    """The method once the element's mass and size (m) are known: here the decision as given, else lifted."""
    del mass_kg, size, ifc_class, limits  # the real rule weighs them
    return decision if decision is not None else MethodDecision(ConstructionMethod.LIFTED)
