"""The support graph of a building: which components must stand before another can be placed.

Component ``B`` supports component ``A`` (B → A) when B's bottom is lower than A's bottom and either

* they are connected in the IFC model (IfcRelConnectsElements and its subtypes, in either direction), or
* they touch under gravity: B's top is within ``tolerance_m`` of A's bottom and their footprints overlap
  (a ceiling carries no wall: :func:`carries`);

a foundation in the ground comes before what stands over its excavation with nothing else under or beside
it, touching or not (:mod:`.excavation`: the model leaves the fill between out; a column on its own footing
inside a ground slab's excavation may still go before the slab), and before a member over it that stands on
props until its frame holds it (``temporary_support`` when ``unconnected``: its props stand on what lies
below; the Revit duplex's first-floor joist panel was set over the open pit of its slab on grade, where
no crew props it, and fell in);
a lining goes up after the wall whose face it lines, and a floor finish after the walls beside it
(:mod:`.fitted_after`: a stud furring against a CMU party wall, tiles cut to the walls), unless it stands
lower;
whatever the heights, a wall supports the window or door that fills one of its openings (IfcRelFillsElement:
the filling is placed into the standing wall, never before it); and the two components of a **joint** (the
model draws them into each other where they are joined: ``Manifest.joints``; a framed end drawn butting
its part is ordered as any side contact) are ordered by one rule, the first that decides:

1. the IFC's host first (the wall before what fills its opening; an element before the fastener that
   realises its connection), or the part a joint rule puts first (``part_first``: the ledger before the
   storefront fitted under it);
2. else the lower part first (its bottom lower by more than ``tolerance_m``: a footing before the column
   drawn into it), its bottom right under the joint where the converter measured it
   (``Joint.bottoms_at_joint_m``: a purlin before the sloped rafter notched over it, whose box reaches
   lower at the eaves), else its box's;
3. else the one that bears first (the part a rule's member bears on or frames into);
4. else the larger first (bounding-box volume), then the smaller GlobalId.

A component that would float (none of the above, and its bottom above the lowest bottom of the model) is
held by what it touches at its side: every component whose bounding box meets its own (within
``tolerance_m``) and whose bottom is lower. Real models frame beams into the faces of columns and other
beams (the structural hub's 40 purlins and channels at 3–5 m rest on nothing from above); without this they
would be erected first, standing in the air. So is a component that rests on something but would tip off it:
the centre of its footprint lies outside the rectangle around where it touches its supports from above (the
hub's channel beam 692716 sits on one column at one end and is framed into the face of another at the other:
with only the first as its support it was erected while the second was never built, and fell every time).

The graph never holds a cycle. Edges from heights run from a strictly lower bottom to a higher one; a
host's or a joint's order overrides a height edge the other way (a door drawn lower than the wall above
it, which rests on the door at its side, is still placed after that wall); and should a cycle remain (from
joints and connections in both directions), its weakest edge (fitted after, side contact, then contact,
connection, joint, host) is dropped with a warning; a component that leaves with nothing before it is then
held at its side, as a floating one. A given predecessor map with a cycle is broken the
same way by :func:`derive_sequence`. Footprints and heights come from the manifest's world-frame bounding
boxes. The graph gives the derived construction sequence (footings and lower, supporting elements first)
and is the yardstick a given sequence is checked against.
"""

from __future__ import annotations

import graphlib
import itertools
import logging
from bisect import bisect_left, bisect_right
from collections.abc import Mapping, Sequence
from enum import IntEnum

import numpy as np

from .connection_kinds import SupportWhen
from .excavation import over_open_pits
from .fitted_after import fitted_after
from .manifest import Component, Joint, JointSource
from .sequence import ConstructionSequence, priority_topological_order, sequence_from_predecessors

_log = logging.getLogger(__name__)

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


class Edge(IntEnum):
    """Why one component precedes another, weakest first: a cycle loses its weakest edge."""

    FITTED = 1  # a lining or a floor finish goes in after the walls it is fitted to (:mod:`.fitted_after`)
    SIDE = 2  # it would float or tip: held by what it touches at its side with a lower bottom
    PIT = 3  # set down near the ground over its open excavation (:mod:`.excavation`)
    CONTACT = 4  # it rests on it from above
    CONNECTION = 5  # connected in the IFC, the lower first
    JOINT = 6  # drawn into each other where they are joined, in the joint's order
    HOST = 7  # the wall before what fills its opening


def support_predecessors(
    components: Sequence[Component],
    tolerance_m: float = CONTACT_TOLERANCE_M,
    joints: Sequence[Joint] = (),
    *,
    cycles_level: int = logging.WARNING,
) -> dict[str, set[str]]:
    """GUID → GUIDs of the components it rests on, is connected to below it, is set into or jointed after
    (``joints``: the manifest's; those naming a component not in ``components`` are passed over).
    ``cycles_level``: how a cycle broken is logged; the converter warns, and what reads its build again
    (fleet check, the planner, physics) finds the same cycles and says them at ``logging.INFO``."""
    by_guid = {item.guid: item for item in components}
    preds: dict[str, set[str]] = {guid: set() for guid in by_guid}
    kinds: dict[tuple[str, str], Edge] = {}  # (pred, component) → why
    bottoms = {guid: item.bbox_world.min_m[2] for guid, item in by_guid.items()}

    def lower(a: str, b: str) -> bool:  # b's bottom is strictly lower than a's
        return bottoms[b] < bottoms[a] - tolerance_m

    def add(pred: str, guid: str, kind: Edge) -> None:
        preds[guid].add(pred)
        kinds[pred, guid] = max(kind, kinds.get((pred, guid), kind))

    stated: list[tuple[str, str]] = []  # (first, second): orders a host or a joint states
    for item in components:
        for connection in item.connections:
            other = connection.other_guid
            if other in by_guid and connection.relation == HOSTING_RELATION:
                if connection.role == "filling" and other != item.guid:
                    add(other, item.guid, Edge.HOST)
                    stated.append((other, item.guid))
            elif other in by_guid and connection.relation in CONNECTION_RELATIONS:
                if lower(item.guid, other):
                    add(other, item.guid, Edge.CONNECTION)
                elif lower(other, item.guid):
                    add(item.guid, other, Edge.CONNECTION)
    for joint in joints:
        if joint.source is JointSource.FRAMED:
            continue  # a member's end butting the part it frames into: ordered as it touches it, at its side
        if joint.guids[0] in by_guid and joint.guids[1] in by_guid and joint.guids[0] != joint.guids[1]:
            first, second = joint_order(joint, by_guid, tolerance_m)
            add(first, second, Edge.JOINT)
            stated.append((first, second))
    connected = {guid for guid, supports in preds.items() if supports}
    resting = _add_contacts(components, preds, bottoms, tolerance_m, kinds)
    tipping = {
        item.guid
        for item in components
        if item.guid in resting and item.guid not in connected and not _balanced(item, resting[item.guid])
    }
    _add_side_contacts(components, preds, bottoms, tolerance_m, tipping, kinds=kinds)
    for wall, fitted in fitted_after(components, tolerance_m):
        if not lower(wall, fitted):  # one lower than the wall stands first, as it carries it
            add(wall, fitted, Edge.FITTED)
    for first, second in stated:  # the stated order wins over an edge of another kind the other way
        if first in preds[second] and second in preds[first] and kinds[second, first] < kinds[first, second]:
            preds[first].discard(second)
            _log.debug("support graph: %s before %s (the host's or the joint's order)", first, second)
    # what nothing holds, the stated orders applied: over an excavation it would fall into the pit; so
    # would the props of a member propped until its frame holds it (they stand on what lies below)
    unsupported = {guid for guid, supports in preds.items() if not supports}
    propped = {
        item.guid
        for item in components
        if item.temporary_support is not None and item.temporary_support.when is SupportWhen.UNCONNECTED
    }
    for foundation, guid in over_open_pits(components, tolerance_m):
        if guid in unsupported or guid in propped:
            add(foundation, guid, Edge.PIT)
    break_cycles(preds, kinds, level=cycles_level)
    # a component a broken cycle left with nothing under or before it would float: held by what it touches
    # at its side, as one that never had a support (the duplex's upper partition, drawn down through its
    # floor, waited only for the guard rail a cycle took from it, and was set in the air), then any cycle
    # that closes broken again
    ground = min(bottoms.values(), default=0.0)
    if any(not supports and bottoms[guid] > ground + tolerance_m for guid, supports in preds.items()):
        _add_side_contacts(components, preds, bottoms, tolerance_m, set(), kinds=kinds)
        break_cycles(preds, kinds, level=cycles_level)
    return preds


def joint_order(joint: Joint, by_guid: Mapping[str, Component], tolerance_m: float) -> tuple[str, str]:
    """(first, second) of a joint's two components by the rule of the module docstring: the IFC's host,
    else the lower, else the one that bears, else the larger, else the smaller GlobalId."""
    a, b = joint.guids
    if (joint.source is JointSource.RELATION or joint.part_first) and joint.directed:
        return a, b
    bottom_a, bottom_b = joint.bottoms_at_joint_m or (
        by_guid[a].bbox_world.min_m[2],
        by_guid[b].bbox_world.min_m[2],
    )
    if abs(bottom_a - bottom_b) > tolerance_m:
        return (a, b) if bottom_a < bottom_b else (b, a)
    if joint.directed:
        return a, b
    size_a, size_b = _box_volume(by_guid[a]), _box_volume(by_guid[b])
    if size_a != size_b:
        return (a, b) if size_a > size_b else (b, a)
    return (a, b) if a < b else (b, a)


def _box_volume(item: Component) -> float:
    low, high = item.bbox_world.min_m, item.bbox_world.max_m
    return float((high[0] - low[0]) * (high[1] - low[1]) * (high[2] - low[2]))


def break_cycles(
    preds: dict[str, set[str]],
    kinds: Mapping[tuple[str, str], Edge] | None = None,
    *,
    level: int = logging.WARNING,
) -> int:
    """Drop, in place, the weakest edge of every cycle of ``preds`` (GUID → predecessors) until none is
    left (``kinds``: why each edge is there; unknown edges are the weakest), each logged at ``level``; the
    number dropped. Deterministic: among equally weak edges of a cycle, the first in GUID order goes."""
    kinds = kinds or {}
    dropped = 0
    while True:
        sorter = graphlib.TopologicalSorter({guid: values & preds.keys() for guid, values in preds.items()})
        try:
            sorter.prepare()
            return dropped
        except graphlib.CycleError as error:
            cycle: list[str] = error.args[1]  # each one a predecessor of the next; the last is the first
        edges = list(itertools.pairwise(cycle))
        pred, guid = min(edges, key=lambda edge: (kinds.get(edge, 0), edge))
        preds[guid].discard(pred)
        dropped += 1
        _log.log(
            level,
            "support graph: %s would wait for itself (%s): it no longer waits for %s (%s, the weakest)",
            guid,
            " → ".join(cycle),
            pred,
            Edge(kinds[pred, guid]).name.lower() if (pred, guid) in kinds else "given",
        )


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
    *,
    kinds: dict[tuple[str, str], Edge],
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
            guid = components[int(other)].guid
            preds[item.guid].add(guid)
            kinds.setdefault((guid, item.guid), Edge.SIDE)


def _add_contacts(
    components: Sequence[Component],
    preds: dict[str, set[str]],
    bottoms: dict[str, float],
    tolerance_m: float,
    kinds: dict[tuple[str, str], Edge],
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
            if bottoms[guid] < bottom - tolerance_m and carries(components[int(other)], item):
                preds[item.guid].add(guid)
                kinds.setdefault((guid, item.guid), Edge.CONTACT)
                resting.setdefault(item.guid, []).append(
                    (
                        max(mins[other, 0], mins[index, 0]),
                        max(mins[other, 1], mins[index, 1]),
                        min(maxs[other, 0], maxs[index, 0]),
                        min(maxs[other, 1], maxs[index, 1]),
                    )
                )
    return resting


def carries(support: Component, item: Component) -> bool:
    """Whether ``item`` set on ``support`` is carried by it. A ceiling (``IfcCovering`` CEILING) is hung from
    the structure or fixed to the walls round it: it carries no wall. A wall's part drawn above the ceiling
    line (Revit splits a wall at a level) stands on the wall below it, where the ceiling's edge is drawn
    into that wall."""
    hung = support.ifc_class.startswith("IfcCovering") and support.predefined_type == "CEILING"
    return not (hung and item.ifc_class.startswith("IfcWall"))


def erection_key(component: Component) -> tuple[float, int, str]:
    """Priority among ready components: lower bottom first, then class rank, then GUID (deterministic)."""
    rank = next((value for prefix, value in CLASS_RANK.items() if component.ifc_class.startswith(prefix)), 5)
    return (round(component.bbox_world.min_m[2], 3), rank, component.guid)


def derive_sequence(
    components: Sequence[Component],
    tolerance_m: float = CONTACT_TOLERANCE_M,
    support: Mapping[str, set[str]] | None = None,
    joints: Sequence[Joint] = (),
) -> ConstructionSequence:
    """A construction sequence from the support graph (explicit predecessors = supports).

    ``support`` is the graph when the caller has already computed it (a cycle in it is broken with a
    warning, see :func:`break_cycles`; the caller's map is not changed).
    """
    if support is None:
        preds = support_predecessors(components, tolerance_m, joints)
    else:
        preds = {guid: set(values) for guid, values in support.items()}
        break_cycles(preds)
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
