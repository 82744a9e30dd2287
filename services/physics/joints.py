"""Joints: pairs of components the model draws into each other where they are joined (``Manifest.joints``).

Why: real models draw a column 50 mm into its footing, a beam's end into a column's face, a window into its
wall. Bullet would push such a pair apart (centimetres: a column set at its target jumps and falls), and the
release would call the overlap a clash in the IFC. The converter tells joints from clashes
(``services/converter/joints.py``); physics then

* turns off the contacts between the two bodies of every joint (``setCollisionFilterPair``), so the pair
  never fights in Bullet, whatever either does;
* leaves a joint partner out of what a released component is moved out of and out of its clashes
  (:mod:`.releasing`, :mod:`.model_clashes`): only a real clash is reported;
* counts a joint as a connection (:mod:`.connections`): a component set down at its target with a joint to a
  component of the structure is fixed where it was set and held while the connection is made, since with
  no contact between them it would otherwise pass into its partner.

A **framed end** (``JointSource.FRAMED``: a member's end drawn butting the part it frames into) is not such
a joint: the two keep their contacts and it is connected as any neighbour. Only its release differs: set
against the part, the member is not moved out of it as long as they overlap no deeper than the model draws
plus the erection clearance, since the member is made short by that gap (:func:`framed_ends`). Boards cut
from one covering (a ceiling's, a floor finish's panels) are let overlap the board beside them as far as a
site trims one to the other, the joint left between them (:func:`trimmed_boards`).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

from bimbot.shared.manifest import Component, Joint, JointSource

from .client import p

# a board is trimmed to the one beside it by up to the joint the converter leaves between two panels side
# by side (services/converter/panelise.py: PANEL_JOINT_M)
BOARD_TRIM_M = 0.015


def joint_partners(joints: Iterable[Joint]) -> dict[str, frozenset[str]]:
    """GUID → the GUIDs it is jointed with (both ways round); framed ends aside (:func:`framed_ends`)."""
    partners: dict[str, set[str]] = {}
    for joint in joints:
        if joint.source is JointSource.FRAMED:
            continue
        a, b = joint.guids
        if a != b:
            partners.setdefault(a, set()).add(b)
            partners.setdefault(b, set()).add(a)
    return {guid: frozenset(others) for guid, others in partners.items()}


def framed_ends(joints: Iterable[Joint]) -> dict[str, dict[str, float]]:
    """GUID → {the GUID it is framed to at an end (either way round): how deep the two may overlap (m)}: as
    deep as the model draws them plus the erection clearance. Within that, a member set against the part
    is not moved out of it at release; once bolted (fixed) neither pushes the other. Their contacts stay:
    a member not held by its connections is pushed out as any other."""
    allowed: dict[str, dict[str, float]] = {}
    for joint in joints:
        if joint.source is JointSource.FRAMED:
            a, b = joint.guids
            depth_m = joint.depth_m + joint.clearance_m
            allowed.setdefault(a, {})[b] = depth_m
            allowed.setdefault(b, {})[a] = depth_m
    return allowed


def is_board(component: Component) -> bool:
    """A board cut from a covering (a ceiling's, a floor finish's, a cladding's panel): a site sets it
    square to the room and trims its edge to what stands (:func:`trimmed_boards`); the fit does not turn it
    to follow a wall or the board beside it (the Janesville restaurant's gypsum ceiling board turned 0.43°
    with what it was fitted to left the next board no room over its 2.4 m width)."""
    return component.parent_guid is not None and component.ifc_class == "IfcCovering"


def trimmed_boards(components: Iterable[Component]) -> dict[str, dict[str, float]]:
    """GUID → {a board beside it cut from the same covering: how deep the two may overlap (m)}, as
    :func:`framed_ends` gives: the panels of a ceiling, floor finish or cladding (``IfcCovering``) are
    boards a site cuts to the one beside it as it stands, by up to the joint left between them
    (:data:`BOARD_TRIM_M`). A board set against a neighbour fitted a few mm towards it and turned (the
    Janesville restaurant's gypsum ceiling: 10 mm and 0.43°) was moved 17.6 mm out of it and failed
    misplaced; on a site its edge is trimmed. Precast panels and planks are not trimmed: they are not here."""
    by_parent: dict[str, list[str]] = {}
    for component in components:
        if is_board(component) and component.parent_guid is not None:
            by_parent.setdefault(component.parent_guid, []).append(component.guid)
    allowed: dict[str, dict[str, float]] = {}
    for boards in by_parent.values():
        for guid in boards:
            allowed[guid] = {other: BOARD_TRIM_M for other in boards if other != guid}
    return allowed


def let_joints_overlap(
    client_id: int, partners: Mapping[str, frozenset[str]], body_of: Mapping[str, int]
) -> int:
    """No contacts between the bodies (``body_of``: GUID → body) of each jointed pair; the pairs set."""
    count = 0
    for guid, others in partners.items():
        for other in others:
            if guid < other and guid in body_of and other in body_of:
                p.setCollisionFilterPair(body_of[guid], body_of[other], -1, -1, 0, physicsClientId=client_id)
                count += 1
    return count
