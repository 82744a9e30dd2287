"""Numeric bounds of the bus messages (:mod:`bimbot.shared.messages`): constants and constrained types.

Schema-valid nonsense used to get through: a ``sim_time_s`` of 1e40 flipped constructed components back to
released, a clock ``step`` of 1e9 froze a robot. Each number of a message is declared with one of the types
here, so :func:`bimbot.shared.bus.decode` rejects (logs and counts) an out-of-bound payload like any other
invalid one. The bounds are far outside what a real site produces, so no producer trips them, and far
inside what breaks a consumer (float precision, integer overflow, a wait that never ends).

* no NaN and no infinity anywhere, except a laser range, where +inf is the usual "no return" (physics
  itself publishes ``range_max_m`` for a beam that hits nothing);
* sim times in [0, :data:`MAX_SIM_TIME_S`]; clock steps and epochs in [0, :data:`MAX_STEP`);
* positions within :data:`MAX_SITE_M` of the site origin on each axis; quaternions of unit norm within
  :data:`QUAT_NORM_TOLERANCE`; angles within :data:`MAX_ANGLE_RAD`;
* speeds within :data:`MAX_SPEED_MPS` and :data:`MAX_TURN_RADPS`; Unix wall times in
  [0, :data:`MAX_WALL_TIME_S`];
* counts, attempts, masses, distances and durations ≥ 0; percentages in [0, 100].
"""

from __future__ import annotations

import math
from typing import Annotated, Final

from pydantic import AfterValidator, Field

# s of simulated time (≈ 3.2 years: a large project's whole programme; 116 days, the bound before, stopped a
# 945-element Revit frame's build halfway), short of float trouble
MAX_SIM_TIME_S: Final = 1.0e8
MAX_STEP: Final = 10**9  # clock steps and epochs are below this (no run takes a billion control periods)
MAX_SITE_M: Final = 1.0e5  # m, |x|, |y|, |z| on site (the converter moves far models to a local origin)
MAX_ANGLE_RAD: Final = 1.0e3  # |yaw| and angles (producers wrap them into [-π, π))
MAX_SPEED_MPS: Final = 1.0e3  # |v| (robots' limits are ≤ 20 m/s; odometry is measured, hence the margin)
MAX_TURN_RADPS: Final = 1.0e3  # |ω| (odometry: a wrapped turn over one physics step can reach π/step_s)
MAX_WALL_TIME_S: Final = 1.0e11  # Unix time, s (year ≈ 5000)
QUAT_NORM_TOLERANCE: Final = 1.0e-3  # | |q| - 1 | of a quaternion on the bus (pybullet's are float32)


def _unit_norm(quat_xyzw: tuple[float, float, float, float]) -> tuple[float, float, float, float]:
    if abs(math.sqrt(sum(c * c for c in quat_xyzw)) - 1.0) > QUAT_NORM_TOLERANCE:
        raise ValueError(f"quaternion {quat_xyzw} is not of unit norm (±{QUAT_NORM_TOLERANCE:g})")
    return quat_xyzw


Finite = Annotated[float, Field(allow_inf_nan=False)]
NonNegative = Annotated[float, Field(ge=0.0, allow_inf_nan=False)]
SimTime = Annotated[float, Field(ge=0.0, le=MAX_SIM_TIME_S, allow_inf_nan=False)]
WallTime = Annotated[float, Field(ge=0.0, le=MAX_WALL_TIME_S, allow_inf_nan=False)]
Step = Annotated[int, Field(ge=0, lt=MAX_STEP)]
Count = Annotated[int, Field(ge=0)]
SiteCoord = Annotated[float, Field(ge=-MAX_SITE_M, le=MAX_SITE_M, allow_inf_nan=False)]
Angle = Annotated[float, Field(ge=-MAX_ANGLE_RAD, le=MAX_ANGLE_RAD, allow_inf_nan=False)]
Speed = Annotated[float, Field(ge=-MAX_SPEED_MPS, le=MAX_SPEED_MPS, allow_inf_nan=False)]
TurnRate = Annotated[float, Field(ge=-MAX_TURN_RADPS, le=MAX_TURN_RADPS, allow_inf_nan=False)]
Position = tuple[SiteCoord, SiteCoord, SiteCoord]
PointXY = tuple[SiteCoord, SiteCoord]
PoseXYYaw = tuple[SiteCoord, SiteCoord, Angle]
UnitQuat = Annotated[tuple[Finite, Finite, Finite, Finite], AfterValidator(_unit_norm)]
Range = Annotated[float, Field(ge=0.0)]  # a laser range: ≥ 0, +inf allowed ("no return"), never NaN
SimDuration = Annotated[float, Field(ge=0.0, le=MAX_SIM_TIME_S, allow_inf_nan=False)]  # sim s, ≥ 0
Period = Annotated[float, Field(gt=0.0, le=MAX_SIM_TIME_S, allow_inf_nan=False)]  # sim s, > 0
RangeMax = Annotated[float, Field(gt=0.0, le=MAX_SITE_M, allow_inf_nan=False)]  # m
JointValue = Annotated[float, Field(ge=-MAX_SITE_M, le=MAX_SITE_M, allow_inf_nan=False)]  # rad or m
Percent = Annotated[float, Field(ge=0.0, le=100.0, allow_inf_nan=False)]
FixStd = Annotated[float, Field(gt=0.0, le=10.0, allow_inf_nan=False)]  # a position fix's std. dev., m
