"""Odometry: a robot's dead reckoning, integrated from its true per-period motion plus Gaussian noise.

Why noise on the truth: a robot localises from odometry and its laser (never from physics' ground truth),
so physics gives it what wheel encoders and a gyro would: increments that drift. A tower crane gets no
odometry of its own: it stands where it was built (:mod:`.simulation` publishes its fixed pose).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bimbot.shared.geometry import wrap_angle


@dataclass(frozen=True)
class OdomReading:
    pose_xy_yaw: tuple[float, float, float]
    v_mps: float
    w_radps: float


class Odometry:
    """Dead reckoning from the true per-period motion, each increment disturbed by Gaussian noise.

    Per control period, with ``d`` the true distance and ``dθ`` the true heading change:
    σ(distance) = ``noise``·d and σ(heading) = ``noise``·(|dθ| + ``HEADING_PER_M``·d). Noise 0 gives the
    true pose exactly; a stopped robot's odometry never drifts. Starts at the robot's true start pose.
    """

    HEADING_PER_M = 0.2  # rad of heading noise scale per metre driven, times ``noise``

    def __init__(
        self, start_xy_yaw: tuple[float, float, float], noise: float, rng: np.random.Generator
    ) -> None:
        self.pose_xy_yaw = start_xy_yaw
        self.noise = noise
        self._rng = rng

    def update(
        self, previous: tuple[float, float, float], current: tuple[float, float, float], period_s: float
    ) -> OdomReading:
        c, s = math.cos(previous[2]), math.sin(previous[2])
        dx, dy = current[0] - previous[0], current[1] - previous[1]
        forward, left = c * dx + s * dy, -s * dx + c * dy  # increment in the robot's previous frame
        turn = wrap_angle(current[2] - previous[2])
        if self.noise > 0.0:
            distance = math.hypot(forward, left)
            scale = 1.0 + self._rng.normal(0.0, self.noise)
            forward, left = forward * scale, left * scale
            turn += self._rng.normal(0.0, self.noise * (abs(turn) + self.HEADING_PER_M * distance))
        x, y, yaw = self.pose_xy_yaw
        co, so = math.cos(yaw), math.sin(yaw)
        self.pose_xy_yaw = (
            x + co * forward - so * left,
            y + so * forward + co * left,
            wrap_angle(yaw + turn),
        )
        return OdomReading(self.pose_xy_yaw, forward / period_s, turn / period_s)
