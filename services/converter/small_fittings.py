"""Small fittings drawn as proxies: ironmongery the finishing trades fix, not parts a robot sets (pure).

Why: the Revit office (PyPI ``ifc-mcp`` 0.1.0) draws 212 cabinet and fridge handles ("Handtag skåp",
"Handtag kyl/frys") as "Generic Models" proxies of 38 g, 15 cm long. Converted as work, each was a task
for the carrier and a hand-off to the tower crane for the upper floors, and one, set by the crane's hook
within 4 mm, missed its 10 mm tolerance three times and failed the run. On a site a handle is fitted to
its cabinet by the joiner with a screwdriver, as the furniture that IFC classes as furnishing (left out
already) is. The rule: a whole element of class ``IfcBuildingElementProxy`` that weighs under
``MAX_FITTING_KG`` and whose longest side is under ``MAX_FITTING_M`` is left out with a reason that says
so. A trim board or a railing panel, however light, is longer and stays. A model of nothing but such
parts (IfcOpenShell's profile test pieces, 5 cm and 9 g) is converted as it is: it is no building's.
"""

from __future__ import annotations

from collections.abc import Sequence

from bimbot.shared.manifest import Component

MAX_FITTING_KG = 1.0  # a handle, a hook, a sign's bracket: a hand tool's work
MAX_FITTING_M = 0.5  # its longest side; a trim board or a rail is longer


def small_fitting_reasons(components: Sequence[Component]) -> dict[str, str]:
    """Element GlobalId → its skip reason, for each small fitting among ``components``."""
    reasons = {}
    for component in components:
        if component.parent_guid is not None or component.ifc_class != "IfcBuildingElementProxy":
            continue
        low, high = component.bbox_world.min_m, component.bbox_world.max_m
        longest_m = max(top - bottom for bottom, top in zip(low, high, strict=True))
        if component.mass_kg < MAX_FITTING_KG and longest_m < MAX_FITTING_M:
            reasons[component.guid] = (
                f"not a building element (a small fitting): {component.mass_kg * 1000:,.0f} g, "
                f"{longest_m:.2f} m at its longest, drawn as a proxy: ironmongery or an accessory the "
                "finishing trades fix by hand (a handle, a hook, a bracket), not a part a construction "
                "robot sets"
            )
    if len({component.parent_guid or component.guid for component in components}) == len(reasons):
        return {}  # nothing but fittings: a model of parts (a profile's test piece), not a building's
    return reasons
