"""An element's method once its mass and size are known: too heavy to lift or too large to carry.

A prefabricated part must be lifted by the fleet and carried on a road truck. A lifted element heavier
than the fleet's largest lift (:func:`method_limits`: the largest payload among the robot types on site
that carry or hook a load and place it, for a crane its load chart's largest) or larger than a truck's
load is turned into what its decision says (``if_too_heavy``): panelised (a wall, a slab, a roof), or
cast in place (a concrete column or beam); ``method_source`` ``rule``, the note with the numbers. Without
such a fallback it stays lifted and the note says why it may not be (a 25 m steel beam travels under a
permit; a planner finds it too heavy). The user's own choice is never changed. An element whose target
lies in the ground first takes its decision's ``if_in_ground``.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import cache

from bimbot.shared.construction_methods import (
    ConstructionMethod,
    MethodDecision,
    MethodLimits,
    MethodSource,
)
from bimbot.shared.fleet import Fleet, default_fleet
from bimbot.shared.methods_file import MaterialKind, MethodsFile, load_methods
from bimbot.shared.robot_description import Capability

SPLIT_NOTE = ": split into precast panels"  # how a note of a part too heavy to lift whole ends

DEFAULT_DECISION = MethodDecision(
    method=ConstructionMethod.LIFTED, source=MethodSource.RULE, note="by default"
)


def method_limits(fleet: Fleet, methods: MethodsFile) -> MethodLimits:
    """The largest payload of the robot types on site that lift (carry or hook a load and place it; all
    types when none is on site), the file's truck load and the longest boom of the types that lay."""
    types = list((fleet.on_site() or fleet.types).values())
    lifters = [
        description
        for description in types
        if description.can(Capability.PLACE)
        and (description.can(Capability.CARRY) or description.can(Capability.HOOK_LIFT))
    ]
    strongest = max(lifters or types, key=lambda description: description.payload_kg)
    layers = [description.reach_m for description in types if description.can(Capability.LAY)]
    return MethodLimits(
        lift_capacity_kg=strongest.payload_kg,
        lifted_by=strongest.name,
        transport_length_m=methods.transport.length_m,
        transport_width_m=methods.transport.width_m,
        transport_height_m=methods.transport.height_m,
        lay_reach_m=max(layers, default=None),
    )


@cache
def default_limits() -> MethodLimits:
    """:func:`method_limits` of the default fleet and methods (a shard context without limits)."""
    return method_limits(default_fleet(), load_methods())


def fits_truck(size_m: Sequence[float], limits: MethodLimits) -> bool:
    """Whether a part of these extents fits a truck's load: its longest side along the deck, the other two
    across it and standing up (the larger of those two in the larger of width and height)."""
    longest, middle, shortest = sorted((float(value) for value in size_m), reverse=True)
    length, width, height = limits.transport_size_m
    across = sorted((width, height), reverse=True)
    return longest <= length and middle <= across[0] and shortest <= across[1]


def final_method(
    decision: MethodDecision | None,
    mass_kg: float,
    size_m: Sequence[float],
    ifc_class: str,
    limits: MethodLimits,
    *,
    in_ground: bool = False,
) -> MethodDecision:
    """The method ``decision`` settles into for an element of ``mass_kg`` whose own bounding box measures
    ``size_m`` (see the module docstring); the result carries no alternatives. No decision: lifted by the
    default rule."""
    decision = decision or DEFAULT_DECISION
    if in_ground and decision.if_in_ground is not None:
        decision = decision.if_in_ground.model_copy(update={"material": decision.material})
    settled = decision.model_copy(update={"if_in_ground": None, "if_too_heavy": None})
    if decision.method is not ConstructionMethod.LIFTED or decision.source is MethodSource.USER:
        return settled
    problems = []
    if mass_kg > limits.lift_capacity_kg:
        who = f" ({limits.lifted_by})" if limits.lifted_by else ""
        problems.append(
            f"{mass_kg:,.0f} kg is more than the fleet lifts, {limits.lift_capacity_kg:,.0f} kg{who}"
        )
    if not fits_truck(size_m, limits):
        extents = " × ".join(f"{value:.2f}" for value in sorted(size_m, reverse=True))
        truck = (
            f"{limits.transport_length_m:g} × {limits.transport_width_m:g} × {limits.transport_height_m:g}"
        )
        problems.append(f"{extents} m does not fit a truck's load of {truck} m")
    if not problems:
        return settled
    why = "; ".join(problems)
    fallback = decision.if_too_heavy
    if fallback is ConstructionMethod.PANELISED:
        return _rule(fallback, f"{why}{SPLIT_NOTE}", decision)
    if fallback is ConstructionMethod.CAST_IN_PLACE:
        unknown = decision.material in (None, MaterialKind.UNKNOWN.value)
        what = (
            f"an {ifc_class} of unknown material, cast in place as concrete instead"
            if unknown
            else f"a {decision.material} {ifc_class} cast in place instead"
        )
        return _rule(fallback, f"{why}: {what}", decision)
    note = f"{decision.note}; " if decision.note else ""
    return settled.model_copy(update={"note": f"{note}{why}, and no other method is known for it"})


def _rule(method: ConstructionMethod, note: str, decision: MethodDecision) -> MethodDecision:
    return MethodDecision(
        method=method, source=MethodSource.RULE, note=" ".join(note.split()), material=decision.material
    )
