"""A component's self-verification: its pose on the bus against its BIM target pose (paper §4.5).

Pure functions over positions (metres, simulation world frame) and unit quaternions ``quat_xyzw``:

* position error: how far the component's centre (``reference_local_m``, its centre of mass in its own
  frame) is from where the target puts it, metres. Not the distance between the frame origins: a Revit
  element's frame often sits at the model's origin, 100 m from its geometry, and a turn of 0.01° that
  the angle tolerance accepts moved that origin 17 mm — concrete columns of the Revit structural hub
  were failed as misplaced by 20 mm for a turn of a few hundredths of a degree, and a column that tipped
  over was reported 103 m off. For a component whose frame is at its geometry the two are the same;
* angle error: the geodesic angle of the rotation that takes the target orientation to the current one,
  radians in ``[0, π]``. ``q`` and ``-q`` are the same rotation, so the error is sign-invariant. It is
  computed as ``2·atan2(|v|, |w|)`` of the relative quaternion, which stays exact for tiny angles (where
  ``2·acos(|q₁·q₂|)`` loses half its digits).

The quaternion product is written out here rather than taken from scipy's ``Rotation`` (which gives the
same angle, ``(target.inv() * current).magnitude()``; the tests compare the two): the agents' process
must not load numpy/scipy, which would add tens of MB to each of the processes that hold 10,000 agents
(tests/component_agents/test_agents_cli.py checks the imports).

A placement is accepted when both errors are within explicit :class:`Tolerances` (inclusive) and the
component did not move more than the drift tolerance after physics released it (a component that slid,
tipped or fell is ``unstable``, even when it came to rest within tolerance by chance).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

from bimbot.shared.manifest import Quat, Vec3


class HasPose(Protocol):
    """Anything with ``position_m`` and ``quat_xyzw`` (bimbot.shared.messages.PoseMsg,
    bimbot.shared.manifest.Pose)."""

    @property
    def position_m(self) -> Vec3: ...

    @property
    def quat_xyzw(self) -> Quat: ...


@dataclass(frozen=True)
class Tolerances:
    """How far a placed component may be from its BIM target and still count as constructed."""

    position_m: float = 0.01
    angle_rad: float = math.radians(1.0)
    # how far it may have moved since physics released it (slid, tipped, fell): beyond this it is unstable,
    # wherever it came to rest (a beam that fell onto its target's neighbour is not a placement); a placement
    # that holds settles 1-3 mm (Bullet's contact margins)
    drift_m: float = 0.005

    def __post_init__(self) -> None:
        for name in ("position_m", "angle_rad", "drift_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"tolerance {name} must be a finite number ≥ 0, got {value!r}")


@dataclass(frozen=True)
class PlacementCheck:
    """The result of one verification: accepted or not, both errors and the drift since release (the
    agent's verdict trigger, in :mod:`.state_table`, follows from it and the attempts left)."""

    ok: bool
    position_error_m: float
    angle_error_rad: float
    drift_m: float | None = None  # None: physics did not say (a pose from before release)
    unstable: bool = False  # it moved more than the drift tolerance after release


def _unit(quat_xyzw: Quat) -> tuple[float, float, float, float]:
    norm = math.sqrt(sum(c * c for c in quat_xyzw))
    if not (math.isfinite(norm) and norm > 1e-9):
        raise ValueError(f"quaternion {tuple(quat_xyzw)!r} has no orientation (norm {norm})")
    x, y, z, w = (c / norm for c in quat_xyzw)
    return x, y, z, w


def is_valid_pose(position_m: Vec3, quat_xyzw: Quat) -> bool:
    """True when the position is finite and the quaternion is finite and not (near) zero."""
    if not all(math.isfinite(c) for c in position_m):
        return False
    try:
        _unit(quat_xyzw)
    except ValueError:
        return False
    return True


def position_error_m(current_m: Vec3, target_m: Vec3) -> float:
    """Distance between two positions, metres."""
    return math.dist(current_m, target_m)


def rotate(quat_xyzw: Quat, vector: Vec3) -> Vec3:
    """``vector`` turned by the rotation ``quat_xyzw`` (normalised here): v + 2w(q×v) + 2q×(q×v)."""
    x, y, z, w = _unit(quat_xyzw)
    vx, vy, vz = vector
    cx, cy, cz = y * vz - z * vy, z * vx - x * vz, x * vy - y * vx
    dx, dy, dz = y * cz - z * cy, z * cx - x * cz, x * cy - y * cx
    return (vx + 2.0 * (w * cx + dx), vy + 2.0 * (w * cy + dy), vz + 2.0 * (w * cz + dz))


def point_error_m(current: HasPose, target: HasPose, point_local_m: Vec3) -> float:
    """How far the point ``point_local_m`` (in the component's frame) is from where the target puts it."""
    a = rotate(current.quat_xyzw, point_local_m)
    b = rotate(target.quat_xyzw, point_local_m)
    here = (current.position_m[0] + a[0], current.position_m[1] + a[1], current.position_m[2] + a[2])
    there = (target.position_m[0] + b[0], target.position_m[1] + b[1], target.position_m[2] + b[2])
    return math.dist(here, there)


def angle_error_rad(current_xyzw: Quat, target_xyzw: Quat) -> float:
    """Geodesic angle between two orientations, radians in [0, π]; the sign of either quaternion is ignored.

    Raises ValueError for a zero or non-finite quaternion.
    """
    x1, y1, z1, w1 = _unit(target_xyzw)
    x2, y2, z2, w2 = _unit(current_xyzw)
    # relative rotation q_rel = conj(q_target) ⊗ q_current
    w = w1 * w2 + x1 * x2 + y1 * y2 + z1 * z2
    x = w1 * x2 - x1 * w2 - y1 * z2 + z1 * y2
    y = w1 * y2 + x1 * z2 - y1 * w2 - z1 * x2
    z = w1 * z2 - x1 * y2 + y1 * x2 - z1 * w2
    return 2.0 * math.atan2(math.sqrt(x * x + y * y + z * z), abs(w))


def verify(
    current: HasPose,
    target: HasPose,
    tolerances: Tolerances,
    drift_m: float | None = None,
    reference_local_m: Vec3 = (0.0, 0.0, 0.0),
) -> PlacementCheck:
    """Compare a current pose with the BIM target pose against ``tolerances`` (every bound inclusive);
    ``drift_m`` is how far it moved since physics released it, when physics said; the position error is
    that of ``reference_local_m``, the component's centre in its own frame (see the module)."""
    position_error = point_error_m(current, target, reference_local_m)
    angle_error = angle_error_rad(current.quat_xyzw, target.quat_xyzw)
    unstable = drift_m is not None and drift_m > tolerances.drift_m
    ok = position_error <= tolerances.position_m and angle_error <= tolerances.angle_rad and not unstable
    return PlacementCheck(ok, position_error, angle_error, drift_m, unstable)
