"""The scene as the laser sees it: every collision primitive of every body as a convex shape the compiled
caster (:mod:`.ray_kernel`) can test, posed from pybullet once per control period.

Where the shapes come from:

* a body made of one primitive per link (the fence, a robot's URDF links, a component's bounding box):
  pybullet's ``getCollisionShapeData`` — boxes, cylinders (``URDF_USE_IMPLICIT_CYLINDER``), spheres and
  the ground plane;
* compound bodies, which pybullet cannot describe (a component's collision parts, the pit floors): the
  code that builds them registers them here (:func:`register_hulls`, :func:`register_boxes`). A
  component's parts are the convex hulls of its ``collision_<i>.obj`` files as converted — the geometry
  Bullet's inset hull plus its 1 mm margin stands for (:mod:`.collision_margin`).

Which bodies a beam can see follows Bullet's filtering, which pybullet does not let one read back: every
``setCollisionFilterGroupMask`` goes through :func:`.scene.set_filter`, which records the group here
(:func:`note_group`). Anything the caster cannot represent exactly (a capsule, a mesh link, a plane a beam
may see, a body created without a record) makes :meth:`RayScene.cast` return None, and the laser casts
with Bullet instead: the same ranges, only slower.

The registry is per pybullet client, like pybullet's own state; :func:`forget` drops a client's.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import ConvexHull, QhullError
from scipy.spatial.transform import Rotation

from .client import CLIENT_FORGETTERS, p
from .ray_kernel import KIND_CONVEX, KIND_CYLINDER, KIND_SPHERE, cast_fan, pose_shapes, warm_up

_log = logging.getLogger(__name__)

FLAT_HALF_THICKNESS_M = 0.001  # a flat hull is as thick as Bullet's margin makes it, on either side
DEFAULT_GROUP = 1  # Bullet's group of a body nobody filtered (DefaultFilter)
GEOM_SPHERE, GEOM_BOX, GEOM_CYLINDER, GEOM_PLANE = 2, 3, 4, 6  # pybullet's geometry type codes


@dataclass(frozen=True)
class Primitive:
    """One convex collision primitive in its link's (centre-of-mass) frame."""

    kind: int
    position: tuple[float, float, float]
    quaternion: tuple[float, float, float, float]  # x, y, z, w
    dims: tuple[float, float] = (0.0, 0.0)  # cylinder: radius, half length; sphere: radius
    planes: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))  # convex: n·x ≤ d
    bound_radius: float = 0.0  # of the bounding sphere about the primitive's frame origin


@dataclass
class _ClientRecord:
    compounds: dict[int, list[Primitive]] = field(default_factory=dict)  # body → its base's parts
    groups: dict[tuple[int, int], int] = field(default_factory=dict)  # (body, link) → filter group
    version: int = 0  # changes with every group that changes
    dynamic: set[int] = field(default_factory=set)  # bodies Bullet moves (posed every period)
    moved: set[int] = field(default_factory=set)  # bodies set somewhere since the last posing
    bodies_version: int = 0  # changes with every body registered or removed: the caster rebuilds


_RECORDS: dict[int, _ClientRecord] = {}


def _record(client_id: int) -> _ClientRecord:
    record = _RECORDS.get(client_id)  # asked for every carried load after every step: no record made
    if record is None:
        record = _RECORDS[client_id] = _ClientRecord()
    return record


def forget(client_id: int) -> None:
    """Drop what was recorded for a client (it was disconnected)."""
    _RECORDS.pop(client_id, None)


CLIENT_FORGETTERS.append(forget)


def unregister(client_id: int, body_id: int) -> None:
    """Forget a body about to be removed from the client (a course of a wall being laid)."""
    record = _record(client_id)
    record.compounds.pop(body_id, None)
    record.dynamic.discard(body_id)
    record.moved.discard(body_id)
    for slot in [slot for slot in record.groups if slot[0] == body_id]:
        del record.groups[slot]
    record.version += 1
    record.bodies_version += 1


def note_group(client_id: int, body_id: int, link: int, group: int) -> None:
    """Record a body link's collision filter group (called by :func:`.scene.set_filter`)."""
    record = _record(client_id)
    if record.groups.get((body_id, link)) != group:
        record.groups[(body_id, link)] = group
        record.version += 1


def note_dynamic(client_id: int, body_id: int, dynamic: bool) -> None:
    """A body became dynamic (Bullet moves it) or static again (called by :mod:`.scene`)."""
    record = _record(client_id)
    if dynamic:
        record.dynamic.add(body_id)
    else:
        record.dynamic.discard(body_id)
        record.moved.add(body_id)  # where it came to rest


def note_moved(client_id: int, body_id: int) -> None:
    """A body was set to a new pose (called by :func:`.scene.set_component_pose`)."""
    _record(client_id).moved.add(body_id)


def box_primitive(
    half_extents: Sequence[float],
    position: Sequence[float] = (0.0, 0.0, 0.0),
    quaternion: Sequence[float] = (0.0, 0.0, 0.0, 1.0),
) -> Primitive:
    hx, hy, hz = (float(value) for value in half_extents)
    planes = np.array(
        [[1, 0, 0, hx], [-1, 0, 0, hx], [0, 1, 0, hy], [0, -1, 0, hy], [0, 0, 1, hz], [0, 0, -1, hz]], float
    )
    return Primitive(
        KIND_CONVEX,
        _vec3(position),
        _quat(quaternion),
        planes=planes,
        bound_radius=float(np.sqrt(hx * hx + hy * hy + hz * hz)),
    )


def hull_primitive(vertices: np.ndarray) -> Primitive | None:
    """The convex hull of ``vertices`` (in the link frame) as planes; a flat set of points is given
    Bullet's margin as thickness. None when the points span no area."""
    points = np.asarray(vertices, dtype=float)
    centre = (points.min(axis=0) + points.max(axis=0)) / 2.0
    centred = points - centre
    equations: np.ndarray | None
    try:
        equations = ConvexHull(centred).equations
    except (QhullError, ValueError):
        equations = _flat_hull_planes(centred)
        if equations is None:
            return None
    planes = np.column_stack([equations[:, :3], -equations[:, 3]])
    planes = np.unique(np.round(planes, 12), axis=0)
    return Primitive(
        KIND_CONVEX,
        _vec3(centre),
        (0.0, 0.0, 0.0, 1.0),
        planes=planes,
        bound_radius=float(np.linalg.norm(centred, axis=1).max()) + FLAT_HALF_THICKNESS_M,
    )


def _flat_hull_planes(points: np.ndarray) -> np.ndarray | None:
    """Planes (qhull's ``n·x + d ≤ 0``) of a flat point set's outline, thickened by the margin on both
    sides of its plane; None when the points lie on a line."""
    mean = points.mean(axis=0)
    _, singular, axes = np.linalg.svd(points - mean, full_matrices=True)
    if len(singular) < 2 or singular[1] <= 1e-9 * max(1.0, singular[0]):
        return None
    try:
        outline = ConvexHull((points - mean) @ axes[:2].T).equations  # a·(u, v) + b ≤ 0 in the plane
    except (QhullError, ValueError):
        return None
    normals = outline[:, :2] @ axes[:2]
    sides = np.column_stack([normals, outline[:, 2] - normals @ mean])
    normal = axes[2]
    faces = np.array(
        [
            [*normal, -(normal @ mean) - FLAT_HALF_THICKNESS_M],
            [*(-normal), normal @ mean - FLAT_HALF_THICKNESS_M],
        ]
    )
    return np.vstack([sides, faces])


def register_hulls(client_id: int, body_id: int, parts: Sequence[np.ndarray]) -> None:
    """A compound body's convex parts, each as vertices in the body's (centre-of-mass) frame."""
    primitives = [hull_primitive(part) for part in parts]
    _record(client_id).bodies_version += 1
    if any(primitive is None for primitive in primitives):
        _log.info("body %d has a collision part without volume: the laser casts with Bullet", body_id)
        _record(client_id).compounds[body_id] = []  # known, but not representable
        return
    _record(client_id).compounds[body_id] = [primitive for primitive in primitives if primitive is not None]


def register_boxes(
    client_id: int, body_id: int, half_extents: Sequence[Sequence[float]], centres: Sequence[Sequence[float]]
) -> None:
    """A compound body of axis-aligned boxes (the pit floors) in the body's frame."""
    _record(client_id).compounds[body_id] = [
        box_primitive(half, centre) for half, centre in zip(half_extents, centres, strict=True)
    ]


def _vec3(values: Sequence[float]) -> tuple[float, float, float]:
    x, y, z = (float(value) for value in values)
    return x, y, z


def _quat(values: Sequence[float]) -> tuple[float, float, float, float]:
    x, y, z, w = (float(value) for value in values)
    return x, y, z, w


def _from_shape_data(row: tuple) -> Primitive | str:
    """A primitive from one ``getCollisionShapeData`` row, or why it cannot be one."""
    geometry, dims, position, quaternion = row[2], row[3], row[5], row[6]
    if geometry == GEOM_BOX:
        return box_primitive([value / 2.0 for value in dims], position, quaternion)
    if geometry == GEOM_CYLINDER:
        length, radius = float(dims[0]), float(dims[1])
        bound = float(np.hypot(radius, length / 2.0))
        dims_m = (radius, length / 2.0)
        return Primitive(KIND_CYLINDER, _vec3(position), _quat(quaternion), dims_m, bound_radius=bound)
    if geometry == GEOM_SPHERE:
        radius = float(dims[0])
        return Primitive(KIND_SPHERE, _vec3(position), _quat(quaternion), (radius, 0.0), bound_radius=radius)
    if geometry == GEOM_PLANE:
        return "plane"
    return f"geometry type {geometry}"


@dataclass
class _Slot:
    body_id: int
    link: int  # -1: the base


class RayScene:
    """The laser's view of one pybullet client: :meth:`refresh` once per period, then :meth:`cast`."""

    def __init__(self, client_id: int) -> None:
        warm_up()  # numba compiles the kernel, or loads it from its cache, before the first scan
        self.client_id = client_id
        self.unsupported: str | None = None  # why the caster cannot stand in for Bullet (then cast is None)
        self._bodies = -1  # bodies seen at the last build
        self._bodies_version = -1  # the record's bodies_version at the last build
        self._slots: list[_Slot] = []
        self._planes_of: set[tuple[int, int]] = set()  # (body, link) holding a plane (the ground)
        self._groups_at: tuple[int, int] = (-1, -1)  # (record version, bodies) the shape groups are from
        self._slots_of: dict[int, dict[int, int]] = {}  # body → link → slot index
        self._articulated: set[int] = set()  # bodies with links (robots): posed every period
        self._shape_groups = np.zeros(0, dtype=np.int64)

    # --- building -------------------------------------------------------------------------------------

    def _build(self) -> None:
        record = _record(self.client_id)
        primitives: list[tuple[int, Primitive]] = []  # slot index, primitive
        slots: list[_Slot] = []
        planes_of: set[tuple[int, int]] = set()
        unsupported: str | None = None
        count = p.getNumBodies(physicsClientId=self.client_id)
        for index in range(count):
            body = p.getBodyUniqueId(index, physicsClientId=self.client_id)
            if body in record.compounds:
                parts = record.compounds[body]
                if not parts:
                    unsupported = f"body {body} has a collision part without volume"
                slots.append(_Slot(body, -1))
                primitives.extend((len(slots) - 1, part) for part in parts)
                continue
            for link in range(-1, p.getNumJoints(body, physicsClientId=self.client_id)):
                try:
                    rows = p.getCollisionShapeData(body, link, physicsClientId=self.client_id)
                except p.error:
                    unsupported = f"body {body} link {link}: a compound shape nobody registered"
                    continue
                for row in rows:
                    made = _from_shape_data(row)
                    if made == "plane":
                        planes_of.add((body, link))
                        continue
                    if isinstance(made, str):
                        unsupported = f"body {body} link {link}: {made}"
                        continue
                    if not slots or (slots[-1].body_id, slots[-1].link) != (body, link):
                        slots.append(_Slot(body, link))
                    primitives.append((len(slots) - 1, made))
        self._bodies, self._slots, self._planes_of, self.unsupported = count, slots, planes_of, unsupported
        if unsupported:
            _log.info("the laser casts with Bullet: %s", unsupported)
        n = len(primitives)
        self._slot_of = np.array([slot for slot, _ in primitives], dtype=np.int64)
        self._kinds = np.array([prim.kind for _, prim in primitives], dtype=np.int64)
        quaternions = [prim.quaternion for _, prim in primitives]
        self._local_rot = Rotation.from_quat(quaternions).as_matrix() if n else np.zeros((0, 3, 3))
        self._local_pos = np.array([prim.position for _, prim in primitives], dtype=float).reshape(n, 3)
        self._dims = np.array([prim.dims for _, prim in primitives], dtype=float).reshape(n, 2)
        self._radii = np.array([prim.bound_radius for _, prim in primitives], dtype=float)
        counts = [len(prim.planes) for _, prim in primitives]
        self._plane_first = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        self._planes = np.vstack([np.zeros((0, 4)), *(prim.planes for _, prim in primitives)])
        self._rotations = np.zeros((n, 3, 3))
        self._positions = np.zeros((n, 3))
        self._slot_first_shape = np.searchsorted(self._slot_of, np.arange(len(slots) + 1)).astype(np.int64)
        self._slots_of = {}  # body → link → slot index
        for index, slot in enumerate(slots):
            self._slots_of.setdefault(slot.body_id, {})[slot.link] = index
        self._articulated = {body for body, links in self._slots_of.items() if max(links) >= 0}

    # --- posing ---------------------------------------------------------------------------------------

    def refresh(self) -> None:
        """Pose the shapes that may have moved since the last call (after stepping, before the period's
        scans): every articulated body's links (the robots), the bodies Bullet moves (released
        components) and the bodies set somewhere (carried, placed, restored); all of them after the
        scene changed. A resting component is static in Bullet (mass 0): it moves only when set."""
        record = _record(self.client_id)
        if (
            p.getNumBodies(physicsClientId=self.client_id) != self._bodies
            or record.bodies_version != self._bodies_version
        ):
            self._bodies_version = record.bodies_version
            self._build()
            bodies = set(self._slots_of)
        else:
            known = self._slots_of.keys()
            bodies = self._articulated | (record.dynamic & known) | (record.moved & known)
        record.moved.clear()
        if self.unsupported or not len(self._kinds) or not bodies:
            return
        cid = self.client_id
        slots: list[int] = []
        poses: list[tuple[float, ...]] = []  # x, y, z, qx, qy, qz, qw
        for body in bodies:
            links = self._slots_of[body]
            moving = [link for link in links if link >= 0]
            if moving:
                states = p.getLinkStates(body, moving, physicsClientId=cid)  # as of the last step or reset
                for link, state in zip(moving, states, strict=True):
                    slots.append(links[link])
                    poses.append((*state[0], *state[1]))
            if -1 in links:
                position, quaternion = p.getBasePositionAndOrientation(body, physicsClientId=cid)
                slots.append(links[-1])
                poses.append((*position, *quaternion))
        posed = np.asarray(poses, dtype=float)
        pose_shapes(
            np.asarray(slots, dtype=np.int64),
            np.ascontiguousarray(posed[:, :3]),
            np.ascontiguousarray(posed[:, 3:]),
            self._slot_first_shape,
            self._local_rot,
            self._local_pos,
            self._rotations,
            self._positions,
        )

    # --- casting --------------------------------------------------------------------------------------

    def visible(self, mask: int) -> np.ndarray | None:
        """Which shapes a ray with filter ``mask`` tests (Bullet: the shape's group shares a bit with the
        mask); None when a plane would be visible (not representable)."""
        record = _record(self.client_id)
        if any((record.groups.get(slot, DEFAULT_GROUP) & mask) != 0 for slot in self._planes_of):
            return None
        if self._groups_at != (record.version, self._bodies):
            slot_groups = np.array(
                [record.groups.get((slot.body_id, slot.link), DEFAULT_GROUP) for slot in self._slots],
                dtype=np.int64,
            )
            self._shape_groups = slot_groups[self._slot_of] if len(self._slot_of) else slot_groups[:0]
            self._groups_at = (record.version, self._bodies)
        return (self._shape_groups & mask) != 0

    def cast(
        self,
        origin: np.ndarray,
        axes: np.ndarray,
        *,
        angle_min: float,
        angle_increment: float,
        full_circle: bool,
        starts: np.ndarray,
        range_max: float,
        mask: int,
    ) -> np.ndarray | None:
        """Ranges of a fan of beams (see :func:`.ray_kernel.cast_fan`); None when Bullet must cast."""
        if self.unsupported or self._bodies != p.getNumBodies(physicsClientId=self.client_id):
            return None
        visible = self.visible(mask)
        if visible is None:
            return None
        return cast_fan(
            np.asarray(origin, dtype=float),
            np.asarray(axes, dtype=float),
            angle_min,
            angle_increment,
            full_circle,
            np.asarray(starts, dtype=float),
            range_max,
            self._kinds,
            self._rotations,
            self._positions,
            self._dims,
            self._plane_first,
            self._planes,
            self._radii,
            visible,
        )
