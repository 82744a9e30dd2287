"""Components in place before the robots come: cast in situ or built by others (pure).

Why: a robot fleet assembles a building's prefabricated members; its foundations are usually cast in situ
first. The Revit structural hub's 49 t ground slab and 3–11 t footings are heavier than any robot on site,
so a run failed them ``too_heavy`` and every member resting on them ``blocked_by``: 3 of 115 built. With
``bimbot convert … --in-place foundations`` (or classes, or GlobalIds) those components are converted as
usual but listed in the manifest's ``in_place``, not in its ``components``: physics puts them at their BIM
pose from the start, static, and nothing plans, carries or counts them; what rests on them is released at
once. ``foundations`` means every component whose target lies in the ground: it reaches more than
``BELOW_GROUND_M`` below it and its top is at most ``IN_THE_GROUND_M`` above it (a trial's first rule, the
top alone, also took the Revit house's 5 cm curtain-wall sills, and a robot got stuck on them). A robot's
laser never sees such a component and it drives over it, so the robots' maps and the planner's access
checks, which follow ``components``, stay right.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence

from bimbot.shared.construction_methods import ConstructionMethod, MethodSource
from bimbot.shared.excavation import BELOW_GROUND_M  # its bottom more than this below the ground
from bimbot.shared.manifest import Component

FOUNDATIONS = "foundations"  # the --in-place keyword
_EXISTING = re.compile(r"\bexisting\b", re.IGNORECASE)
IN_THE_GROUND_M = 0.02  # a foundation's top is at most this above the ground


def in_the_ground(component: Component) -> bool:
    """Its BIM target lies in the ground (a footing, a ground slab, a pile cap flush with the ground)."""
    return lies_in_ground(component.bbox_world.min_m[2], component.bbox_world.max_m[2])


def lies_in_ground(bottom_z_m: float, top_z_m: float) -> bool:
    """A target from ``bottom_z_m`` to ``top_z_m`` (world frame) lies in the ground."""
    return bottom_z_m < -BELOW_GROUND_M and top_z_m <= IN_THE_GROUND_M


def split_in_place(
    components: Sequence[Component], guids: Iterable[str], *, foundations: bool
) -> tuple[list[Component], list[Component]]:
    """``(to build, in place)``: the components named by GlobalId, and with ``foundations`` every one in
    the ground, are in place (``method`` ``in_place``, the user's word), as is every component whose
    method is already ``in_place`` (existing work the IFC names); the order of each list is the order
    given."""
    named = set(guids)
    asked = {c.guid for c in components if c.guid in named or (foundations and in_the_ground(c))}
    in_place = [
        c.model_copy(update=_asked_in_place(c)) if c.guid in asked else c
        for c in components
        if c.guid in asked or c.method is ConstructionMethod.IN_PLACE
    ]
    placed = {c.guid for c in in_place}
    return [c for c in components if c.guid not in placed], in_place


def _asked_in_place(component: Component) -> dict[str, object]:
    return {
        "method": ConstructionMethod.IN_PLACE,
        "method_source": MethodSource.USER,
        "method_note": "convert --in-place",
        "cast": None,
    }


def above_ground(in_place: Sequence[Component]) -> list[Component]:
    """The in-place components that reach above the ground: a robot's laser sees them and they stand in
    its way (its map has them, from the manifest's ``in_place``)."""
    return [c for c in in_place if not in_the_ground(c)]


def named_existing(components: Sequence[Component]) -> list[Component]:
    """The components to build whose name says they exist (Revit's "Existing Strip Footing"), with no
    status or phase in the IFC to say so: a hint that they may stand before the build (``--in-place``)."""
    return [
        c
        for c in components
        if c.method is not ConstructionMethod.IN_PLACE and _EXISTING.search(c.name or "")
    ]
