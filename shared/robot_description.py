"""What a robot type can carry and reach: the one description physics, robots and the planner share.

A fleet file (:mod:`.fleet`) holds one description per robot type. Physics spawns from it and serves the
descriptions with its site info (``SiteInfoMsg.robot_types``); a robot reads its own type from there, the
planner all of them. Nobody keeps a second default for a robot's limits: the rules below are the only
place they are applied.

Two kinds of robot:

* **ground** robots drive (differential drive, speed and turn limits) and carry a load on their deck. The
  reach rule (physics accepts or refuses an attach/place with it, the robot chooses where to stand by it,
  the planner checks feasibility with it): a robot reaches a component when the horizontal distance from
  the robot's centre to the *nearest point* of the component's footprint (its posed bounding box seen from
  above) is at most ``reach_m``.
* **tower cranes** (``crane`` set) stand still. The hook is slung above a load's centre, so its **hook
  radius** is the distance from the mast to the centre of the component's footprint; a component is
  within reach when that radius lies between the trolley's innermost radius and the largest radius at
  which the crane's load chart lifts its mass (payload by radius, linear between the chart's points,
  nothing beyond the last). The crane picks where the hook reaches and places there; it never travels.

Feasibility (before a task is ever assigned): a component heavier than ``payload_kg`` (for a crane: the
chart's largest payload) is ``too_heavy``; one whose target reaches higher than ``max_place_height_m`` (the
top of its posed bounding box) is ``out_of_reach``. Both are reasons a user can act on.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from pydantic import BaseModel, ConfigDict, Field, model_validator

from .reasons import Reason, ReasonCode

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


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

    @model_validator(mode="after")
    def _ascending(self) -> CraneSpec:
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
    handling_s: float = Field(default=2.0, ge=0, le=3600, description="to grip or sling, and to release")
    placement_precision_m: float = Field(default=0.0, ge=0, le=1, description="1 σ, per horizontal axis")
    placement_precision_yaw_deg: float = Field(default=0.0, ge=0, le=45, description="1 σ")
    crane: CraneSpec | None = None

    @model_validator(mode="after")
    def _consistent(self) -> RobotDescription:
        if self.crane is None and (self.max_speed_mps <= 0 or self.max_turn_radps <= 0):
            raise ValueError(f"ground robot type {self.name!r} needs max_speed_mps and max_turn_radps > 0")
        if self.crane is not None:
            chart_max = max(point.payload_kg for point in self.crane.load_chart)
            if abs(chart_max - self.payload_kg) > 1e-6 or abs(self.crane.max_radius_m - self.reach_m) > 1e-6:
                raise ValueError(
                    f"crane type {self.name!r}: payload_kg and reach_m must be its load chart's largest "
                    f"payload ({chart_max:g} kg) and radius ({self.crane.max_radius_m:g} m)"
                )
        return self

    @property
    def is_crane(self) -> bool:
        return self.crane is not None

    @property
    def radius_m(self) -> float:
        """Circumscribed radius of the footprint (what the planning grid inflates by)."""
        return 0.5 * math.hypot(self.length_m, self.width_m)

    def refusal(self, mass_kg: float, target_top_z_m: float) -> Reason | None:
        """``too_heavy`` / ``out_of_reach`` for a component of ``mass_kg`` whose target top is at
        ``target_top_z_m`` (world z, m), or None when this type can carry and place it."""
        if mass_kg > self.payload_kg:
            what = "largest crane payload (load chart)" if self.is_crane else "payload"
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

        if self.crane is None:
            nearest = float(footprint_distance_m(footprint_xy_m, robot_xy_m)[0])
            return nearest <= self.reach_m + 1e-9
        hook_m = self.hook_radius_m(robot_xy_m, footprint_xy_m)
        return self.crane.min_radius_m - 1e-9 <= hook_m <= self.crane.radius_for(mass_kg) + 1e-9

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
