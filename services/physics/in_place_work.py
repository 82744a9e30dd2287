"""Components built where they stand: poured whole (cast in place) or laid course by course (masonry).

A cast-in-place or laid component never lies in the yard. Until its work starts it is *unbuilt*: its body
waits out of sight, far below its target, colliding with nothing and unseen by the lasers. A robot that can
pour (a pump and its crew) or lay (a block layer) asks physics to build it up to a fraction of its height
(:class:`~bimbot.shared.messages.BuildRequest`), from where it stands, within its boom's reach:

* below the full height (a course of blocks): the component's convex collision parts, posed at its BIM
  target, cut by the horizontal plane at that height (trimesh's plane slicing, capped) stand there as
  static bodies: what the robots' lasers see and what a robot drives round. Each course replaces the last.
* the full height (the pour, the last course): the component's own body stands at its BIM target, static
  (concrete cast in its formwork does not settle; mortar holds a course where it is laid), and the course
  bodies are removed. Its pose is then fixed, and its agent verifies it like any placement.

Refusals say why with the numbers: another method (lifted components are carried), a robot that cannot
pour or lay, a boom that does not cover the component from where the machine stands.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from itertools import product
from pathlib import Path

import numpy as np

from bimbot.shared.footprint import posed_footprint
from bimbot.shared.messages import PhysicsReply
from bimbot.shared.work_methods import BUILT_IN_PLACE, WORK_CAPABILITY

from .client import p
from .collision_margin import obj_vertices
from .handling_state import HandlingState, Item, Phase, pose_msg, target_frame
from .ray_scene import register_hulls, unregister
from .robots import Robot
from .scene import (
    STATIC_GROUP,
    STATIC_MASK,
    Frame,
    compose,
    make_static,
    put_to_sleep,
    set_component_pose,
    set_filter,
)

_log = logging.getLogger(__name__)

UNBUILT_DEPTH_M = 500.0  # an unbuilt component's body waits this far below its target
HIDDEN_GROUP = 0  # no filter bit: nothing collides with it and no laser ray sees it


def unbuilt_frame(component_frame: Frame) -> Frame:
    """Where an unbuilt component's body waits: straight below its target, out of everyone's way."""
    (x, y, z), quat = component_frame
    return (x, y, z - UNBUILT_DEPTH_M), quat


def hide(client_id: int, item: Item) -> None:
    """Make ``item`` unbuilt: out of sight below its target, colliding with nothing, static."""
    item.phase = Phase.UNBUILT
    item.pose = unbuilt_frame(target_frame(item.component))
    set_component_pose(client_id, item.body, item.pose)
    make_static(client_id, item.body)
    set_filter(client_id, item.body.body_id, HIDDEN_GROUP, HIDDEN_GROUP)


def world_parts(component_frame: Frame, parts_local: list[np.ndarray]) -> list[np.ndarray]:
    """The collision parts' vertices (component frame) in the world, the component at ``component_frame``."""
    from scipy.spatial.transform import Rotation

    position, quat = component_frame
    rotation = Rotation.from_quat(quat).as_matrix()
    return [part @ rotation.T + np.asarray(position, float) for part in parts_local]


def parts_below(parts_world: list[np.ndarray], top_z_m: float) -> list[np.ndarray]:
    """Each convex part cut at the horizontal plane ``top_z_m``, the part below it (its hull's vertices,
    capped by trimesh's plane slicing); parts wholly above the plane are left out."""
    import trimesh

    below: list[np.ndarray] = []
    for vertices in parts_world:
        if float(vertices[:, 2].min()) >= top_z_m - 1e-6:
            continue
        if float(vertices[:, 2].max()) <= top_z_m + 1e-6:
            below.append(vertices)
            continue
        hull = trimesh.Trimesh(vertices=vertices).convex_hull
        cut = hull.slice_plane(plane_origin=[0.0, 0.0, top_z_m], plane_normal=[0.0, 0.0, -1.0], cap=True)
        if cut is not None and len(cut.vertices) >= 4 and cut.volume > 1e-9:
            below.append(np.asarray(cut.vertices, dtype=float))
    return below


@dataclass
class InPlaceWork:
    """The built-in-place components of one simulation: unbuilt, partly laid (course bodies), or built."""

    client_id: int
    state: HandlingState  # the handling's items and records (:mod:`.handling_state`)
    build_dir: Path
    ground_id: int = -1
    fraction: dict[str, float] = field(default_factory=dict)  # GUID → height built so far (0..1)
    courses: dict[str, list[int]] = field(default_factory=dict)  # GUID → the bodies of its courses
    _parts: dict[str, list[np.ndarray]] = field(default_factory=dict)  # GUID → parts, component frame

    def build(self, robot: Robot | None, guid: str, height_fraction: float, now_s: float) -> PhysicsReply:
        """Build ``guid`` up to ``height_fraction`` of its height (see the module docstring)."""
        item = self.state.items.get(guid)
        refusal = self._refusal(robot, guid, item)
        if refusal is not None or item is None:
            return PhysicsReply(ok=False, reason=refusal or f"unknown component {guid}", sim_time_s=now_s)
        done = self.fraction.get(guid, 0.0)
        if item.phase is not Phase.UNBUILT or height_fraction <= done + 1e-9:
            return PhysicsReply(ok=True, sim_time_s=now_s, pose=pose_msg(item.pose))  # built that far
        self.fraction[guid] = height_fraction
        if height_fraction >= 1.0 - 1e-9:
            self._stand(item)
        else:
            self._course(item, height_fraction)
        return PhysicsReply(ok=True, sim_time_s=now_s, pose=pose_msg(target_frame(item.component)))

    def stand_built(self, guid: str, frame: Frame | None = None) -> None:
        """``guid`` stands built at ``frame`` (its target by default): a restart of a built component."""
        item = self.state.items[guid]
        self.fraction[guid] = 1.0
        self._stand(item, frame)

    def _refusal(self, robot: Robot | None, guid: str, item: Item | None) -> str | None:
        if robot is None:
            return "unknown robot"
        if item is None:
            return f"unknown component {guid}"
        method = item.component.method
        if method not in BUILT_IN_PLACE:
            return f"{guid} is {method.value}: it is carried and placed, not built where it stands"
        needs = WORK_CAPABILITY[method]
        if not robot.description.can(needs):
            who = f"robot {robot.robot_id} ({robot.description.name})"
            return f"{who} cannot {needs.value}; {guid} is {method.value}"
        target = target_frame(item.component)
        polygon = posed_footprint(item.component, target[0], target[1]).polygon_xy_m
        base = robot.pose_xy_yaw(self.client_id)[:2]
        if not robot.description.reaches(base, polygon):
            far_m = float(np.max(np.hypot(*(np.asarray(polygon) - np.asarray(base)).T)))
            return (
                f"{guid} reaches {far_m:.1f} m from {robot.robot_id} ({robot.description.name}), "
                f"whose boom reaches {robot.description.reach_m:g} m"
            )
        return None

    def _local_parts(self, item: Item) -> list[np.ndarray]:
        guid = item.component.guid
        if guid not in self._parts:
            files = [self.build_dir / path for path in item.component.files.collision]
            if files and all(path.is_file() for path in files):
                self._parts[guid] = [obj_vertices(path) for path in files]
            else:  # no collision parts: its bounding box
                box = item.component.bbox_local
                self._parts[guid] = [np.array(list(product(*zip(box.min_m, box.max_m, strict=True))))]
        return self._parts[guid]

    def _course(self, item: Item, height_fraction: float) -> None:
        """Replace the standing courses of ``item`` by its parts below ``height_fraction`` of its height."""
        component = item.component
        bottom_z, top_z = component.bbox_world.min_m[2], component.bbox_world.max_m[2]
        cut_z = bottom_z + height_fraction * (top_z - bottom_z)
        parts = parts_below(world_parts(target_frame(component), self._local_parts(item)), cut_z)
        self._remove_courses(component.guid)
        bodies: list[int] = []
        cid = self.client_id
        for vertices in parts:
            centre = vertices.mean(axis=0)
            local = vertices - centre
            shape = p.createCollisionShape(p.GEOM_MESH, vertices=local.tolist(), physicsClientId=cid)
            body_id = p.createMultiBody(0.0, shape, basePosition=centre.tolist(), physicsClientId=cid)
            register_hulls(cid, body_id, [local])
            set_filter(cid, body_id, STATIC_GROUP, STATIC_MASK)
            put_to_sleep(cid, body_id)
            if self.ground_id >= 0:
                p.setCollisionFilterPair(self.ground_id, body_id, -1, -1, 0, physicsClientId=cid)
            bodies.append(body_id)
        self.courses[component.guid] = bodies
        _log.info(
            "%s laid to %.2f m (%.0f %% of its height): %d course part(s) stand",
            component.guid,
            cut_z,
            100.0 * height_fraction,
            len(bodies),
        )

    def _stand(self, item: Item, frame: Frame | None = None) -> None:
        """The component's own body at its target (or ``frame``), static and placed; courses removed."""
        cid = self.client_id
        self._remove_courses(item.component.guid)
        item.pose = frame or target_frame(item.component)
        set_component_pose(cid, item.body, item.pose)
        make_static(cid, item.body)
        if self.ground_id >= 0:
            p.setCollisionFilterPair(self.ground_id, item.body.body_id, -1, -1, 0, physicsClientId=cid)
        item.phase = Phase.PLACED
        item.supports = ()
        self.state.changed.add(item.component.guid)
        centre = compose(item.pose, (item.component.com_local_m, (0.0, 0.0, 0.0, 1.0)))[0]
        _log.info(
            "%s built in place (%s), standing at its target, its centre at (%.2f, %.2f, %.2f)",
            item.component.guid,
            item.component.method.value,
            *centre,
        )

    def _remove_courses(self, guid: str) -> None:
        for body_id in self.courses.pop(guid, []):
            unregister(self.client_id, body_id)
            p.removeBody(body_id, physicsClientId=self.client_id)
