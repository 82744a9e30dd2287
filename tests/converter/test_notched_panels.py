"""A deck panel is cut round an upright as the model draws the deck: the share of its plan the upright
takes is judged against the element it was cut from (the Janesville restaurant's bridge floor, cut in five,
has a wall through a third of one panel's box: a small part of the floor)."""

from __future__ import annotations

from itertools import product

import numpy as np
from component_boxes import box_component

from bimbot.services.converter.notches import element_plans_m2, notched_round
from bimbot.services.converter.overlaps import Overlap
from bimbot.shared.manifest import JointSource


def _corners(low: tuple[float, float, float], high: tuple[float, float, float]) -> np.ndarray:
    return np.array(list(product(*zip(low, high, strict=True))), dtype=float)


def test_a_wall_through_a_third_of_one_panel_of_a_five_panel_floor_is_cut_round_as_the_floor_is_drawn() -> (
    None
):
    panels = [
        box_component(f"p{i}", (3.0, 2.0, 0.2), (0.0, 2.0 * i, 3.7)).model_copy(
            update={"ifc_class": "IfcSlab", "parent_guid": "floor"}
        )
        for i in range(5)
    ]
    wall = box_component("wall", (3.0, 0.7, 1.1), (0.0, 0.0, 3.2)).model_copy(update={"ifc_class": "IfcWall"})
    deck = panels[0]
    overlap = Overlap(
        first="p0",
        second="wall",
        depth_m=0.5,
        part_pairs=(
            (_corners((0.0, 0.0, 3.7), (3.0, 2.0, 3.9)), _corners((0.0, 0.0, 3.2), (3.0, 0.7, 4.3))),
        ),
    )
    plans = element_plans_m2([*panels, wall])
    assert plans["p0"] == 30.0 and "wall" not in plans
    joint = notched_round(overlap, deck, wall, plans)
    assert joint is not None and joint.source is JointSource.NOTCHED and joint.guids == ("wall", "p0")
    # the same panel judged by its own box: the wall takes 35 % of it, more than a notch
    assert notched_round(overlap, deck, wall) is None
