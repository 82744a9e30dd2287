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
robot holds it while the connection is made (its kind's time, :mod:`bimbot.shared.connection_hold`, which
the planner's estimate of the task counts too): the place request is answered after that. What rests on
nothing at its side, or lies off its target, is not connected: it stands on its temporary supports if its
manifest gives it some (:mod:`.temporary_supports`, set wherever it was put), else it is released and must
stand by itself. ``--no-connections`` (``bimbot run``,
``--check-stability``) turns this off: every component must then stand by itself, the rehearsal of a
sequence without connections.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

from bimbot.shared.connection_hold import UNLINKED_CONNECTION_S
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
    # how long the robot holds the component while a connection its manifest does not link is made (sim s;
    # a linked one takes its link's time: :func:`bimbot.shared.connection_hold.plan_connections`)
    hold_s: float = UNLINKED_CONNECTION_S
    # the connection is made only where its agent would accept the placement
    fit: Tolerances = field(default_factory=Tolerances)

    def __post_init__(self) -> None:
        for name in ("gap_m", "hold_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"connections: {name} must be a finite number ≥ 0, got {value!r}")


def fits_its_target(
    component: Component,
    frame: Frame,
    fit: Tolerances,
    fitted_target: Frame | None = None,
) -> bool:
    """Whether ``component`` at ``frame`` lies within the agents' tolerances of its BIM target, or of its
    target fitted to the structure as built (:mod:`.support_fit`) when it has one."""
    here = PoseMsg(position_m=frame[0], quat_xyzw=frame[1])
    target = (
        PoseMsg(position_m=fitted_target[0], quat_xyzw=fitted_target[1])
        if fitted_target is not None
        else component.target_pose_world
    )
    return verify(here, target, fit, reference_local_m=component.com_local_m).ok


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


def within_gap(client_id: int, body_id: int, structure: Mapping[int, str], gap_m: float) -> tuple[str, ...]:
    """GUIDs of the ``structure`` bodies (body → GUID) within ``gap_m`` of ``body_id``, on any side."""
    return tuple(
        guid
        for other, guid in structure.items()
        if p.getClosestPoints(bodyA=body_id, bodyB=other, distance=gap_m, physicsClientId=client_id)
    )
