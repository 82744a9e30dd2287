"""What a robot type can carry and reach: the one description physics, robots and the planner share.

Physics owns the robots on site and serves their descriptions with its site info
(``SiteInfoMsg.robot_types``); a robot reads its own type from there, the planner all of them. Nobody
keeps a second default for a robot's limits: the rules below are the only place they are applied.

The reach rule (used by physics to accept or refuse an attach/place, by the robot to choose where it
stands, and by the planner's feasibility check): a robot reaches a component when the horizontal distance
from the robot's centre to the *nearest point* of the component's footprint (its posed bounding box seen
from above) is at most ``reach_m``. A wide slab is therefore reachable from any point along its edge, and
a robot standing over a component's footprint is at distance 0.

Feasibility (before a task is ever assigned): a component heavier than ``payload_kg`` is ``too_heavy``; one
whose target reaches higher than ``max_place_height_m`` (the top of its posed bounding box) is
``out_of_reach``. Both are reasons a user can act on (another robot type, another sequence).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from pydantic import BaseModel, ConfigDict, Field

from .reasons import Reason, ReasonCode

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


class RobotDescription(BaseModel):
    """One robot type: its model, its limits and its footprint (SI units, robot base frame)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    name: str = Field(min_length=1, max_length=64, pattern=r"^[a-z0-9_-]+$")
    urdf: str = Field(description="URDF path, absolute or relative to pybullet_data")
    payload_kg: float = Field(gt=0, le=1e6)
    reach_m: float = Field(gt=0, le=100, description="robot centre → nearest point of the footprint")
    max_place_height_m: float = Field(gt=0, le=300, description="highest target top it can place")
    length_m: float = Field(gt=0, le=50)
    width_m: float = Field(gt=0, le=50)
    max_speed_mps: float = Field(gt=0, le=20)
    max_turn_radps: float = Field(gt=0, le=20)

    @property
    def radius_m(self) -> float:
        """Circumscribed radius of the footprint (what the planning grid inflates by)."""
        return 0.5 * math.hypot(self.length_m, self.width_m)

    def refusal(self, mass_kg: float, target_top_z_m: float) -> Reason | None:
        """``too_heavy`` / ``out_of_reach`` for a component of ``mass_kg`` whose target top is at
        ``target_top_z_m`` (world z, m), or None when this type can carry and place it."""
        if mass_kg > self.payload_kg:
            return Reason(
                code=ReasonCode.TOO_HEAVY,
                message=f"{mass_kg:,.0f} kg exceeds the {self.name} payload of {self.payload_kg:,.0f} kg",
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

    def reaches(self, robot_xy_m: ArrayLike, footprint_xy_m: ArrayLike) -> bool:
        """The reach rule (see the module docstring) for one robot position."""
        from .footprint import footprint_distance_m  # numpy: not loaded by processes that only decode

        return bool(footprint_distance_m(footprint_xy_m, robot_xy_m)[0] <= self.reach_m + 1e-9)


# A Husky-sized site robot (pybullet_data's Husky, 0.99 m × 0.67 m) with the payload of a small site
# carrier, so that the bundled frame (259 kg footings) builds; the fleet issue brings real robot types.
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
