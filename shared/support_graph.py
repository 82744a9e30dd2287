"""The support graph of a building: which components must stand before another can be placed.

Component ``B`` supports component ``A`` (B → A) when B's bottom is lower than A's bottom and either

* they are connected in the IFC model (IfcRelConnectsElements and its subtypes, in either direction), or
* they touch under gravity: B's top is within ``tolerance_m`` of A's bottom and their footprints overlap;

and, whatever the heights, a wall supports the window or door that fills one of its openings
(IfcRelFillsElement: the filling is placed into the standing wall, never before it).

A component that would float (none of the above, and its bottom above the lowest bottom of the model) is
held by what it touches at its side: every component whose bounding box meets its own (within
``tolerance_m``) and whose bottom is lower. Real models frame beams into the faces of columns and other
beams (the structural hub's 40 purlins and channels at 3–5 m rest on nothing from above); without this they
would be erected first, standing in the air. So is a component that rests on something but would tip off it:
the centre of its footprint lies outside the rectangle around where it touches its supports from above (the
hub's channel beam 692716 sits on one column at one end and is framed into the face of another at the other:
with only the first as its support it was erected while the second was never built, and fell every time).

Edges run from a strictly lower bottom to a higher one, or from a host to its filling (a host never
depends on what fills it), so the graph has no cycle. Footprints and
heights come from the manifest's world-frame bounding boxes. The graph gives the derived construction
sequence (footings and lower, supporting elements first) and is the yardstick a given sequence is checked
against.
"""

from __future__ import annotations

from bisect import bisect_left, bisect_right
from collections.abc import Mapping, Sequence

import numpy as np

from .manifest import Component
from .sequence import ConstructionSequence, priority_topological_order, sequence_from_predecessors

CONTACT_TOLERANCE_M = 0.02
HOSTING_RELATION = "IfcRelFillsElement"  # role "filling": the other element is the host
CONNECTION_RELATIONS = (
    "IfcRelConnectsElements",
    "IfcRelConnectsWithRealizingElements",
    "IfcRelConnectsPathElements",
)
# Erection preference among components at the same height: foundations, then vertical, then horizontal.
CLASS_RANK = {
    "IfcFooting": 0,
    "IfcPile": 0,
    "IfcColumn": 1,
    "IfcWall": 1,
    "IfcBeam": 2,
    "IfcMember": 2,
    "IfcSlab": 3,
}


def support_predecessors(
    components: Sequence[Component], tolerance_m: float = CONTACT_TOLERANCE_M
) -> dict[str, set[str]]:
    """GUID → GUIDs of the components it rests on or is connected to below it."""
    by_guid = {item.guid: item for item in components}
    preds: dict[str, set[str]] = {guid: set() for guid in by_guid}
    bottoms = {guid: item.bbox_world.min_m[2] for guid, item in by_guid.items()}

    def lower(a: str, b: str) -> bool:  # b's bottom is strictly lower than a's
        return bottoms[b] < bottoms[a] - tolerance_m

    for item in components:
        for connection in item.connections:
            other = connection.other_guid
            if other in by_guid and connection.relation == HOSTING_RELATION:
                if connection.role == "filling":
                    preds[item.guid].add(other)
            elif other in by_guid and connection.relation in CONNECTION_RELATIONS:
                if lower(item.guid, other):
                    preds[item.guid].add(other)
                elif lower(other, item.guid):
                    preds[other].add(item.guid)
    connected = {guid for guid, supports in preds.items() if supports}
    resting = _add_contacts(components, preds, bottoms, tolerance_m)
    tipping = {
        item.guid
        for item in components
        if item.guid in resting and item.guid not in connected and not _balanced(item, resting[item.guid])
    }
    _add_side_contacts(components, preds, bottoms, tolerance_m, tipping)
    return preds


def _balanced(item: Component, rests: list[tuple[float, float, float, float]]) -> bool:
    """Whether the centre of ``item``'s footprint lies within the rectangle around where it rests."""
    x0, y0 = min(r[0] for r in rests), min(r[1] for r in rests)
    x1, y1 = max(r[2] for r in rests), max(r[3] for r in rests)
    low, high = item.bbox_world.min_m, item.bbox_world.max_m
    centre_x, centre_y = (low[0] + high[0]) / 2.0, (low[1] + high[1]) / 2.0
    return bool(x0 <= centre_x <= x1 and y0 <= centre_y <= y1)


def _add_side_contacts(
    components: Sequence[Component],
    preds: dict[str, set[str]],
    bottoms: dict[str, float],
    tolerance_m: float,
    tipping: set[str],
) -> None:
    """Floating components, and those in ``tipping``, are held by what they touch with a lower bottom (see
    the module docstring)."""
    if not components:
        return
    ground = min(bottoms.values())
    mins = np.array([item.bbox_world.min_m for item in components]) - tolerance_m
    maxs = np.array([item.bbox_world.max_m for item in components]) + tolerance_m
    lows = np.array([bottoms[item.guid] for item in components])
    for index, item in enumerate(components):
        floating = not preds[item.guid] and lows[index] > ground + tolerance_m
        if not floating and item.guid not in tipping:
            continue
        touching = np.all((mins <= maxs[index]) & (maxs >= mins[index]), axis=1)
        lower = lows < lows[index] - tolerance_m
        for other in np.flatnonzero(touching & lower):
            preds[item.guid].add(components[int(other)].guid)


def _add_contacts(
    components: Sequence[Component], preds: dict[str, set[str]], bottoms: dict[str, float], tolerance_m: float
) -> dict[str, list[tuple[float, float, float, float]]]:
    """Supports from below; GUID → where it rests on each (x0, y0, x1, y1 of the overlapping footprints)."""
    resting: dict[str, list[tuple[float, float, float, float]]] = {}
    tops = sorted((item.bbox_world.max_m[2], index) for index, item in enumerate(components))
    top_values = [value for value, _ in tops]
    mins = np.array([item.bbox_world.min_m for item in components])
    maxs = np.array([item.bbox_world.max_m for item in components])
    for index, item in enumerate(components):
        bottom = item.bbox_world.min_m[2]
        low, high = (
            bisect_left(top_values, bottom - tolerance_m),
            bisect_right(top_values, bottom + tolerance_m),
        )
        candidates = np.array([tops[k][1] for k in range(low, high)], dtype=int)
        if len(candidates) == 0:
            continue
        overlap_x = np.minimum(maxs[candidates, 0], maxs[index, 0]) - np.maximum(
            mins[candidates, 0], mins[index, 0]
        )
        overlap_y = np.minimum(maxs[candidates, 1], maxs[index, 1]) - np.maximum(
            mins[candidates, 1], mins[index, 1]
        )
        for other in candidates[(overlap_x > 0) & (overlap_y > 0)]:
            guid = components[int(other)].guid
            if bottoms[guid] < bottom - tolerance_m:
                preds[item.guid].add(guid)
                resting.setdefault(item.guid, []).append(
                    (
                        max(mins[other, 0], mins[index, 0]),
                        max(mins[other, 1], mins[index, 1]),
                        min(maxs[other, 0], maxs[index, 0]),
                        min(maxs[other, 1], maxs[index, 1]),
                    )
                )
    return resting


def erection_key(component: Component) -> tuple[float, int, str]:
    """Priority among ready components: lower bottom first, then class rank, then GUID (deterministic)."""
    rank = next((value for prefix, value in CLASS_RANK.items() if component.ifc_class.startswith(prefix)), 5)
    return (round(component.bbox_world.min_m[2], 3), rank, component.guid)


def derive_sequence(
    components: Sequence[Component],
    tolerance_m: float = CONTACT_TOLERANCE_M,
    support: Mapping[str, set[str]] | None = None,
) -> ConstructionSequence:
    """A construction sequence from the support graph (explicit predecessors = supports).

    ``support`` is the graph when the caller has already computed it.
    """
    preds = support if support is not None else support_predecessors(components, tolerance_m)
    by_guid = {item.guid: item for item in components}
    ordered = priority_topological_order(preds, lambda guid: erection_key(by_guid[guid]))
    names = {item.guid: f"Erect {item.name or item.ifc_class}" for item in components}
    return sequence_from_predecessors(ordered, preds, source="derived", names=names)


def support_violations(order: Sequence[str], preds: Mapping[str, set[str]]) -> list[tuple[str, str]]:
    """(component, support) pairs where the support comes after the component in ``order`` or is missing."""
    position = {guid: index for index, guid in enumerate(order)}
    violations: list[tuple[str, str]] = []
    for guid in order:
        for support in sorted(preds.get(guid, ())):
            if position.get(support, len(order)) > position[guid]:
                violations.append((guid, support))
    return violations
