"""How high a site erects its tower cranes: as high as the building needs, up to the mast's free-standing
limit (pure, part of the site plan).

Why: a tower crane is not bought at one height. The site orders as many mast sections as the building
needs, so that the hook clears the highest part it sets. The fleet file gives the height a type is
erected at (``[crane] jib_height_m``) and, with ``max_jib_height_m``, the most its mast stands
free-standing. A building taller than the default height (the Revit office from ifc-mcp stands 46.5 m:
82 slab and wall parts lay above the crane's 36 m placement height) gets a taller crane, as a site would
order one; a low building keeps the fleet file's height, so its hoist times do not change.

The rule: for each crane type with a ``max_jib_height_m``, the height under hook needed is the top of the
highest component a crane may lift (lifted or panelised; world z, m) plus what the type keeps between
its hook and its placement height (``jib_height_m - max_place_height_m``: the lift clearance and the
sling), rounded up to a whole ``ERECTION_STEP_M``. The crane is erected at that height when it is higher
than the file's and no higher than ``max_jib_height_m``; above its free-standing limit it stands at the
limit (a crane tied to the building and climbed with it is not simulated), and the parts above are out
of its reach with the usual reason. The placement height rises with the jib, metre for metre.

Deterministic: the same fleet and components give the same heights.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

from .construction_methods import ConstructionMethod
from .fleet import Fleet
from .manifest import Component
from .robot_description import RobotDescription

ERECTION_STEP_M = 1.0  # heights in whole metres (assumption: mast sections are longer, a head adapts)
LIFTED_BY_CRANE = frozenset({ConstructionMethod.LIFTED, ConstructionMethod.PANELISED})


def highest_lifted_top_m(components: Iterable[Component]) -> float:
    """The world z (m) of the highest target top a crane may set, 0 when nothing is lifted."""
    return max((float(c.bbox_world.max_m[2]) for c in components if c.method in LIFTED_BY_CRANE), default=0.0)


def erected_height_m(description: RobotDescription, top_m: float) -> float | None:
    """The height under hook ``description``'s crane is erected at for a building whose highest lifted top
    is ``top_m``, or None when it stays at the fleet file's (not a crane, no free-standing limit given, or
    the file's height suffices)."""
    crane = description.crane
    if crane is None or crane.max_jib_height_m is None:
        return None
    kept_m = crane.jib_height_m - description.max_place_height_m
    needed_m = math.ceil((top_m + kept_m) / ERECTION_STEP_M - 1e-9) * ERECTION_STEP_M
    height_m = min(needed_m, crane.max_jib_height_m)
    return height_m if height_m > crane.jib_height_m + 1e-9 else None


def erected(description: RobotDescription, height_m: float) -> RobotDescription:
    """``description`` with its crane erected at ``height_m`` under hook, its placement height raised as
    much."""
    assert description.crane is not None
    raised_m = height_m - description.crane.jib_height_m
    crane = description.crane.model_copy(
        update={"jib_height_m": height_m, "mast_raised_m": description.crane.mast_raised_m + raised_m}
    )
    return description.model_copy(
        update={"crane": crane, "max_place_height_m": description.max_place_height_m + raised_m}
    )


def erected_for(fleet: Fleet, components: Iterable[Component]) -> Fleet:
    """``fleet`` with each crane type erected as high as ``components`` need (see the module docstring);
    the same fleet object when none is raised."""
    top_m = highest_lifted_top_m(components)
    raised = {}
    for name, description in fleet.types.items():
        height_m = erected_height_m(description, top_m)
        if height_m is not None:
            raised[name] = erected(description, height_m)
    if not raised:
        return fleet
    return fleet.model_copy(update={"types": {**fleet.types, **raised}})


def erection_words(before: Fleet, after: Fleet) -> list[str]:
    """One phrase per crane type ``after`` raised: ``tower_crane erected at 51 m under hook (fleet file:
    40 m; free-standing up to 55.8 m)``."""
    words = []
    for name, description in after.types.items():
        old = before.types.get(name)
        if description.crane is None or old is None or old.crane is None:
            continue
        if description.crane.jib_height_m != old.crane.jib_height_m:
            words.append(
                f"{name} erected at {description.crane.jib_height_m:g} m under hook for the building (fleet "
                f"file: {old.crane.jib_height_m:g} m; free-standing up to {old.crane.max_jib_height_m:g} m)"
            )
    return words
