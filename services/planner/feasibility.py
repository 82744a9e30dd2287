"""Before the build: which robot types can carry and place each component, or why none can (pure).

Why: a component no robot on site can lift or place would otherwise be released, assigned and given back
again and again. The planner fails it at once with the reason a user can act on (another robot type,
another sequence) and builds the rest. The rule itself is the robot description's
(:meth:`bimbot.shared.robot_description.RobotDescription.refusal`: payload and placement height); this
module only applies it to every component and every type on site, and chooses the one reason to report
when every type refuses: ``too_heavy`` when the component is heavier than every payload, else the first
type's refusal.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from bimbot.shared.manifest import Component
from bimbot.shared.reasons import Reason, ReasonCode
from bimbot.shared.robot_description import RobotDescription


@dataclass(frozen=True)
class Feasibility:
    """One component: the robot types that can build it (by name), or the reason none can."""

    guid: str
    capable_types: tuple[str, ...]
    reason: Reason | None  # None when some type can


def component_feasibility(component: Component, robot_types: Mapping[str, RobotDescription]) -> Feasibility:
    """Which of ``robot_types`` can carry and place ``component`` at its BIM target."""
    top_z_m = component.bbox_world.max_m[2]
    refusals = {name: robot.refusal(component.mass_kg, top_z_m) for name, robot in robot_types.items()}
    capable = tuple(sorted(name for name, refusal in refusals.items() if refusal is None))
    if capable or not refusals:
        return Feasibility(component.guid, capable, None)
    heaviest = max(robot_types.values(), key=lambda robot: robot.payload_kg)
    if component.mass_kg > heaviest.payload_kg:
        kinds = ", ".join(sorted(robot_types))
        reason = Reason(
            code=ReasonCode.TOO_HEAVY,
            message=(
                f"{component.mass_kg:,.0f} kg exceeds the largest payload on site "
                f"({heaviest.payload_kg:,.0f} kg, robot type {heaviest.name}; types on site: {kinds})"
            ),
        )
    else:
        reason = next(refusal for refusal in refusals.values() if refusal is not None)
    return Feasibility(component.guid, (), reason)


def infeasible(
    components: Sequence[Component], robot_types: Mapping[str, RobotDescription]
) -> dict[str, Reason]:
    """GUID → reason for every component that no robot type on site can build."""
    result: dict[str, Reason] = {}
    for component in components:
        verdict = component_feasibility(component, robot_types)
        if verdict.reason is not None:
            result[component.guid] = verdict.reason
    return result
