"""What a robot may lift, and where a load it cannot deliver goes down (pure: no pybullet).

Why apart from :mod:`.handling`: these are the rules of the robot descriptions
(:mod:`bimbot.shared.robot_description`) applied to one request, worded for the user. A refusal names the
robot, its type, the component and the numbers, so the robot's log, the planner's give-back and the run's
report say what to change (a bigger robot, a crane nearer, a lighter element).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

from bimbot.shared.footprint import footprint_distance_m, posed_footprint
from bimbot.shared.manifest import Component
from bimbot.shared.robot_description import Capability, RobotDescription
from bimbot.shared.site_plan import Rect
from bimbot.shared.yard_slot import GROUND_CLEARANCE_M, lying_rotation

from .crane import load_box
from .scene import Frame, compose, footprint, yaw_of, yaw_quat

DROP_GAP_M = 0.3  # between a lost robot and the load it drops


def carry_refusal(
    description: RobotDescription,
    robot_id: str,
    robot_xy_m: ArrayLike,
    component: Component,
    frame: Frame,
    *,
    what: str,
) -> tuple[str | None, float | None]:
    """Whether a robot of ``description`` at ``robot_xy_m`` may lift ``component`` at ``frame`` (attach:
    where it lies; place: its target): ``(None, None)`` when it may, else ``(refusal, distance_m)`` — the
    distance to the footprint's nearest point when reach decided. ``what`` names the place in a reach
    refusal (the GUID, or "the target of <GUID>").

    A ground robot: no heavier than its payload, the footprint's nearest point within its reach. A crane
    (:meth:`~bimbot.shared.robot_description.RobotDescription.reaches`): that point between its smallest
    hook radius and its reach, and the mass within its load chart at the footprint's farthest point."""
    crane = description.crane if description.can(Capability.HOOK_LIFT) else None
    mass = component.mass_kg
    weight = f"{mass:,.0f} kg"
    load = (
        f"{component.name} ({component.guid}, {weight})" if component.name else f"{component.guid} ({weight})"
    )
    if crane is None and mass > description.payload_kg:
        payload = f"{description.name}, {description.payload_kg:,.0f} kg"
        return f"{load} exceeds {robot_id}'s payload ({payload})", None
    polygon = np.asarray(posed_footprint(component, frame[0], frame[1]).polygon_xy_m, dtype=float)
    robot_xy = np.asarray(robot_xy_m, dtype=float)[:2]
    if description.reaches(robot_xy, polygon, mass):
        return None, None
    nearest = float(footprint_distance_m(polygon, robot_xy)[0])
    who = f"{'robot' if crane is None else 'crane'} {robot_id} ({description.name})"
    if crane is None or nearest > description.reach_m + 1e-9:
        return (
            f"{who} is {nearest:.2f} m from {what}, reach is {description.reach_m:g} m",
            nearest,
        )
    if nearest < crane.min_radius_m - 1e-9:
        inside = f"inside its smallest hook radius of {crane.min_radius_m:g} m"
        return f"{who} is {nearest:.2f} m from {what}, {inside}", nearest
    farthest = float(np.max(np.hypot(*(polygon - robot_xy).T)))
    chart = (
        f"{description.name}, {crane.payload_at(farthest):,.0f} kg there; it lifts {mass:,.0f} kg out to "
        f"{crane.radius_for(mass):.2f} m"
    )
    return f"{load} exceeds {robot_id}'s load chart at {farthest:.2f} m ({chart})", None


def lowered(component: Component, frame: Frame) -> Frame:
    """A crane's load let down straight below its hook, onto the ground (as it hangs)."""
    bbox = component.bbox_local
    low, _ = load_box(bbox.min_m, bbox.max_m, frame[0], frame[1])
    (x, y, z), quat = frame
    return (x, y, z - float(low[2]) + GROUND_CLEARANCE_M), quat


def lying_corners(component: Component) -> tuple[np.ndarray, np.ndarray]:
    """The rotation that lays ``component`` flat (as in the yard) and its bounding box's 8 corners turned
    by it, in the component frame: what carrying and putting down both place it by."""
    low, high = np.array(component.bbox_local.min_m), np.array(component.bbox_local.max_m)
    rotation = lying_rotation(high - low)
    corners = np.array(
        [[a, b, c] for a in (low[0], high[0]) for b in (low[1], high[1]) for c in (low[2], high[2])]
    )
    return rotation, corners @ rotation.T


def drop_beside(
    component: Component,
    robot_frame: Frame,
    half_extents_xy_m: tuple[float, float],
    others: list[Rect],
    site_bounds: Rect,
    *,
    near_xy_m: tuple[float, float] | None = None,
) -> Frame:
    """Lying like in the yard, beside the robot: left, right, behind or ahead, the first spot that is free
    of ``others`` (the other components' footprints) and inside the site (else left); with ``near_xy_m``
    (a hand-off's staging spot) the free spot whose centre is nearest it first."""
    (x, y, _), quat = robot_frame
    heading = yaw_quat(yaw_of(quat))
    rotation, turned = lying_corners(component)
    centre = (turned.min(axis=0) + turned.max(axis=0)) / 2.0
    length, depth = turned.max(axis=0)[:2] - turned.min(axis=0)[:2]
    lying_quat = tuple(float(q) for q in Rotation.from_matrix(rotation).as_quat())
    half_x, half_y = half_extents_xy_m
    offsets = (
        (0.0, half_y + DROP_GAP_M + depth / 2.0),
        (0.0, -(half_y + DROP_GAP_M + depth / 2.0)),
        (-(half_x + DROP_GAP_M + length / 2.0), 0.0),
        (half_x + DROP_GAP_M + length / 2.0, 0.0),
    )
    candidates = []
    for dx, dy in offsets:
        local = ((dx - centre[0], dy - centre[1], GROUND_CLEARANCE_M - turned[:, 2].min()), lying_quat)
        candidates.append(compose(((x, y, 0.0), heading), local))  # type: ignore[arg-type]
    ordered = list(candidates)
    if near_xy_m is not None:
        ordered.sort(key=lambda frame: math.dist(_centre_xy(component, frame), near_xy_m))
    for frame in ordered:
        spot = footprint(component, frame)
        inside = site_bounds.min_xy[0] <= spot.min_xy[0] and spot.max_xy[0] <= site_bounds.max_xy[0]
        inside = (
            inside and site_bounds.min_xy[1] <= spot.min_xy[1] and spot.max_xy[1] <= site_bounds.max_xy[1]
        )
        if inside and not any(spot.overlaps(other) for other in others):
            return frame
    return candidates[0]


def _centre_xy(component: Component, frame: Frame) -> tuple[float, float]:
    spot = footprint(component, frame)
    return ((spot.min_xy[0] + spot.max_xy[0]) / 2.0, (spot.min_xy[1] + spot.max_xy[1]) / 2.0)
