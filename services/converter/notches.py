"""A deck drawn through an upright that passes through it: a joint, the deck cut round the upright on site.

Why: models draw a thin deck (a roof's plank, a floor's finish, a slab) whole, through the post, pier or
partition that rises through it; on site the deck is delivered or laid with a blockout round it. The overlap
is no end in a support, and its depth is no measure of anything (the shortest move that parts them lifts
the deck over the upright's top: the Janesville restaurant's 38 mm roof plank through a post reads 729 mm
deep), so no depth rule can tell it from a clash. The shape does: the overlap spans the deck's whole
thickness, the upright rises past the deck, and the overlap is a small part of the deck's plan (the area it
covers seen from above, for a wall crossing on the slant as much as square; a panel's share is taken of the
element it was cut from, as the model draws the deck: the Janesville restaurant's bridge floor, cut in five,
has a wall through a third of one panel's box, a small part of the floor). The upright stands first; the
deck is set round it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from bimbot.shared.manifest import Component, Joint, JointSource

from .overlaps import Overlap

DECK_CLASSES = ("IfcSlab", "IfcRoof", "IfcCovering", "IfcPlate")
DECK_MAX_THICKNESS_M = 0.5  # a deck: a plank, a finish, a slab (its box's height, so level ones only)
THROUGH_TOLERANCE_M = 0.005  # the overlap reaches the deck's faces within this
PAST_THE_DECK_M = 0.05  # the upright rises (or reaches down) at least this far past the deck's faces
MAX_PLAN_SHARE = 0.25  # the overlap's plan (its hull) is at most this share of the deck's plan box


def element_plans_m2(components: Sequence[Component]) -> dict[str, float]:
    """Panel GUID → the plan area of the element it was cut from (the sum of its panels' plan boxes):
    a deck is judged as the model draws it, not as bimbot cut it."""
    by_parent: dict[str, list[Component]] = {}
    for component in components:
        if component.parent_guid:
            by_parent.setdefault(component.parent_guid, []).append(component)
    plans: dict[str, float] = {}
    for panels in by_parent.values():
        total = sum(_plan_box_m2(panel) for panel in panels)
        plans.update((panel.guid, total) for panel in panels)
    return plans


def _plan_box_m2(component: Component) -> float:
    low, high = component.bbox_world.min_m, component.bbox_world.max_m
    return (high[0] - low[0]) * (high[1] - low[1])


def notched_round(
    overlap: Overlap, a: Component, b: Component, element_plans_m2: Mapping[str, float] | None = None
) -> Joint | None:
    """The joint of a deck drawn through an upright that passes through it (see the module doc), the
    upright first; None when neither way round fits. ``element_plans_m2``: a panel's element's plan
    (:func:`element_plans_m2`), against which its share is taken."""
    plans = element_plans_m2 or {}
    for deck, upright in ((a, b), (b, a)):
        if _passes_through(overlap, deck, upright, plans.get(deck.guid)):
            return Joint(
                guids=(upright.guid, deck.guid),
                depth_m=round(overlap.depth_m, 4),
                source=JointSource.NOTCHED,
                rule=f"{deck.ifc_class} cut round {upright.ifc_class} passing through it",
                directed=True,
            )
    return None


def _passes_through(
    overlap: Overlap, deck: Component, upright: Component, element_plan_m2: float | None = None
) -> bool:
    if not deck.ifc_class.startswith(DECK_CLASSES) or upright.ifc_class.startswith(DECK_CLASSES):
        return False
    deck_low, deck_high = deck.bbox_world.min_m, deck.bbox_world.max_m
    thickness_m = deck_high[2] - deck_low[2]
    if thickness_m > DECK_MAX_THICKNESS_M:
        return False
    up_low, up_high = upright.bbox_world.min_m[2], upright.bbox_world.max_m[2]
    if up_high - up_low < thickness_m + PAST_THE_DECK_M:
        return False
    region = overlap.region_m
    if len(region) == 0:
        return False
    spans = region[:, 2].min() <= deck_low[2] + THROUGH_TOLERANCE_M
    spans = spans and region[:, 2].max() >= deck_high[2] - THROUGH_TOLERANCE_M
    if not spans:
        return False
    deck_plan = element_plan_m2 if element_plan_m2 is not None else _plan_box_m2(deck)
    return plan_area_m2(region) <= MAX_PLAN_SHARE * deck_plan


def plan_area_m2(region_world_m: np.ndarray) -> float:
    """The plan area the overlap covers: its vertices' convex hull seen from above (a wall crossing a deck
    on the slant covers a strip, not the box around it); a region flat in plan covers none."""
    points = np.unique(region_world_m[:, :2].round(6), axis=0)
    if len(points) < 3:
        return 0.0
    from scipy.spatial import ConvexHull, QhullError  # here: scipy costs a command its import

    try:
        return float(ConvexHull(points).volume)  # a 2-D hull's "volume" is its area
    except QhullError:  # all on one line
        return 0.0
