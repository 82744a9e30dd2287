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
plus the erection clearance, since the member is made short by that gap (:func:`framed_ends`).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

from bimbot.shared.manifest import Joint, JointSource

from .client import p


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
