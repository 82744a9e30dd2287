"""Where a placement really puts a component: the robot's belief about itself, and its hand's precision.

Why: a robot commands a placement in the world frame as it believes the world is, but it can only move the
component relative to its own body. Physics therefore carries the commanded pose from the robot's believed
frame into its true frame (``true ∘ believed⁻¹ ∘ commanded``): a robot localised 3 cm east of where it
stands places 3 cm west of the target, and a robot that localises badly places badly. On top comes the
robot type's placement precision (:class:`bimbot.shared.robot_description.RobotDescription`: 1σ per
horizontal axis and in yaw, the turn about the vertical through the component's centre — where the hand
holds it — not about its frame origin, which for a Revit element often sits at the model origin 100 m
away, where a turn of 0.2° swung the column 350 mm), drawn from a seeded generator, so a run is
reproducible and a type with a poor hand misses more often. Pure: no pybullet, frames in, frame out
(metres, radians, world frame, Z up).
"""

from __future__ import annotations

import math

import numpy as np

from .scene import Frame, compose, invert, quat_multiply, turned_about, yaw_quat


def guided_yaw_std_rad(yaw_std_rad: float, precision_m: float, half_span_m: float) -> float:
    """The 1σ turn of a load landed with each end guided onto its seat (tag lines, then a connector at
    each end): no larger than what sets an end ``precision_m`` off, ``half_span_m`` from its centre. A
    crane's free turn (0.2°) would swing the ends of a 30 m beam 52 mm; a crew sets each end."""
    if half_span_m <= 0.0 or precision_m <= 0.0:
        return yaw_std_rad
    return min(yaw_std_rad, math.atan2(precision_m, half_span_m))


def ground_frame(xy_yaw: tuple[float, float, float]) -> Frame:
    """A robot's pose on the ground as a frame (z 0: robots stand on flat ground)."""
    x, y, yaw = xy_yaw
    return (x, y, 0.0), yaw_quat(yaw)


def physical_placement(
    commanded: Frame,
    believed_xy_yaw: tuple[float, float, float] | None,
    true_xy_yaw: tuple[float, float, float],
    *,
    precision_m: float,
    precision_yaw_rad: float,
    rng: np.random.Generator,
    centre_local_m: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> Frame:
    """The pose the component really gets: ``commanded`` (world, as the robot believes it) moved by the
    robot's localisation error, then by a precision draw (horizontal offset, and a turn about the vertical
    axis through the component's frame origin). ``believed_xy_yaw`` None: the robot knows its pose."""
    frame = commanded
    if believed_xy_yaw is not None:
        relative = compose(invert(ground_frame(believed_xy_yaw)), commanded)
        frame = compose(ground_frame(true_xy_yaw), relative)
    dx, dy = (float(v) for v in rng.normal(0.0, precision_m, 2)) if precision_m > 0 else (0.0, 0.0)
    dyaw = float(rng.normal(0.0, precision_yaw_rad)) if precision_yaw_rad > 0 else 0.0
    # the turn is about the vertical through the component's centre: the centre stays, the frame moves
    (x, y, z), turned = turned_about(frame, quat_multiply(yaw_quat(dyaw), frame[1]), centre_local_m)
    return (x + dx, y + dy, z), turned


def offset_m(a: Frame, b: Frame) -> float:
    """Distance between two frames' origins (m)."""
    return math.dist(a[0], b[0])
