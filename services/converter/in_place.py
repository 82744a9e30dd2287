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

from collections.abc import Iterable, Sequence

from bimbot.shared.manifest import Component

FOUNDATIONS = "foundations"  # the --in-place keyword
IN_THE_GROUND_M = 0.02  # a foundation's top is at most this above the ground
BELOW_GROUND_M = 0.02  # and its bottom more than this below it


def in_the_ground(component: Component) -> bool:
    """Its BIM target lies in the ground (a footing, a ground slab, a pile cap flush with the ground)."""
    low, high = component.bbox_world.min_m[2], component.bbox_world.max_m[2]
    return low < -BELOW_GROUND_M and high <= IN_THE_GROUND_M


def split_in_place(
    components: Sequence[Component], guids: Iterable[str], *, foundations: bool
) -> tuple[list[Component], list[Component]]:
    """``(to build, in place)``: the components named by GlobalId, and with ``foundations`` every one in
    the ground, are in place; the order of each list is the order given."""
    named = set(guids)
    in_place = [c for c in components if c.guid in named or (foundations and in_the_ground(c))]
    placed = {c.guid for c in in_place}
    return [c for c in components if c.guid not in placed], in_place


def above_ground(in_place: Sequence[Component]) -> list[Component]:
    """The in-place components that reach above the ground: a robot's laser would see them and they would
    stand in its way, which its map (built from the components to build) does not know."""
    return [c for c in in_place if not in_the_ground(c)]
