"""A deck drawn through an upright that passes through it: a joint, the deck cut round the upright on site.

Why: models draw a thin deck (a roof's plank, a floor's finish, a slab) whole, through the post, pier or
partition that rises through it; on site the deck is delivered or laid with a blockout round it. The overlap
is no end in a support, and its depth is no measure of anything (the shortest move that parts them lifts
the deck over the upright's top: the Janesville restaurant's 38 mm roof plank through a post reads 729 mm
deep), so no depth rule can tell it from a clash. The shape does: the overlap spans the deck's whole
thickness, the upright rises past the deck, and the overlap is a small part of the deck's plan (the area it
covers seen from above, for a wall crossing on the slant as much as square). The upright stands first; the
deck is set round it.
"""

from __future__ import annotations

import numpy as np

from bimbot.shared.manifest import Component, Joint, JointSource

from .overlaps import Overlap

DECK_CLASSES = ("IfcSlab", "IfcRoof", "IfcCovering", "IfcPlate")
DECK_MAX_THICKNESS_M = 0.5  # a deck: a plank, a finish, a slab (its box's height, so level ones only)
THROUGH_TOLERANCE_M = 0.005  # the overlap reaches the deck's faces within this
PAST_THE_DECK_M = 0.05  # the upright rises (or reaches down) at least this far past the deck's faces
MAX_PLAN_SHARE = 0.25  # the overlap's plan (its hull) is at most this share of the deck's plan box


def notched_round(overlap: Overlap, a: Component, b: Component) -> Joint | None:
    """The joint of a deck drawn through an upright that passes through it (see the module doc), the
    upright first; None when neither way round fits."""
    for deck, upright in ((a, b), (b, a)):
        if _passes_through(overlap, deck, upright):
            return Joint(
                guids=(upright.guid, deck.guid),
                depth_m=round(overlap.depth_m, 4),
                source=JointSource.NOTCHED,
                rule=f"{deck.ifc_class} cut round {upright.ifc_class} passing through it",
                directed=True,
            )
    return None


def _passes_through(overlap: Overlap, deck: Component, upright: Component) -> bool:
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
    deck_plan = (deck_high[0] - deck_low[0]) * (deck_high[1] - deck_low[1])
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
