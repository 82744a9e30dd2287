"""The static part of the physics scene: component bodies from the manifest (mass, CoM, full inertia and the
converter's convex collision parts), the ground plane and the site fence, plus the frame arithmetic every
other physics module uses.

Why bodies are built by hand and not with ``loadSDF`` (see docs/architecture.md): pybullet's SDF importer
ignores ``<inertia>`` and ``<static>``, and caches parsed files by name (every component's file is called
``model.sdf``). The manifest owns what the ``model.sdf`` files also say, so each component becomes one
multibody from its manifest entry (:func:`component_model`):

* a compound collision shape of the convex ``collision_<i>.obj`` parts, in the component frame (read
  through ASCII links when the build's path is not ASCII: :mod:`.mesh_paths`);
* ``baseInertialFramePosition`` = the CoM and ``baseInertialFrameOrientation`` = the principal axes of the
  full inertia tensor, then ``changeDynamics(mass=…, localInertiaDiagonal=eigenvalues)``, so the full
  tensor (products of inertia included) is honoured;
* pybullet reports and sets a base's *centre-of-mass* frame; :func:`component_pose` and
  :func:`set_component_pose` convert from and to the component frame (the BIM frame of ``<pose>``).

Components at rest are *static* (mass 0) and asleep in Bullet (:func:`put_to_sleep`): they neither fall
nor drift and cost nothing in the solver (static–static pairs are never tested) nor in a step's per-body
work. Each is a Bullet rigid body (``useMaximalCoordinates``), not a
fixed-base multibody: Bullet updates every multibody each step, so 782 resting multibodies made a step 3.5×
dearer than 28; as rigid bodies the step costs about the same (``bench/physics.py --build``). Their real
mass and inertia stay in :class:`ComponentBody` and :func:`make_dynamic` restores them.

Collision filter groups: pybullet lets a pair collide when *either* one's group is in the other's mask
(measured: its default filter ORs the two tests), so two bodies that must not collide both leave the
other's group out of their mask; laser rays hit a body when the ray mask holds its group (:mod:`.sensors`).
:data:`STATIC_GROUP` for resting components and the fence, :data:`GROUND_GROUP` for the ground plane
(never seen by the laser), one bit per robot (:func:`robot_group`), also given to the load it carries:
the robot's mask and the load's both leave that bit out, so the robot neither collides with nor sees it.

Frames: world = the simulation world frame of :mod:`bimbot.shared.manifest` (metres, Z up). A :data:`Frame` is
``((x, y, z), (qx, qy, qz, qw))``.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from itertools import product
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from bimbot.shared.errors import InputError
from bimbot.shared.geometry import Quat, Vec3
from bimbot.shared.manifest import MAX_COLLISION_PARTS, Component
from bimbot.shared.site_plan import FENCE_HEIGHT_M, FENCE_THICKNESS_M, Rect

from .client import p
from .collision_margin import inset_parts, obj_vertices
from .mesh_paths import pybullet_path
from .ray_scene import note_dynamic, note_group, note_moved, register_hulls

_log = logging.getLogger(__name__)

Frame = tuple[Vec3, Quat]

IDENTITY: Frame = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))

ALL_GROUPS = -1  # every bit (pybullet takes a signed 32-bit int)
DYNAMIC_GROUP = 1  # Bullet's DefaultFilter: laser rays carry it as their own group
STATIC_GROUP = 2  # Bullet's StaticFilter: components at rest, placed components, the fence
PIT_EDGE_GROUP = 1 << 2  # the ground round the pits (.pits): touched by released components only
GROUND_GROUP = 1 << 3
FIRST_ROBOT_BIT = 4
ROBOT_BITS = 27  # bits 4..30: robots beyond 27 share bits (they then neither see nor hit each other's loads)
STATIC_MASK = ALL_GROUPS ^ STATIC_GROUP ^ GROUND_GROUP ^ PIT_EDGE_GROUP


def robot_group(index: int) -> int:
    """The collision group bit of the robot with this 0-based index."""
    return 1 << (FIRST_ROBOT_BIT + index % ROBOT_BITS)


# --- frames ------------------------------------------------------------------------------------------------
# quat_multiply, rotate, compose and invert are written out rather than taken from scipy's Rotation: they
# run in the per-step loop (every carried load and every robot frame, each physics step), where small
# Rotation objects cost ~50× more (measured: compose 0.6 µs by hand, 31 µs through Rotation.from_quat,
# apply, multiply, as_quat). tests/physics/test_physics_frames.py compares them with scipy.


def quat_multiply(a: Quat, b: Quat) -> Quat:
    """Hamilton product ``a * b`` of (x, y, z, w) quaternions, in double precision."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


def rotate(quat_xyzw: Quat, v: Vec3) -> Vec3:
    """``v`` rotated by a unit quaternion (v + 2w(u×v) + 2u×(u×v))."""
    x, y, z, w = quat_xyzw
    tx = 2.0 * (y * v[2] - z * v[1])
    ty = 2.0 * (z * v[0] - x * v[2])
    tz = 2.0 * (x * v[1] - y * v[0])
    return (
        v[0] + w * tx + (y * tz - z * ty),
        v[1] + w * ty + (z * tx - x * tz),
        v[2] + w * tz + (x * ty - y * tx),
    )


def turned_about(frame: Frame, quat_xyzw: Quat, centre_local_m: Vec3) -> Frame:
    """``frame`` turned to ``quat_xyzw`` about its centre (``centre_local_m`` in its own frame): the centre
    stays where it is in the world, the origin moves (by metres, for a Revit origin far from its part)."""
    before, after = rotate(frame[1], centre_local_m), rotate(quat_xyzw, centre_local_m)
    x, y, z = frame[0]
    return (x + before[0] - after[0], y + before[1] - after[1], z + before[2] - after[2]), quat_xyzw


def compose(a: Frame, b: Frame) -> Frame:
    """``a ∘ b``: frame ``b`` given in frame ``a``, expressed in ``a``'s parent (double precision: pybullet's
    own ``multiplyTransforms`` works in single precision)."""
    moved = rotate(a[1], b[0])
    return (a[0][0] + moved[0], a[0][1] + moved[1], a[0][2] + moved[2]), quat_multiply(a[1], b[1])


def invert(a: Frame) -> Frame:
    x, y, z, w = a[1]
    conjugate = (-x, -y, -z, w)
    back = rotate(conjugate, a[0])
    return (-back[0], -back[1], -back[2]), conjugate


def yaw_of(quat_xyzw: Quat) -> float:
    """Heading (rotation about world z of the frame's x axis), radians in (-π, π]."""
    x, y, z, w = quat_xyzw
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def yaw_quat(yaw_rad: float) -> Quat:
    return (0.0, 0.0, math.sin(yaw_rad / 2.0), math.cos(yaw_rad / 2.0))


def normalised_quat(quat_xyzw: Quat) -> Quat:
    q = np.asarray(quat_xyzw, dtype=float)
    q = q / np.linalg.norm(q)
    return float(q[0]), float(q[1]), float(q[2]), float(q[3])


def interpolate(start: Frame, end: Frame, fraction: float) -> Frame:
    """Linear in position, spherical-linear in orientation; exactly ``end`` at ``fraction >= 1``. Plain
    floats: it runs for every moving load after every physics step."""
    if fraction >= 1.0:
        return end
    s = max(0.0, fraction)
    (x0, y0, z0), (x1, y1, z1) = start[0], end[0]
    position = (x0 + (x1 - x0) * s, y0 + (y1 - y0) * s, z0 + (z1 - z0) * s)
    q0, q1 = start[1], end[1]
    dot = q0[0] * q1[0] + q0[1] * q1[1] + q0[2] * q1[2] + q0[3] * q1[3]
    if dot < 0.0:  # the short way round
        q1, dot = (-q1[0], -q1[1], -q1[2], -q1[3]), -dot
    if dot > 0.9995:
        a, b = 1.0 - s, s
    else:
        theta = math.acos(min(1.0, dot))
        sin_theta = math.sin(theta)
        a, b = math.sin((1.0 - s) * theta) / sin_theta, math.sin(s * theta) / sin_theta
    q = [a * u + b * v for u, v in zip(q0, q1, strict=True)]
    norm = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    return position, (q[0] / norm, q[1] / norm, q[2] / norm, q[3] / norm)


def footprint(component: Component, frame: Frame) -> Rect:
    """The xy rectangle covered by the component's local bounding box when its frame is at ``frame``."""
    low, high = component.bbox_local.min_m, component.bbox_local.max_m
    corners = np.array(
        [[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])]
    )
    turned = Rotation.from_quat(frame[1]).apply(corners) + np.asarray(frame[0])
    return Rect(
        (float(turned[:, 0].min()), float(turned[:, 1].min())),
        (float(turned[:, 0].max()), float(turned[:, 1].max())),
    )


def distance_to_rect(xy: tuple[float, float], rect: Rect) -> float:
    """Horizontal distance from a point to the nearest point of a rectangle (0 inside it)."""
    dx = max(rect.min_xy[0] - xy[0], 0.0, xy[0] - rect.max_xy[0])
    dy = max(rect.min_xy[1] - xy[1], 0.0, xy[1] - rect.max_xy[1])
    return math.hypot(dx, dy)


# --- the component's body, from the manifest ------------------------------------------------------------


@dataclass(frozen=True)
class ComponentModel:
    """What physics needs to make one component's body; the inertia tensor is about the CoM, component axes.

    Taken from the manifest, which owns these facts (the converter writes the same numbers into
    ``model.sdf`` for Gazebo and other SDF readers; physics does not read them back)."""

    guid: str
    mass_kg: float
    com_local_m: Vec3
    inertia_kg_m2: tuple[Vec3, Vec3, Vec3]
    collision_files: tuple[Path, ...]
    visual_file: Path | None


def component_model(component: Component, build_dir: Path) -> ComponentModel:
    """The body facts of ``component``: mass, CoM, full inertia tensor and mesh files under ``build_dir``."""
    i = component.inertia_kg_m2
    visual = build_dir / component.files.visual_obj if component.files.visual_obj else None
    return ComponentModel(
        guid=component.guid,
        mass_kg=component.mass_kg,
        com_local_m=component.com_local_m,
        inertia_kg_m2=((i.ixx, i.ixy, i.ixz), (i.ixy, i.iyy, i.iyz), (i.ixz, i.iyz, i.izz)),
        collision_files=tuple(build_dir / path for path in component.files.collision),
        visual_file=visual,
    )


def principal_axes(inertia_kg_m2: np.ndarray) -> tuple[Vec3, Quat]:
    """Eigenvalues (principal moments) and the right-handed rotation whose columns are the principal axes."""
    values, vectors = np.linalg.eigh(np.asarray(inertia_kg_m2, dtype=float))
    if np.linalg.det(vectors) < 0.0:
        vectors[:, 2] *= -1.0
    values = np.maximum(values, 1e-9)  # a degenerate (flat) part still needs a positive moment
    quat = Rotation.from_matrix(vectors).as_quat()
    return (
        (float(values[0]), float(values[1]), float(values[2])),
        (float(quat[0]), float(quat[1]), float(quat[2]), float(quat[3])),
    )


# --- bodies ----------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ComponentBody:
    """A component's pybullet body and the constants needed to move it in its own (BIM) frame."""

    guid: str
    body_id: int
    inertial_frame: Frame  # CoM frame (principal axes) in the component frame
    mass_kg: float
    inertia_diagonal_kg_m2: Vec3


def create_component_body(
    client_id: int, component: Component, model: ComponentModel, frame: Frame, *, visual: bool = False
) -> ComponentBody:
    """One multibody for ``component`` at ``frame`` (component frame in the world), static (at rest)."""
    missing = [str(path) for path in model.collision_files if not path.is_file()]
    if missing:
        raise InputError(f"{component.guid}: collision meshes missing: {', '.join(missing)}")
    files = [str(path) for path in model.collision_files]
    if len(files) > MAX_COLLISION_PARTS:  # pybullet would keep 16 of them, silently (a build from before)
        _log.warning(
            "%s has %d collision parts, more than the %d pybullet keeps: it collides as its bounding box "
            "(convert the model again to split it into %d parts)",
            component.guid,
            len(files),
            MAX_COLLISION_PARTS,
            MAX_COLLISION_PARTS,
        )
        files = []
    if files:  # each part's vertices read once: for pybullet's inset hulls and for the laser (ray_scene.py)
        parts = [obj_vertices(path) for path in model.collision_files]
        scales, positions = inset_parts(parts)  # the hulls' margin is the geometry's skin
        shape = p.createCollisionShapeArray(  # a non-ASCII path crashes it: mesh_paths gives ASCII ones
            shapeTypes=[p.GEOM_MESH] * len(files),
            fileNames=[pybullet_path(path) for path in model.collision_files],
            meshScales=scales,
            collisionFramePositions=positions,
            physicsClientId=client_id,
        )
    else:  # a component without (usable) collision parts still takes its bounding box's room
        low, high = np.array(component.bbox_local.min_m), np.array(component.bbox_local.max_m)
        parts = [np.array(list(product(*zip(low, high, strict=True))))]  # its corners: what the laser sees
        if not model.collision_files:
            _log.warning("%s has no collision parts: using its bounding box", component.guid)
        shape = p.createCollisionShape(
            p.GEOM_BOX,
            halfExtents=((high - low) / 2.0).tolist(),
            collisionFramePosition=((high + low) / 2.0).tolist(),
            physicsClientId=client_id,
        )
    if shape < 0:
        raise InputError(f"{component.guid}: pybullet could not load its collision meshes {files}")
    visual_shape = -1
    if visual and model.visual_file is not None and model.visual_file.is_file():
        visual_shape = p.createVisualShape(
            p.GEOM_MESH, fileName=str(model.visual_file), physicsClientId=client_id
        )
    diagonal, principal = principal_axes(np.array(model.inertia_kg_m2))
    body_id = p.createMultiBody(
        baseMass=model.mass_kg,
        baseCollisionShapeIndex=shape,
        baseVisualShapeIndex=visual_shape,
        basePosition=frame[0],
        baseOrientation=frame[1],
        baseInertialFramePosition=model.com_local_m,
        baseInertialFrameOrientation=principal,
        useMaximalCoordinates=True,  # a rigid body: at rest it costs the solver nothing (see module doc)
        physicsClientId=client_id,
    )
    body = ComponentBody(component.guid, body_id, (model.com_local_m, principal), model.mass_kg, diagonal)
    to_body = Rotation.from_quat(principal).as_matrix()  # vertices into the body's (centre-of-mass) frame
    register_hulls(client_id, body_id, [(part - np.asarray(model.com_local_m)) @ to_body for part in parts])
    make_static(client_id, body)
    return body


def make_static(client_id: int, body: ComponentBody) -> None:
    """Mass 0: held exactly where it is set; the real mass and inertia stay in ``body``. Asleep: see
    :func:`put_to_sleep`."""
    p.changeDynamics(body.body_id, -1, mass=0.0, physicsClientId=client_id)
    put_to_sleep(client_id, body.body_id)
    set_filter(client_id, body.body_id, STATIC_GROUP, STATIC_MASK)
    note_dynamic(client_id, body.body_id, dynamic=False)


def make_dynamic(client_id: int, body: ComponentBody) -> None:
    """The component's real mass and principal moments of inertia (the order matters: mass first), awake
    and never put to sleep by Bullet while it is dynamic (pybullet's default for a new body: a body that
    may sleep stops once slower than Bullet's thresholds for 2 s — a slowly tipping beam would freeze)."""
    p.changeDynamics(body.body_id, -1, mass=body.mass_kg, physicsClientId=client_id)
    p.changeDynamics(
        body.body_id, -1, localInertiaDiagonal=body.inertia_diagonal_kg_m2, physicsClientId=client_id
    )
    p.changeDynamics(body.body_id, -1, activationState=p.ACTIVATION_STATE_WAKE_UP, physicsClientId=client_id)
    p.changeDynamics(
        body.body_id, -1, activationState=p.ACTIVATION_STATE_DISABLE_SLEEPING, physicsClientId=client_id
    )
    set_filter(client_id, body.body_id, DYNAMIC_GROUP, ALL_GROUPS)
    note_dynamic(client_id, body.body_id, dynamic=True)  # posed for the laser every period


def put_to_sleep(client_id: int, body_id: int) -> None:
    """Mark a static (mass 0) body asleep in Bullet, so that a step spends nothing on it.

    pybullet creates every body awake with sleeping disabled, and each step it visits every awake body
    (its bounding box, a transform-changed notification): 782 resting components made a step 0.16 ms
    instead of 0.08 ms with 28 (`bench/physics.py --build`). Asleep, a static body still collides: Bullet
    tests a pair when either body is awake, and every dynamic body (a robot driving, a released component)
    is; a static body moved by hand (a carried load) collides as before. Only for static bodies: a dynamic
    body put to sleep would stop moving.
    """
    p.changeDynamics(body_id, -1, activationState=p.ACTIVATION_STATE_SLEEP, physicsClientId=client_id)


def set_filter(client_id: int, body_id: int, group: int, mask: int, links: range | None = None) -> None:
    for link in links if links is not None else (-1,):
        p.setCollisionFilterGroupMask(body_id, link, group, mask, physicsClientId=client_id)
        note_group(client_id, body_id, link, group)  # the laser's caster filters as Bullet does


def set_component_pose(client_id: int, body: ComponentBody, frame: Frame) -> None:
    """Put the component frame at ``frame`` (pybullet's base frame is the CoM frame)."""
    com = compose(frame, body.inertial_frame)
    p.resetBasePositionAndOrientation(body.body_id, com[0], com[1], physicsClientId=client_id)
    note_moved(client_id, body.body_id)


def component_pose(client_id: int, body: ComponentBody) -> Frame:
    """The component frame in the world, from pybullet's CoM frame."""
    position, quat = p.getBasePositionAndOrientation(body.body_id, physicsClientId=client_id)
    return compose((tuple(position), tuple(quat)), invert(body.inertial_frame))


# --- ground and fence ------------------------------------------------------------------------------------


def create_ground(client_id: int, friction: float = 1.0) -> int:
    """An infinite static plane at z = 0 (its own filter group: the laser never reports it)."""
    shape = p.createCollisionShape(p.GEOM_PLANE, physicsClientId=client_id)
    body_id = p.createMultiBody(0.0, shape, physicsClientId=client_id)
    p.changeDynamics(body_id, -1, lateralFriction=friction, physicsClientId=client_id)
    put_to_sleep(client_id, body_id)
    # not with the pits' rims either: the plane and 180 static boxes made pairs that nearly doubled a step
    set_filter(client_id, body_id, GROUND_GROUP, ALL_GROUPS ^ GROUND_GROUP ^ STATIC_GROUP ^ PIT_EDGE_GROUP)
    return body_id


def create_fence(client_id: int, fence: Rect) -> list[int]:
    """Four static boxes just outside ``fence`` (its inner edge), FENCE_THICKNESS_M thick."""
    t, h = FENCE_THICKNESS_M, FENCE_HEIGHT_M
    (x0, y0), (x1, y1) = fence.min_xy, fence.max_xy
    sides = (  # centre xy, half extents xy
        (((x0 + x1) / 2.0, y0 - t / 2.0), ((x1 - x0) / 2.0 + t, t / 2.0)),
        (((x0 + x1) / 2.0, y1 + t / 2.0), ((x1 - x0) / 2.0 + t, t / 2.0)),
        ((x0 - t / 2.0, (y0 + y1) / 2.0), (t / 2.0, (y1 - y0) / 2.0)),
        ((x1 + t / 2.0, (y0 + y1) / 2.0), (t / 2.0, (y1 - y0) / 2.0)),
    )
    bodies = []
    for (cx, cy), (hx, hy) in sides:
        shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=[hx, hy, h / 2.0], physicsClientId=client_id)
        body_id = p.createMultiBody(0.0, shape, basePosition=[cx, cy, h / 2.0], physicsClientId=client_id)
        set_filter(client_id, body_id, STATIC_GROUP, STATIC_MASK)
        put_to_sleep(client_id, body_id)
        bodies.append(body_id)
    return bodies
