"""Stand-in for the method decision until it lands in main: the names the panel writer calls.

The method decision (which element is lifted, panelised, cast…) is written on another branch, with
``MethodDecision`` and ``MethodLimits`` in ``shared/construction_methods.py`` and ``final_method`` in the
converter. The panel writer needs only this much of it, under the same names and fields: a decision per
GlobalId (``ShardContext.decisions``), the limits a panel must keep (``ShardContext.limits``) and
``final_method(decision, mass_kg, size_m, ifc_class, limits)``, asked once the element's mass is known.
Here a decision is taken as given and no rule decides: an element without one is lifted. When the real
decision lands, this module becomes its imports.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cache

from bimbot.shared.construction_methods import ConstructionMethod, MethodSource
from bimbot.shared.fleet import default_fleet

# a semitrailer's deck (13.6 m × 2.55 m); wall panels stand on an inloader's low deck: 4.0 m less 0.3 m
TRANSPORT_SIZE_M = (13.6, 2.55, 3.7)


@dataclass(frozen=True)
class MethodDecision:
    method: ConstructionMethod
    source: MethodSource
    note: str = ""
    host_guid: str | None = None


@dataclass(frozen=True)
class MethodLimits:
    """What a prefabricated part may weigh and measure: the fleet's largest lift, and a road truck's load."""

    lift_capacity_kg: float
    transport_length_m: float
    transport_width_m: float
    transport_height_m: float
    lifted_by: str = ""


DEFAULT_DECISION = MethodDecision(
    method=ConstructionMethod.LIFTED, source=MethodSource.RULE, note="the default"
)


@cache
def default_limits() -> MethodLimits:
    """The default fleet's largest payload on site (its tower crane's load chart) and a truck's load."""
    strongest = max(default_fleet().on_site().values(), key=lambda robot: robot.payload_kg)
    length, width, height = TRANSPORT_SIZE_M
    return MethodLimits(
        lift_capacity_kg=strongest.payload_kg,
        lifted_by=strongest.name,
        transport_length_m=length,
        transport_width_m=width,
        transport_height_m=height,
    )


def final_method(
    decision: MethodDecision,
    mass_kg: float,
    size_m: Sequence[float],
    ifc_class: str,
    limits: MethodLimits,
) -> MethodDecision:
    """The method once the element's mass and size are known: here the decision as given."""
    del mass_kg, size_m, ifc_class, limits  # the real rule weighs them
    return decision
