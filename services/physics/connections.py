"""Connections: a component set down at its target beside the structure is fastened to it.

On a site a beam framed into a column's face, a curtain-wall panel between its mullions or a door in its
wall's opening does not stand by itself: the crane or robot holds it while the crew bolts, welds or screws
it to what is already built, and lets go once the connection is made. Until this module the simulation
released every component into free dynamics, so such members tipped and failed ``unstable`` ("it stands
only with temporary bracing, which is not simulated"), and everything resting on them ``blocked_by``.

The rule, checked at the moment a robot lets go (:meth:`.releasing.Releasing.release`):

* it lies where its agent would accept it (the agents' position and angle tolerances: the holes line up;
  a connection is never made to a component set down off its target),
* and a component that is part of the structure already (joined after its agent verified it, or in place
  from the start) lies within ``gap_m`` (0.1 m) of it **at its side**: where the two come closest, the
  normal lies within 60° of horizontal. Resting on top of something is what gravity does, not a
  connection; or it is **jointed** with such a component (``Manifest.joints``, :mod:`.joints`: the model
  draws the two into each other where they are joined, a column into its footing, a beam's end into a
  column), on whatever side: a bolted base, a bolted or welded end, a bearing, a grouted pocket.

Then it is fixed where it is (static, as a fixed constraint to the static structure would make it) and its
robot holds it ``hold_s`` of sim time while the connection is made: the place request is answered after
that. What rests on nothing at its side, or lies off its target, is not connected: it stands on its
temporary supports if its manifest gives it some (:mod:`.temporary_supports`, set wherever it was put),
else it is released and must stand by itself. ``--no-connections`` (``bimbot run``,
``--check-stability``) turns this off: every component must then stand by itself, the rehearsal of a
sequence without connections.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from bimbot.shared.connection_kinds import ConnectionKind, ConnectionLink
from bimbot.shared.manifest import Component
from bimbot.shared.messages import PoseMsg
from bimbot.shared.reasons import CONNECTION_GAP_M
from bimbot.shared.verification import Tolerances, verify

from .client import p
from .scene import Frame

# a contact normal with |z| below this is at the component's side (within 60° of horizontal)
SIDE_NORMAL_MAX_Z = 0.5
NEAREST_BAND_M = 0.001  # closest points this much farther than the nearest count as where they meet


@dataclass(frozen=True)
class ConnectionConfig:
    """Whether and how components are connected to the structure as they are set down."""

    enabled: bool = True
    # the gap a connection bridges: models leave out cleats, end plates, fin plates and ties (the Revit
    # hub's channel beams stop 95 mm short of the columns they frame into, an SHS beam 11 mm), and the
    # collision parts are inset 1 mm each (two faces that touch in the model are 2 mm apart in physics)
    gap_m: float = CONNECTION_GAP_M
    # how long the robot holds the component while the connection is made (sim s)
    hold_s: float = 20.0
    # the connection is made only where its agent would accept the placement
    fit: Tolerances = field(default_factory=Tolerances)

    def __post_init__(self) -> None:
        for name in ("gap_m", "hold_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"connections: {name} must be a finite number ≥ 0, got {value!r}")


def fits_its_target(component: Component, frame: Frame, fit: Tolerances) -> bool:
    """Whether ``component`` at ``frame`` lies within the agents' tolerances of its BIM target."""
    here = PoseMsg(position_m=frame[0], quat_xyzw=frame[1])
    return verify(here, component.target_pose_world, fit, reference_local_m=component.com_local_m).ok


def side_neighbours(
    client_id: int, body_id: int, structure: Mapping[int, str], gap_m: float
) -> tuple[str, ...]:
    """GUIDs of the ``structure`` bodies (body → GUID) within ``gap_m`` of ``body_id`` at its side, in
    the order of ``structure``."""
    found: list[str] = []
    for other, guid in structure.items():
        points = p.getClosestPoints(bodyA=body_id, bodyB=other, distance=gap_m, physicsClientId=client_id)
        if not points:
            continue
        # where the two come closest (the parts of a compound shape give a point a pair: a beam lying on a
        # column also has its flange 4 mm beside the column's top, which is not where they meet);
        # contactNormalOnB (index 7) points from the other body towards this one
        nearest_m = min(point[8] for point in points)
        if any(
            abs(point[7][2]) < SIDE_NORMAL_MAX_Z for point in points if point[8] <= nearest_m + NEAREST_BAND_M
        ):
            found.append(guid)
    return tuple(found)


@dataclass(frozen=True)
class ConnectionPlan:
    """What is made as a member is let go at its target (:func:`plan_connections`)."""

    kinds: dict[str, ConnectionKind]  # every neighbour it is connected to → how
    fixed_to: tuple[str, ...]  # those that hold it where it was put (all but bearings on a contact)
    holds_at_s: dict[str, float]  # fixing ones → after how long they hold (sim s from the release)
    connection_s: float  # the crew time while its robot holds it (the longest of the kinds made)


def plan_connections(
    made: Sequence[str],
    links: Mapping[str, ConnectionLink],
    jointed: Sequence[str],
    fallback_s: float,
) -> ConnectionPlan:
    """Kinds and times for the neighbours ``made`` (GUIDs in order): a neighbour the manifest links is
    connected as its link says; one it does not (an older build, a contact physics found) as a bolted end
    in ``fallback_s``. A bearing holds by friction only, except on a joint partner (no contact between
    the two: it would pass into it), which holds it as a fixed connection would."""
    kinds: dict[str, ConnectionKind] = {}
    holds_at_s: dict[str, float] = {}
    connection_s = 0.0
    for guid in made:
        link = links.get(guid)
        kind = link.kind if link is not None else ConnectionKind.PINNED_END
        time_s = link.time_s if link is not None else fallback_s
        kinds[guid] = kind
        connection_s = max(connection_s, time_s)
        if kind.fixes or guid in jointed:
            holds_at_s[guid] = time_s + (link.set_s if link is not None else 0.0)
    if hinged_only(holds_at_s, kinds, jointed):
        holds_at_s = {}  # one pinned end is a hinge: the member turns about it unless something else holds it
    return ConnectionPlan(kinds, tuple(holds_at_s), holds_at_s, connection_s)


def hinged_only(
    holds: Mapping[str, float], kinds: Mapping[str, ConnectionKind], jointed: Sequence[str]
) -> bool:
    """Whether the member is held by a single pinned end and nothing else: a bolted shear end lets it turn,
    so it stands only with a second end (or a fixed connection, a joint, a support) holding it."""
    pinned = [guid for guid in holds if kinds[guid] is ConnectionKind.PINNED_END and guid not in jointed]
    return len(holds) == 1 and len(pinned) == 1


def within_gap(client_id: int, body_id: int, structure: Mapping[int, str], gap_m: float) -> tuple[str, ...]:
    """GUIDs of the ``structure`` bodies (body → GUID) within ``gap_m`` of ``body_id``, on any side."""
    return tuple(
        guid
        for other, guid in structure.items()
        if p.getClosestPoints(bodyA=body_id, bodyB=other, distance=gap_m, physicsClientId=client_id)
    )


def longest_hold_s(component: Component, fallback_s: float) -> float:
    """The longest its robot may hold it: its slowest connection and all its temporary supports."""
    need = component.temporary_support
    slowest = max((link.time_s for link in component.connection_links), default=0.0)
    return max(slowest, fallback_s) + (need.count * need.place_s if need is not None else 0.0)
