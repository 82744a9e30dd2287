"""How each component is connected to its supporting neighbours, and which need temporary supports (pure).

For every component set by a robot (lifted or panelised) and each neighbour it may be connected to:

* the neighbour is found where the IFC relates the two (IfcRelConnectsElements and its subtypes: source
  ``ifc``), where the model draws them into each other (a joint: ``joint``), where the component's
  underside lies on the neighbour's top face (``bearing face``), or where they meet at the side within the
  gap a connection bridges (``side``);
* the kind follows the pair: a column-like member (a spiral stair on its post too) whose base sits on it →
  ``bolted_base`` (a base plate on anchor bolts, a footing); a precast wall on what carries it →
  ``grouted``; a slab, plank or roof on a beam or wall, a beam on a wall → ``bearing``, or ``fastened``
  where it lies on a pitch (its ``face_slope_deg`` beyond :data:`LEVEL_SEAT_MAX_DEG`: a site screws a
  pitched roof panel down); a beam or member framed in at its side, or set on a column's cap →
  ``pinned_end``, ``fixed_end`` where the IFC realises the connection with a weld; a thin panel (a board,
  sign or lining) whose broad face lies against the neighbour's side → ``fastened`` (screwed or anchored
  across its face).

Temporary supports (``[temporary_supports]`` of the methods file): a precast wall panel gets props (it
stands on grout that has not set); a member with nothing under it above the ground gets props when no
fixing connection is made as it is set down (a stub column hung from beams not built yet); a column-like
member, or a member standing on a narrow edge (the Revit duplex's 50 mm stair stringer, 3.1 m
tall, tipped onto the carrier that set it), with no fixing base connection that is slender (height over
least width beyond ``brace_slenderness``) gets braces unless its connections already reach what stands by
itself. Physics
applies the condition (``TemporarySupportNeed.when``). Times come from the methods file. The decision uses
the manifest's world bounding boxes and each component's face slope only: cheap for any model.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from bimbot.shared.connection_kinds import (
    ConnectionKind,
    ConnectionLink,
    ConnectionTimes,
    SupportKind,
    SupportWhen,
    TemporarySupportNeed,
    TemporarySupportRules,
)
from bimbot.shared.construction_methods import ConstructionMethod
from bimbot.shared.manifest import Component, Joint, JointSource
from bimbot.shared.reasons import CONNECTION_GAP_M

FACE_TOLERANCE_M = 0.02  # an underside this close to a top face bears on it (the support graph's contact)
SET_BY_ROBOT = (ConstructionMethod.LIFTED, ConstructionMethod.PANELISED)
RELATIONS = ("IfcRelConnectsElements", "IfcRelConnectsPathElements", "IfcRelConnectsWithRealizingElements")
BEARS = ("IfcSlab", "IfcRoof", "IfcPlate", "IfcCovering", "IfcStair", "IfcRamp")  # set on, held by friction
WELD_WORDS = ("weld",)
# a bearing deck or member whose broad faces slope more than this (a flat roof's fall is 1-3°) is fastened
# down: a pitched roof panel, a rafter (a window's sloped sill says nothing of how it is seated)
LEVEL_SEAT_MAX_DEG = 5.0
PITCHED = (*BEARS, "IfcBeam", "IfcMember")
BASE_KINDS = (ConnectionKind.BOLTED_BASE, ConnectionKind.GROUTED, ConnectionKind.BEARING)
# a board, sign, lining or cladding panel: this thin at most, and this many times wider and taller than thick…
FACE_PANEL_MAX_M = 0.10
FACE_PANEL_ASPECT = 5.0
FACE_SHARE = 0.5  # …whose broad face lies against a neighbour's side over this share of each of its sides
FACE_FIXED_CLASSES = ("IfcBuildingElementProxy", "IfcCovering", "IfcPlate", "IfcMember")


def _is(component: Component, prefixes: Sequence[str]) -> bool:
    return component.ifc_class.startswith(tuple(prefixes))


def column_like(component: Component) -> bool:
    """A column, or a member or stair standing upright (taller than twice its larger plan side): a spiral
    stair stands on its central post, whose base plate a site bolts to the floor (the ArchiCAD 14 export of
    the FZK-Haus: its 3.56 m spiral stair on a 1.7 m × 1.6 m plan, set bearing on the floor, tipped three
    times and 76 components rested on it). A straight flight runs longer than it rises and bears."""
    low, high = component.bbox_world.min_m, component.bbox_world.max_m
    height, plan = high[2] - low[2], max(high[0] - low[0], high[1] - low[1])
    return _is(component, ("IfcColumn",)) or (
        _is(component, ("IfcMember", "IfcBeam", "IfcStair")) and height > 2.0 * max(plan, 1e-6)
    )


def _braced_kind(component: Component) -> bool:
    """A column-like member, or a member that may stand on a narrow edge (a stair's stringer): braced when
    slender with no fixed base. A wall panel gets props instead; a door or window is set in its opening; a
    plate (a curtain wall's glazing) is set into the pockets of its frame."""
    return column_like(component) or _is(component, ("IfcMember",))


def slenderness(component: Component) -> float:
    """Height over least plan width of its bounding box."""
    low, high = component.bbox_world.min_m, component.bbox_world.max_m
    return (high[2] - low[2]) / max(min(high[0] - low[0], high[1] - low[1]), 1e-6)


def _precast_wall(component: Component) -> bool:
    return _is(component, ("IfcWall",)) and component.method in SET_BY_ROBOT


def face_fixed(component: Component, other: Component) -> bool:
    """Whether ``component`` is a thin panel (a board, a sign, a lining or cladding panel; not a wall, slab,
    door or window) whose broad face lies against ``other``'s side: a site screws or anchors it to
    ``other`` across that face, which holds it (a single bolted end would be a hinge). The Janesville
    restaurant's 23 mm, 2.4 m square board hung on its brick wall 0.56 m above the floor fell when linked
    by one pinned end."""
    if not _is(component, FACE_FIXED_CLASSES):
        return False
    low, high = np.asarray(component.bbox_world.min_m), np.asarray(component.bbox_world.max_m)
    o_low, o_high = np.asarray(other.bbox_world.min_m), np.asarray(other.bbox_world.max_m)
    size = high - low
    thin = int(np.argmin(size))
    broad = [axis for axis in range(3) if axis != thin]
    if size[thin] > FACE_PANEL_MAX_M or min(size[axis] for axis in broad) < FACE_PANEL_ASPECT * size[thin]:
        return False
    beside = o_low[thin] <= high[thin] + CONNECTION_GAP_M and o_high[thin] >= low[thin] - CONNECTION_GAP_M
    shares = [(min(high[a], o_high[a]) - max(low[a], o_low[a])) / size[a] for a in broad]
    return bool(beside and min(shares) >= FACE_SHARE)


def connection_kind(component: Component, other: Component, *, base: bool, welded: bool) -> ConnectionKind:
    """The kind of ``component``'s connection to ``other`` (``base``: its underside sits on ``other``)."""
    if not base and face_fixed(component, other):
        return ConnectionKind.FASTENED  # a board or panel fixed flat to the wall face beside it
    if base and column_like(component):
        return ConnectionKind.BOLTED_BASE
    if base and _precast_wall(component):
        return ConnectionKind.GROUTED
    if base and (_is(component, BEARS) or _is(other, ("IfcWall", "IfcSlab"))):
        if _is(component, PITCHED) and component.face_slope_deg > LEVEL_SEAT_MAX_DEG:
            return ConnectionKind.FASTENED  # on a pitch friction is not a fixing: screwed or nailed down
        return ConnectionKind.BEARING
    return ConnectionKind.FIXED_END if welded else ConnectionKind.PINNED_END


def decide_connections(
    components: Sequence[Component],
    neighbours: Sequence[Component],
    joints: Sequence[Joint],
    times: ConnectionTimes,
    rules: TemporarySupportRules,
) -> list[Component]:
    """``components`` with ``connection_links`` and ``temporary_support`` set (``neighbours``: every
    component and those in place, what a component may be connected to)."""
    by_guid = {item.guid: item for item in neighbours}
    jointed: dict[str, set[str]] = {}
    for joint in joints:
        if joint.source is JointSource.FRAMED:
            continue  # a framed end touches its part: linked as the side contact it is
        a, b = joint.guids
        jointed.setdefault(a, set()).add(b)
        jointed.setdefault(b, set()).add(a)
    mins = np.array([item.bbox_world.min_m for item in neighbours]).reshape(-1, 3)
    maxs = np.array([item.bbox_world.max_m for item in neighbours]).reshape(-1, 3)
    ground_z_m = float(mins[:, 2].min()) if len(neighbours) else 0.0
    decided: list[Component] = []
    for component in components:
        if component.method not in SET_BY_ROBOT:
            decided.append(component)
            continue
        links = _links(component, neighbours, by_guid, jointed, mins, maxs, times)
        need = _support_need(component, links, rules, ground_z_m)
        decided.append(component.model_copy(update={"connection_links": links, "temporary_support": need}))
    return decided


def _links(  # noqa: PLR0917 (the arrays are computed once for all components)
    component: Component,
    neighbours: Sequence[Component],
    by_guid: dict[str, Component],
    jointed: dict[str, set[str]],
    mins: np.ndarray,
    maxs: np.ndarray,
    times: ConnectionTimes,
) -> list[ConnectionLink]:
    sources: dict[str, str] = {}
    welded: set[str] = set()
    for relation in component.connections:
        if relation.relation in RELATIONS and relation.other_guid in by_guid:
            sources.setdefault(relation.other_guid, "ifc")
        if relation.role == "realized_by" and any(w in relation.other_class.lower() for w in WELD_WORDS):
            welded.update(r.other_guid for r in component.connections if r.relation in RELATIONS)
    for other in sorted(jointed.get(component.guid, ())):
        if other in by_guid:
            sources.setdefault(other, "joint")
    low, high = np.asarray(component.bbox_world.min_m), np.asarray(component.bbox_world.max_m)
    near = np.all((mins <= high + CONNECTION_GAP_M) & (maxs >= low - CONNECTION_GAP_M), axis=1)
    plan = (np.minimum(maxs[:, 0], high[0]) > np.maximum(mins[:, 0], low[0])) & (
        np.minimum(maxs[:, 1], high[1]) > np.maximum(mins[:, 1], low[1])
    )
    bears = plan & (np.abs(maxs[:, 2] - low[2]) <= FACE_TOLERANCE_M)
    for index in np.flatnonzero(near):
        other = neighbours[int(index)].guid
        if other != component.guid:
            sources.setdefault(other, "bearing face" if bears[index] else "side")
    links: list[ConnectionLink] = []
    for other_guid, source in sources.items():
        neighbour = by_guid[other_guid]
        base = _under(component, neighbour)
        if (
            not base
            and neighbour.bbox_world.min_m[2] > low[2] + FACE_TOLERANCE_M
            and not column_like(component)
        ):
            continue  # it sits higher: it is the one connected to this component, not a support of it
        kind = connection_kind(component, neighbour, base=base, welded=other_guid in welded)
        set_s = times.grout_set_s if kind is ConnectionKind.GROUTED else 0.0
        links.append(
            ConnectionLink(
                other_guid=other_guid, kind=kind, time_s=times.time_s(kind), set_s=set_s, source=source
            )
        )
    return sorted(links, key=lambda link: link.other_guid)


def _under(component: Component, other: Component) -> bool:
    """Whether ``component``'s base sits on or in ``other``: their plans overlap and ``other``'s top lies
    at the component's bottom (within the face tolerance, or drawn into it) while ``other`` starts lower."""
    low, high = component.bbox_world.min_m, component.bbox_world.max_m
    o_low, o_high = other.bbox_world.min_m, other.bbox_world.max_m
    overlaps_plan = all(min(high[i], o_high[i]) > max(low[i], o_low[i]) for i in (0, 1))
    top_at_bottom = low[2] - FACE_TOLERANCE_M <= o_high[2] <= low[2] + 0.25 * (high[2] - low[2])
    return overlaps_plan and top_at_bottom and o_low[2] < low[2] - 1e-6


def _support_need(
    component: Component, links: Sequence[ConnectionLink], rules: TemporarySupportRules, ground_z_m: float
) -> TemporarySupportNeed | None:
    if _precast_wall(component):
        return TemporarySupportNeed(
            kind=SupportKind.PROPS,
            count=rules.props_per_panel,
            place_s=rules.prop_place_s,
            why="a precast wall panel stands on props until its grout has set and its frame holds it",
        )
    fixed_base = any(link.kind is ConnectionKind.BOLTED_BASE for link in links)
    bottom_z = component.bbox_world.min_m[2]
    if not any(link.source == "bearing face" or link.kind in BASE_KINDS for link in links) and (
        bottom_z > ground_z_m + FACE_TOLERANCE_M
    ):
        return TemporarySupportNeed(
            kind=SupportKind.PROPS,
            count=rules.props_per_panel,
            place_s=rules.prop_place_s,
            when=SupportWhen.UNCONNECTED,
            why="nothing under it: propped until the members it is framed into hold it",
        )
    if _braced_kind(component) and not fixed_base and slenderness(component) > rules.brace_slenderness:
        return TemporarySupportNeed(
            kind=SupportKind.BRACES,
            count=rules.braces_per_column,
            place_s=rules.brace_place_s,
            when=SupportWhen.UNANCHORED,
            why=(
                f"slender ({slenderness(component):.0f}× its least width) with no fixed base: braced "
                "until what it is framed to connects it to the structure"
            ),
        )
    return None
