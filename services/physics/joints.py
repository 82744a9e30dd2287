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
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

from bimbot.shared.manifest import Joint

from .client import p


def joint_partners(joints: Iterable[Joint]) -> dict[str, frozenset[str]]:
    """GUID → the GUIDs it is jointed with (both ways round)."""
    partners: dict[str, set[str]] = {}
    for joint in joints:
        a, b = joint.guids
        if a != b:
            partners.setdefault(a, set()).add(b)
            partners.setdefault(b, set()).add(a)
    return {guid: frozenset(others) for guid, others in partners.items()}


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
