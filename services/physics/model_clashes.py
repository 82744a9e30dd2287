"""Every pair of components the model itself puts into each other: the clashes in the IFC, found at once.

Why: ``bimbot run OUT/ --check-stability`` stops at the first step that does not stand. On a Revit model
whose concrete elements are joined by overlapping (a footing 229 mm into a strip footing, a column 26 mm
into a wall), each run named one clash, and a user leaving them out one by one ran it again for each.
Before the replay, every component is put at its BIM pose in the replay's own scene (nothing is stepped),
and every pair whose collision parts overlap deeper than a contact (:data:`.release.MAX_CLEARED_M`, what
a release counts as a clash) is listed with how deep; then every component goes back where it lay. A
pair the model joins (``Manifest.joints``: a column drawn into its footing) is no clash and is left out.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from .client import p
from .release import clashes_among
from .scene import ComponentBody, Frame, component_pose, set_component_pose


@dataclass(frozen=True)
class Clash:
    """Two components the model puts into each other, ``depth_m`` deep (GUIDs, ``first < second``)."""

    first: str
    second: str
    depth_m: float


def model_clashes(
    client_id: int,
    bodies: Mapping[str, ComponentBody],
    targets: Mapping[str, Frame],
    joints: Mapping[str, frozenset[str]] | None = None,
) -> list[Clash]:
    """The pairs of ``bodies`` (GUID → body) that overlap deeper than a contact when each stands at its
    ``targets`` frame, deepest first, but for the pairs of ``joints`` (GUID → jointed GUIDs); the bodies
    are back where they were when it returns."""
    joints = joints or {}
    before = {guid: component_pose(client_id, body) for guid, body in bodies.items()}
    guid_of = {body.body_id: guid for guid, body in bodies.items()}
    deepest: dict[tuple[str, str], float] = {}
    try:
        for guid, body in bodies.items():
            set_component_pose(client_id, body, targets[guid])
        p.performCollisionDetection(physicsClientId=client_id)  # every box where its body now is
        for guid, body in bodies.items():
            low, high = p.getAABB(body.body_id, -1, physicsClientId=client_id)
            for other, _ in p.getOverlappingObjects(low, high, physicsClientId=client_id) or ():
                other_guid = guid_of.get(other)
                if other_guid is None or other_guid <= guid:  # not a component, itself, or the pair seen
                    continue
                if other_guid in joints.get(guid, ()):  # a joint: the model means them to overlap
                    continue
                points = p.getClosestPoints(body.body_id, other, 0.0, physicsClientId=client_id)
                for _, depth_m in clashes_among([(point, other_guid) for point in points]):
                    deepest[guid, other_guid] = depth_m
    finally:
        for guid, body in bodies.items():
            set_component_pose(client_id, body, before[guid])
        p.performCollisionDetection(physicsClientId=client_id)
    clashes = [Clash(first, second, depth_m) for (first, second), depth_m in deepest.items()]
    return sorted(clashes, key=lambda clash: (-clash.depth_m, clash.first, clash.second))
