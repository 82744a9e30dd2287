"""Each robot drawn as its own type's model: URDF link meshes, moved by the joint values physics publishes.

Why: a fleet has robot types that look and move differently (a Husky, a heavy carrier, a tower crane
whose jib slews, trolley runs and hook drops). Physics serves each robot's type with its site info
(``SiteInfoMsg.robot_type_of`` / ``robot_types``); the type's URDF (:func:`bimbot.shared.fleet.resolve_urdf`)
gives the geometry (:mod:`.urdf_mesh`) and the joint chain (:mod:`.urdf_model`); a crane's joint values
come with its ground-truth pose (``RobotPoseMsg.joint_positions``).

Cheap on purpose, like the rest of the twin (:mod:`.twin_log`):

* every link's mesh is logged **once** per robot, static, at ``world/robots/<id>/model/<link>`` (in the
  robot frame, which :mod:`.twin_log` moves with the robot's planar pose); each URDF is read and each mesh
  file loaded once per run, whatever the number of robots of its type;
* a link's pose in the robot frame is a ``Transform3D`` on its entity: all of them at sim time 0, then
  only the links below a joint whose value changed (by more than ``JOINT_MIN_CHANGE``), at most one set
  per ``pose_min_interval_s`` of sim time per robot; the skipped latest set is kept and given by
  :meth:`FleetLog.flush`, so the crane's last pose always reaches the recording;
* the robot's state colour (which the single box of a robot without a model shows) goes on a labelled
  point above the model, ``world/robots/<id>/marker`` ("r3 (tower_crane)"), logged when the state changes.

A robot whose type has no URDF the observer can read keeps the plain box of :mod:`.twin_log` (logged once
as a warning per URDF).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import rerun as rr
from scipy.spatial.transform import Rotation

from bimbot.shared.errors import InputError
from bimbot.shared.fleet import resolve_urdf
from bimbot.shared.messages import RobotPoseMsg, RobotState, SiteInfoMsg
from bimbot.shared.state_colors import ROBOT_COLORS

from .twin_items import LogItem, robot_path
from .urdf_mesh import LinkMesh, LinkMeshes
from .urdf_model import UrdfModel, read_urdf

_log = logging.getLogger(__name__)

JOINT_MIN_CHANGE = 1e-3  # rad or m: smaller joint changes are not logged
MARKER_ABOVE_M = 0.4  # the state marker floats this far above the model's top
MARKER_RADIUS_M = 0.12


@dataclass(frozen=True)
class RobotModel:
    """A robot type's drawing: its URDF, each link's mesh and how high the model reaches at rest."""

    urdf: UrdfModel
    meshes: dict[str, LinkMesh]
    top_z_m: float


def link_path(robot_id: str, link: str) -> str:
    return f"{robot_path(robot_id)}/model/{rr.escape_entity_path_part(link)}"


def marker_path(robot_id: str) -> str:
    return f"{robot_path(robot_id)}/marker"


def matrix_transform(matrix: np.ndarray) -> rr.Transform3D:
    """A 4×4 pose as a rerun transform (translation and unit quaternion)."""
    quat = Rotation.from_matrix(matrix[:3, :3]).as_quat()  # x, y, z, w
    return rr.Transform3D(translation=matrix[:3, 3].tolist(), quaternion=rr.Quaternion(xyzw=quat.tolist()))


def mesh_archetype(mesh: LinkMesh) -> rr.Mesh3D:
    return rr.Mesh3D(
        vertex_positions=mesh.vertices_m,
        triangle_indices=mesh.triangles,
        vertex_normals=mesh.vertex_normals,
        vertex_colors=mesh.vertex_colors,
    )


def build_model(urdf: UrdfModel, meshes: LinkMeshes) -> RobotModel | None:
    """``urdf``'s drawing (None when no link has anything to draw)."""
    link_meshes = meshes.model_meshes(urdf)
    if not link_meshes:
        return None
    poses = urdf.link_poses()
    top = max(
        float((mesh.vertices_m @ poses[name][:3, :3].T + poses[name][:3, 3])[:, 2].max())
        for name, mesh in link_meshes.items()
    )
    return RobotModel(urdf, link_meshes, top)


@dataclass
class _Joints:
    """Per robot: the joint values last logged, when, and the set held back by throttling."""

    values: dict[str, float] = field(default_factory=dict)
    logged_s: float = -math.inf
    pending: tuple[float, dict[str, float]] | None = None


class FleetLog:
    """Robot models from the site info; link transforms from joint values; state markers."""

    def __init__(self, pose_min_interval_s: float = 0.1) -> None:
        self.pose_min_interval_s = pose_min_interval_s
        self._meshes = LinkMeshes()
        self._models_by_urdf: dict[tuple[str, float], RobotModel | None] = {}
        self._robots: dict[str, RobotModel] = {}
        self._labels: dict[str, str] = {}
        self._joints: dict[str, _Joints] = {}
        self._early: dict[str, dict[str, float]] = {}  # joint values heard before the robot was drawn

    def drawn(self, robot_id: str) -> bool:
        """True when ``robot_id`` is drawn as its type's model (it needs no box)."""
        return robot_id in self._robots

    def robot_model(self, robot_id: str) -> RobotModel | None:
        return self._robots.get(robot_id)

    def site_known(self, info: SiteInfoMsg) -> tuple[list[LogItem], list[LogItem]]:
        """``(static meshes, link transforms for sim time 0)`` of every robot on site with a model."""
        static: list[LogItem] = []
        initial: list[LogItem] = []
        for robot_id in info.robot_ids:
            type_name = info.robot_type_of.get(robot_id)
            description = info.robot_types.get(type_name) if type_name else None
            if description is None or robot_id in self._robots:
                continue
            raised_m = description.crane.mast_raised_m if description.crane is not None else 0.0
            model = self._model(description.urdf, raised_m)
            if model is None:
                continue
            self._robots[robot_id] = model
            self._labels[robot_id] = f"{robot_id} ({type_name})"
            self._joints[robot_id] = _Joints()
            for link, mesh in model.meshes.items():
                static.append(LogItem(link_path(robot_id, link), mesh_archetype(mesh), static=True))
            initial += self._link_items(robot_id, model.urdf.link_poses(), model.meshes)
        return static, initial

    def robot_pose(self, msg: RobotPoseMsg) -> list[LogItem]:
        """Transforms of the links that moved since the last logged set (throttled, see the module)."""
        model = self._robots.get(msg.robot_id)
        values = {name: float(value) for name, value in msg.joint_positions.items()}
        if model is None or not values:
            if values:
                self._early[msg.robot_id] = {**self._early.get(msg.robot_id, {}), **values}
            return []
        joints = self._joints[msg.robot_id]
        changed = _changed(values, joints.values)
        if not changed:
            joints.pending = None
            return []
        if msg.sim_time_s - joints.logged_s < self.pose_min_interval_s:
            joints.pending = (msg.sim_time_s, values)
            return []
        return self._log_joints(msg.robot_id, msg.sim_time_s, values)

    def catch_up(self, sim_time_s: float) -> list[LogItem]:
        """Link transforms for the joint values heard before their robot was drawn (log them now)."""
        items: list[LogItem] = []
        for robot_id in [r for r in self._early if r in self._robots]:
            items += self._log_joints(robot_id, sim_time_s, self._early.pop(robot_id))
        return items

    def robot_state(self, robot_id: str, state: RobotState, activity: str = "") -> list[LogItem]:
        """The state marker of a drawn robot, labelled with what it is doing (none for a robot without a
        model)."""
        model = self._robots.get(robot_id)
        if model is None:
            return []
        label = self._labels[robot_id] + (f": {activity}" if activity else "")
        return [
            LogItem(
                marker_path(robot_id),
                rr.Points3D(
                    [(0.0, 0.0, model.top_z_m + MARKER_ABOVE_M)],
                    colors=[ROBOT_COLORS[state]],
                    radii=MARKER_RADIUS_M,
                    labels=[label],
                ),
            )
        ]

    def flush(self) -> list[tuple[float, LogItem]]:
        """Joint sets held back by throttling, with their sim times (call at the end of a run)."""
        out: list[tuple[float, LogItem]] = []
        for robot_id, joints in self._joints.items():
            if joints.pending is not None:
                sim_time_s, values = joints.pending
                out += [(sim_time_s, item) for item in self._log_joints(robot_id, sim_time_s, values)]
        return out

    # --- helpers ---

    def _log_joints(self, robot_id: str, sim_time_s: float, values: Mapping[str, float]) -> list[LogItem]:
        model, joints = self._robots[robot_id], self._joints[robot_id]
        changed = _changed(values, joints.values)
        joints.values = {**joints.values, **values}
        joints.logged_s, joints.pending = sim_time_s, None
        moved = model.urdf.moved_links(changed)
        poses = model.urdf.link_poses(joints.values)
        return self._link_items(robot_id, {link: poses[link] for link in moved}, model.meshes)

    def _link_items(
        self, robot_id: str, poses: Mapping[str, np.ndarray], meshes: Mapping[str, LinkMesh]
    ) -> list[LogItem]:
        # temporal, not static: a static transform would hide every later one
        return [
            LogItem(link_path(robot_id, link), matrix_transform(pose))
            for link, pose in poses.items()
            if link in meshes
        ]

    def _model(self, urdf: str, mast_raised_m: float = 0.0) -> RobotModel | None:
        """The drawing of the URDF named ``urdf``, a crane's mast ``mast_raised_m`` taller (read once; None,
        warned once, when it cannot be)."""
        key = (urdf, mast_raised_m)
        if key not in self._models_by_urdf:
            model = None
            try:
                model = build_model(read_urdf(resolve_urdf(urdf), mast_raised_m=mast_raised_m), self._meshes)
            except InputError as exc:
                _log.warning("robots of URDF %r are drawn as boxes: %s", urdf, exc)
            self._models_by_urdf[key] = model
        return self._models_by_urdf[key]


def _changed(values: Mapping[str, float], last: Mapping[str, float]) -> set[str]:
    """The joints of ``values`` that moved by ``JOINT_MIN_CHANGE`` or more from ``last`` (0 if unseen)."""
    return {name for name, value in values.items() if abs(value - last.get(name, 0.0)) >= JOINT_MIN_CHANGE}
