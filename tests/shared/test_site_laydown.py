"""The laydown beside the crane: each crane-only load at the free spot nearest the mast, heaviest first.

The spots are searched a block of candidates at a time; these tests hold them to the rule as the module
states it, checked one candidate at a time, on a yard crowded enough that later loads go far out."""

from __future__ import annotations

import math

import numpy as np
from component_boxes import box_component

from bimbot.shared.fleet import default_fleet
from bimbot.shared.robot_description import Capability
from bimbot.shared.site_laydown import LAYDOWN_GAP_M, SPOT_STEP_M, Crane, lay_down
from bimbot.shared.site_plan import Rect
from bimbot.shared.yard_slot import laid_slot


def _crane() -> Crane:
    description = next(item for item in default_fleet().robot_types() if item.can(Capability.HOOK_LIFT))
    return Crane(description, (0.0, 0.0, 0.0))


def _loads(count: int) -> list:
    rng = np.random.default_rng(3)
    return [
        box_component(
            f"panel{number:03d}",
            (float(rng.uniform(2.0, 7.0)), 0.2, float(rng.uniform(1.0, 3.0))),
            (10.0, 0.0, 0.0),
            mass_kg=float(rng.uniform(3100.0, 7900.0)),
        )
        for number in range(count)
    ]


def _reference_spot(crane: Crane, component, taken: list[Rect]) -> tuple[float, float] | None:
    """The rule, one candidate at a time: nearest the mast, ties by x then y, overlapping nothing taken."""
    spec = crane.description.crane
    assert spec is not None
    probe = laid_slot(component, 0.0, 0.0).footprint
    half = ((probe.max_xy[0] - probe.min_xy[0]) / 2.0, (probe.max_xy[1] - probe.min_xy[1]) / 2.0)
    low, high = spec.min_radius_m, spec.radius_for(component.mass_kg)
    steps = int(high // SPOT_STEP_M)
    candidates = sorted(
        (round(math.hypot(i * SPOT_STEP_M, j * SPOT_STEP_M), 6), i * SPOT_STEP_M, j * SPOT_STEP_M)
        for i in range(-steps, steps + 1)
        for j in range(-steps, steps + 1)
        if low - 1e-9 <= math.hypot(i * SPOT_STEP_M, j * SPOT_STEP_M) <= high + 1e-9
    )
    for _, x, y in candidates:
        if all(
            x + half[0] <= rect.min_xy[0]
            or x - half[0] >= rect.max_xy[0]
            or y + half[1] <= rect.min_xy[1]
            or y - half[1] >= rect.max_xy[1]
            for rect in taken
        ):
            return (x, y)
    return None


def test_each_load_lies_where_the_rule_checked_candidate_by_candidate_puts_it() -> None:
    crane, loads = _crane(), _loads(40)
    blocked = [Rect((-3.0, -3.0), (3.0, 3.0)), Rect((5.0, -20.0), (30.0, 20.0))]  # the mast, the building
    slots = lay_down(loads, [crane], blocked)
    taken = [rect.grown(LAYDOWN_GAP_M) for rect in blocked]
    placed = 0
    for component in sorted(loads, key=lambda item: -item.mass_kg):
        spot = _reference_spot(crane, component, taken)
        if spot is None:
            assert component.guid not in slots
            continue
        footprint = slots[component.guid].footprint
        centre = (
            (footprint.min_xy[0] + footprint.max_xy[0]) / 2,
            (footprint.min_xy[1] + footprint.max_xy[1]) / 2,
        )
        assert centre == (spot[0], spot[1]) or np.allclose(centre, spot, atol=1e-9), component.guid
        taken.append(footprint.grown(LAYDOWN_GAP_M))
        placed += 1
    assert placed >= 30  # the yard is crowded: later loads go far out, not one beside another


def test_no_two_loads_overlap_and_each_lies_within_its_chart_radius() -> None:
    crane, loads = _crane(), _loads(40)
    slots = lay_down(loads, [crane], [Rect((-3.0, -3.0), (3.0, 3.0))])
    spec = crane.description.crane
    assert spec is not None and len(slots) == len(loads)
    rects = {guid: slot.footprint for guid, slot in slots.items()}
    for guid, rect in rects.items():
        centre = ((rect.min_xy[0] + rect.max_xy[0]) / 2, (rect.min_xy[1] + rect.max_xy[1]) / 2)
        mass = next(item.mass_kg for item in loads if item.guid == guid)
        assert spec.min_radius_m - 1e-9 <= math.hypot(*centre) <= spec.radius_for(mass) + 1e-9
        for other, rect_b in rects.items():
            if other != guid:
                assert (
                    rect.max_xy[0] <= rect_b.min_xy[0]
                    or rect_b.max_xy[0] <= rect.min_xy[0]
                    or rect.max_xy[1] <= rect_b.min_xy[1]
                    or rect_b.max_xy[1] <= rect.min_xy[1]
                ), (guid, other)
