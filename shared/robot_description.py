"""What a robot type can carry and reach: the one description physics, robots and the planner share.

A fleet file (:mod:`.fleet`) holds one description per robot type. Physics spawns from it and serves the
descriptions with its site info (``SiteInfoMsg.robot_types``); a robot reads its own type from there, the
planner all of them. Nobody keeps a second default for a robot's limits: the rules below are the only
place they are applied.

A robot type says what it can do as a set of :class:`Capability` values; every service asks for a
capability, never for a kind of robot. Adding a kind is a fleet entry (its capabilities and the specs they
need) plus, per service, at most one module that implements a new capability. The reach rules, the only
place they are applied:

* a robot that ``drive``s reaches a component when the horizontal distance from the robot's centre to the
  *nearest point* of the component's footprint (its posed bounding box seen from above) is at most
  ``reach_m`` (physics accepts or refuses an attach/place with it, the robot chooses where to stand by
  it, the planner checks feasibility with it);
* a robot that lifts by hook (``hook_lift``, its ``crane`` spec) stands still. The hook is slung above a
  load's centre, so its **hook radius** is the distance from the mast to the centre of the component's
  footprint; a component is within reach when that radius lies between the trolley's innermost radius and
  the largest radius at which the load chart lifts its mass (linear between the chart's points, nothing
  beyond the last);
* a boom machine that stands fixed and works in place (``pour``, ``lay``, ``pile``) reaches a component when
  its whole footprint lies within ``reach_m`` of its base (the boom covers every part of it); a truck-mounted
  one that may ``relocate`` reaches it from any of the set-up positions the site plan gives it
  (``SiteLayout.setups``), at the cost of a relocation (:meth:`RobotDescription.relocation_s`).

Feasibility (before a task is ever assigned): a component heavier than ``payload_kg`` (for a crane: the
chart's largest payload) is ``too_heavy``; one whose target reaches higher than ``max_place_height_m`` (the
top of its posed bounding box) is ``out_of_reach``. Both are reasons a user can act on.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from enum import StrEnum
from typing import TYPE_CHECKING

from pydantic import BaseModel, ConfigDict, Field, field_serializer, model_validator

from .reasons import Reason, ReasonCode

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


class Capability(StrEnum):
    """What a robot type can do. Services ask for these, never for a kind of robot."""

    DRIVE = "drive"  # moves itself across the site on wheels or tracks: plans paths, scans, localises
    STAND_FIXED = "stand_fixed"  # stands where the site plan puts it and never moves: it knows its pose
    CARRY = "carry"  # carries a load on itself from where it lies to where it goes
    HOOK_LIFT = "hook_lift"  # lifts a load by its hook within its load chart (``crane``)
    PLACE = "place"  # sets a component at its target, up to ``max_place_height_m``
    HAND_OFF = "hand_off"  # puts a load down in a crane's staging area for the crane to lift
    POUR = "pour"  # forms and pours cast-in-place concrete within its boom's reach (``reach_m``)
    LAY = "lay"  # lays masonry course by course within its boom's reach (``laying``)
    PILE = "pile"  # pitches and drives piles within its reach (``piling``)
    # a truck-mounted machine that stands fixed but drives to another of its set-up positions (the site
    # plan's) for work its boom cannot reach from where it stands: stow, drive, set up (``setup_s``,
    # ``relocation_speed_mps``)
    RELOCATE = "relocate"


GROUND_CAPABILITIES = frozenset({Capability.DRIVE, Capability.CARRY, Capability.PLACE, Capability.HAND_OFF})
CRANE_CAPABILITIES = frozenset({Capability.STAND_FIXED, Capability.HOOK_LIFT, Capability.PLACE})


LIFT_CLEARANCE_M = 3.0  # a crane lifts a load this far above the higher of its two ends before slewing


class LoadPoint(BaseModel):
    """One line of a crane's load chart: at this hook radius it lifts at most this mass."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    radius_m: float = Field(gt=0, le=150)
    payload_kg: float = Field(gt=0, le=1e6)


class CraneSpec(BaseModel):
    """A tower crane's joints and chart: slew about the mast, trolley along the jib, hoist below it."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    jib_height_m: float = Field(gt=0, le=300, description="height of the jib (hook's highest point)")
    min_radius_m: float = Field(ge=0, le=150, description="trolley's innermost hook radius")
    slew_radps: float = Field(gt=0, le=5)
    trolley_mps: float = Field(gt=0, le=10)
    hoist_mps: float = Field(gt=0, le=10)
    load_chart: tuple[LoadPoint, ...] = Field(min_length=1, description="radii ascending")
    max_jib_height_m: float | None = Field(
        default=None,
        gt=0,
        le=300,
        description="the most its mast stands free-standing: the site erects it as high as the building "
        "needs, up to this (shared/crane_erection.py); none: it stands at jib_height_m",
    )
    mast_raised_m: float = Field(
        default=0.0,
        ge=0,
        le=300,
        description="how much taller the site erected it than its URDF draws it (set by the site plan: "
        "physics and the dashboard stretch the mast, shared/crane_mast.py)",
    )

    @model_validator(mode="after")
    def _ascending(self) -> CraneSpec:
        if self.max_jib_height_m is not None and self.max_jib_height_m < self.jib_height_m:
            raise ValueError("max_jib_height_m must be at least jib_height_m")
        radii = [point.radius_m for point in self.load_chart]
        if radii != sorted(radii) or len(set(radii)) != len(radii):
            raise ValueError("load_chart radii must be strictly ascending")
        if self.min_radius_m >= radii[-1]:
            raise ValueError("min_radius_m must be below the load chart's largest radius")
        return self

    @property
    def max_radius_m(self) -> float:
        return self.load_chart[-1].radius_m

    def payload_at(self, radius_m: float) -> float:
        """The chart's payload at ``radius_m`` (kg): the first point's up to its radius, linear between
        points, 0 below the trolley's innermost radius and beyond the last point."""
        import numpy as np  # not loaded by processes that only decode messages

        if radius_m < self.min_radius_m - 1e-9 or radius_m > self.max_radius_m + 1e-9:
            return 0.0
        radii = [point.radius_m for point in self.load_chart]
        payloads = [point.payload_kg for point in self.load_chart]
        return float(np.interp(radius_m, radii, payloads, left=payloads[0], right=payloads[-1]))

    def motion_s(self, base_xy_m: ArrayLike, from_xyz_m: ArrayLike, to_xyz_m: ArrayLike) -> float:
        """Sim seconds to move a load from ``from_xyz_m`` to ``to_xyz_m`` with the crane at ``base_xy_m``:
        hoist it ``LIFT_CLEARANCE_M`` above the higher end, slew and trolley at once (the longer of the
        two), lower it onto the target."""
        import numpy as np  # not loaded by processes that only decode messages

        base = np.asarray(base_xy_m, float)[:2]
        start, end = np.asarray(from_xyz_m, float), np.asarray(to_xyz_m, float)
        a, b = start[:2] - base, end[:2] - base
        turn = abs(math.remainder(math.atan2(b[1], b[0]) - math.atan2(a[1], a[0]), math.tau))
        radial = abs(float(np.hypot(*b)) - float(np.hypot(*a)))
        peak = min(self.jib_height_m, max(start[2], end[2]) + LIFT_CLEARANCE_M)
        hoist = max(0.0, peak - start[2]) + max(0.0, peak - end[2])
        return max(turn / self.slew_radps, radial / self.trolley_mps) + hoist / self.hoist_mps

    def radius_for(self, mass_kg: float) -> float:
        """The largest hook radius at which the chart lifts ``mass_kg`` (0 when it lifts it nowhere)."""
        chart = self.load_chart
        if mass_kg > max(point.payload_kg for point in chart):
            return 0.0
        best = 0.0
        previous: LoadPoint | None = None
        for point in chart:
            if point.payload_kg >= mass_kg:
                best = point.radius_m
            elif previous is not None and previous.payload_kg >= mass_kg:
                share = (previous.payload_kg - mass_kg) / (previous.payload_kg - point.payload_kg)
                best = previous.radius_m + share * (point.radius_m - previous.radius_m)
                break
            previous = point
        return best


class LayingSpec(BaseModel):
    """A block-laying machine's work: the block it lays and how fast (a course is one block high)."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    block_length_m: float = Field(gt=0, le=5)
    block_height_m: float = Field(gt=0, le=2)
    block_width_m: float = Field(gt=0, le=2)
    block_mass_kg: float = Field(gt=0, le=1000)
    blocks_per_h: float = Field(gt=0, le=10000)


class PilingSpec(BaseModel):
    """A piling rig's work: pitching a pile (slinging it, lifting it upright into the hammer's grip, setting
    its toe on its mark) and driving it at a rate of penetration."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    pitch_s: float = Field(ge=0, le=86400)
    penetration_m_per_h: float = Field(gt=0, le=10000)

    def drive_s(self, length_m: float) -> float:
        """Seconds to pitch a pile ``length_m`` long and drive it to its toe."""
        return self.pitch_s + 3600.0 * max(0.0, length_m) / self.penetration_m_per_h


class RobotDescription(BaseModel):
    """One robot type: its model, its limits and its footprint (SI units, robot base frame)."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    name: str = Field(min_length=1, max_length=64, pattern=r"^[a-z0-9_-]+$")
    urdf: str = Field(
        description="URDF: absolute, relative to the fleet file, bimbot's models or pybullet_data"
    )
    payload_kg: float = Field(gt=0, le=1e6)
    reach_m: float = Field(gt=0, le=150, description="robot centre → nearest point of the footprint")
    max_place_height_m: float = Field(gt=0, le=300, description="highest target top it can place")
    length_m: float = Field(gt=0, le=50)
    width_m: float = Field(gt=0, le=50)
    max_speed_mps: float = Field(ge=0, le=20, description="0 for a crane: it never drives")
    max_turn_radps: float = Field(ge=0, le=20)
    max_step_m: float = Field(
        default=0.0,
        ge=0,
        le=1,
        description="a ground robot: the highest edge of a built floor it drives up onto (a ground slab, "
        "its flooring); a floor no higher than this is driven on once built, not driven round",
    )
    handling_s: float = Field(default=2.0, ge=0, le=3600, description="to grip or sling, and to release")
    placement_precision_m: float = Field(default=0.0, ge=0, le=1, description="1 σ, per horizontal axis")
    placement_precision_yaw_deg: float = Field(default=0.0, ge=0, le=45, description="1 σ")
    placement_guided_ends: bool = Field(
        default=False,
        description="a load is landed with each end guided onto its seat (tag lines, then a connector's "
        "drift pin at each end): the turn is no larger than what sets an end placement_precision_m off",
    )
    cost_per_h: float | None = Field(
        default=None,
        ge=0,
        le=1e6,
        description="hourly rate of one robot of this type (any currency; bimbot study costs busy hours)",
    )
    relocation_speed_mps: float = Field(
        default=0.0, ge=0, le=20, description="a machine that relocates: its driving speed on site"
    )
    setup_s: float = Field(
        default=0.0, ge=0, le=86400, description="a machine that relocates: to stow and to set up again"
    )
    crane: CraneSpec | None = None
    laying: LayingSpec | None = None
    piling: PilingSpec | None = None
    capabilities: frozenset[Capability] = Field(
        default=frozenset(),
        description="what it can do; when left out: a crane spec means "
        "stand_fixed, hook_lift, place; else drive, carry, place, hand_off",
    )

    @field_serializer("capabilities")
    def _sorted(self, capabilities: frozenset[Capability]) -> list[str]:
        return sorted(capabilities)

    @model_validator(mode="before")
    @classmethod
    def _implied_capabilities(cls, data: object) -> object:
        """A type that names no capabilities is a ground robot, or a crane when it has a crane spec."""
        if isinstance(data, dict) and not data.get("capabilities"):
            implied = CRANE_CAPABILITIES if data.get("crane") is not None else GROUND_CAPABILITIES
            data = {**data, "capabilities": implied}
        return data

    @model_validator(mode="after")
    def _consistent(self) -> RobotDescription:
        has = self.capabilities
        if (Capability.DRIVE in has) == (Capability.STAND_FIXED in has):
            raise ValueError(f"robot type {self.name!r} must either drive or stand_fixed (one of the two)")
        if Capability.DRIVE in has and (self.max_speed_mps <= 0 or self.max_turn_radps <= 0):
            raise ValueError(
                f"robot type {self.name!r} drives: it needs max_speed_mps and max_turn_radps > 0"
            )
        if (Capability.HOOK_LIFT in has) != (self.crane is not None):
            raise ValueError(f"robot type {self.name!r}: hook_lift and a [crane] spec go together")
        if (Capability.LAY in has) != (self.laying is not None):
            raise ValueError(f"robot type {self.name!r}: lay and a [laying] spec go together")
        if (Capability.PILE in has) != (self.piling is not None):
            raise ValueError(f"robot type {self.name!r}: pile and a [piling] spec go together")
        if Capability.RELOCATE in has and (
            Capability.STAND_FIXED not in has or Capability.HOOK_LIFT in has or self.relocation_speed_mps <= 0
        ):
            raise ValueError(
                f"robot type {self.name!r}: relocate is for a boom machine that stands fixed (not a crane), "
                "with relocation_speed_mps > 0"
            )
        if Capability.HAND_OFF in has and Capability.CARRY not in has:
            raise ValueError(f"robot type {self.name!r}: hand_off needs carry")
        if self.crane is not None:
            chart_max = max(point.payload_kg for point in self.crane.load_chart)
            if abs(chart_max - self.payload_kg) > 1e-6 or abs(self.crane.max_radius_m - self.reach_m) > 1e-6:
                raise ValueError(
                    f"crane type {self.name!r}: payload_kg and reach_m must be its load chart's largest "
                    f"payload ({chart_max:g} kg) and radius ({self.crane.max_radius_m:g} m)"
                )
        return self

    def can(self, capability: Capability) -> bool:
        """Whether this type has ``capability``."""
        return capability in self.capabilities

    @property
    def radius_m(self) -> float:
        """Circumscribed radius of the footprint (what the planning grid inflates by)."""
        return 0.5 * math.hypot(self.length_m, self.width_m)

    def refusal(self, mass_kg: float, target_top_z_m: float) -> Reason | None:
        """``too_heavy`` / ``out_of_reach`` for a component of ``mass_kg`` whose target top is at
        ``target_top_z_m`` (world z, m), or None when this type can carry and place it."""
        if mass_kg > self.payload_kg:
            what = "largest crane payload (load chart)" if self.crane is not None else "payload"
            return Reason(
                code=ReasonCode.TOO_HEAVY,
                message=f"{mass_kg:,.0f} kg exceeds the {self.name} {what} of {self.payload_kg:,.0f} kg",
            )
        if target_top_z_m > self.max_place_height_m:
            return Reason(
                code=ReasonCode.OUT_OF_REACH,
                message=(
                    f"target top at {target_top_z_m:.2f} m is above the {self.name} placement height "
                    f"of {self.max_place_height_m:.2f} m"
                ),
            )
        return None

    def reaches(self, robot_xy_m: ArrayLike, footprint_xy_m: ArrayLike, mass_kg: float = 0.0) -> bool:
        """The reach rule (see the module docstring) for one robot position and a load of ``mass_kg``."""

        from .footprint import footprint_distance_m

        if self.crane is not None:
            hook_m = self.hook_radius_m(robot_xy_m, footprint_xy_m)
            return self.crane.min_radius_m - 1e-9 <= hook_m <= self.crane.radius_for(mass_kg) + 1e-9
        if self.can(Capability.STAND_FIXED):
            return self.boom_covers(robot_xy_m, footprint_xy_m)
        nearest = float(footprint_distance_m(footprint_xy_m, robot_xy_m)[0])
        return nearest <= self.reach_m + 1e-9

    @property
    def relocates(self) -> bool:
        """A machine that stands fixed but may drive to another set-up position (``relocate``)."""
        return Capability.RELOCATE in self.capabilities

    def relocation_s(self, from_xy_m: ArrayLike, to_xy_m: ArrayLike) -> float:
        """Sim seconds to move between two set-up positions: stow and set up again (``setup_s``) and drive
        the grid distance between them (|dx| + |dy|: the site's lanes run along its axes) at
        ``relocation_speed_mps``; 0 when they are the same place."""
        import numpy as np  # not loaded by processes that only decode messages

        delta = np.asarray(to_xy_m, float)[:2] - np.asarray(from_xy_m, float)[:2]
        drive_m = float(np.abs(delta).sum())
        if drive_m < 1e-3:
            return 0.0
        speed = self.relocation_speed_mps if self.relocation_speed_mps > 0 else math.inf
        return self.setup_s + drive_m / speed

    def setup_for(
        self,
        setups: Sequence[tuple[float, float, float]],
        from_xy_m: ArrayLike,
        footprint_xy_m: ArrayLike,
    ) -> tuple[float, float, float] | None:
        """Of ``setups`` (a machine that stands fixed: where it may set up), the one it works on a footprint
        from, standing at ``from_xy_m``: among those whose boom covers it, the one it relocates to soonest
        (where it stands, when that covers it; then the earlier one); None when none covers it. The planner
        estimates by it and the machine relocates by it."""
        covering = [pose for pose in setups if self.boom_covers(pose[:2], footprint_xy_m)]
        if not covering:
            return None
        return min(covering, key=lambda pose: self.relocation_s(from_xy_m, pose[:2]))

    def boom_covers(self, base_xy_m: ArrayLike, footprint_xy_m: ArrayLike) -> bool:
        """A fixed boom machine reaches every corner of the footprint from ``base_xy_m``."""
        import numpy as np  # not loaded by processes that only decode messages

        corners = np.asarray(footprint_xy_m, float).reshape(-1, 2)
        far_m = float(np.max(np.hypot(*(corners - np.asarray(base_xy_m, float)[:2]).T)))
        return far_m <= self.reach_m + 1e-9

    @staticmethod
    def hook_radius_m(base_xy_m: ArrayLike, footprint_xy_m: ArrayLike) -> float:
        """A crane's hook radius for a load: from the mast to the centre of the load's footprint (the hook
        is slung above the load's centre of mass)."""
        import numpy as np  # not loaded by processes that only decode messages

        centre = np.asarray(footprint_xy_m, float).reshape(-1, 2).mean(axis=0)
        return float(np.hypot(*(centre - np.asarray(base_xy_m, float)[:2])))


# The Husky-sized site robot of earlier versions (pybullet_data's Husky with a 1 t payload): what tests and
# the site plan fall back to when no fleet is given. The fleet file (:mod:`.fleet`) holds the real types.
DEFAULT_ROBOT = RobotDescription(
    name="default",
    urdf="husky/husky.urdf",
    payload_kg=1000.0,
    reach_m=1.5,
    max_place_height_m=6.0,
    length_m=0.99,
    width_m=0.67,
    max_speed_mps=1.0,
    max_turn_radps=1.5,
)
