"""A robot's URDF as data — links with their visual geometry, the joint tree — and its forward kinematics.

Why the observer reads URDFs itself: it draws every robot type as its own model (the Husky, the carrier, the
tower crane), and a crane's links must follow the joint values physics publishes
(``RobotPoseMsg.joint_positions``). Physics owns the joint values; the URDF owns the geometry and the
chain; this module only combines them. Pure: it reads the URDF file (lxml) and nothing else — meshes are
loaded by :mod:`.urdf_mesh`.

Frames: every pose is a 4×4 homogeneous matrix (metres) of a link frame in the robot's root-link frame
(the link no joint has as its child). A joint's child frame is ``parent · origin · motion(q)``: for a
revolute or continuous joint ``motion`` rotates by ``q`` rad about the joint's unit ``axis``; for a
prismatic one it translates by ``q`` m along it; fixed (and floating/planar, which carry no value here) do
not move. A joint without a value is at 0. Values outside a joint's limits are drawn as given: the
observer shows what physics says, it does not correct it.
"""

from __future__ import annotations

import logging
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from lxml import etree
from scipy.spatial.transform import Rotation

from bimbot.shared.crane_mast import raised_mast_urdf
from bimbot.shared.errors import InputError

_log = logging.getLogger(__name__)

MOVING_JOINTS = frozenset({"revolute", "continuous", "prismatic"})
ROTATING_JOINTS = frozenset({"revolute", "continuous"})
DEFAULT_RGBA = (0.6, 0.6, 0.6, 1.0)
# a number in an attribute; xacro left-overs like "$(optenv HUSKY_IMU_RPY 0 -1.5708 3.1416)" (pybullet_data's
# Husky) keep their default values at the end
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


@dataclass(frozen=True)
class Geometry:
    """One visual or collision shape in its link's frame.

    ``kind`` is ``box`` (``size_m``: x, y, z), ``cylinder`` (``size_m``: radius, length, along z),
    ``sphere`` (``size_m``: radius) or ``mesh`` (``mesh_file``, resolved against the URDF's folder, and
    ``scale``)."""

    kind: str
    origin: np.ndarray  # 4×4, link frame ← shape frame
    size_m: tuple[float, ...] = ()
    mesh_file: Path | None = None
    mesh_uri: str = ""  # as the URDF wrote it (messages)
    scale: tuple[float, float, float] = (1.0, 1.0, 1.0)
    rgba: tuple[float, float, float, float] = DEFAULT_RGBA


@dataclass(frozen=True)
class Link:
    name: str
    visuals: tuple[Geometry, ...] = ()
    collisions: tuple[Geometry, ...] = ()


@dataclass(frozen=True)
class Joint:
    name: str
    kind: str  # revolute, continuous, prismatic, fixed, floating, planar
    parent: str
    child: str
    origin: np.ndarray  # 4×4, parent link frame ← joint frame at q = 0
    axis: np.ndarray  # unit vector in the joint frame

    def motion(self, value: float) -> np.ndarray:
        """The joint's own motion at ``value`` (rad or m) as a 4×4 matrix (identity when it cannot move)."""
        matrix = np.eye(4)
        if self.kind in ROTATING_JOINTS:
            matrix[:3, :3] = Rotation.from_rotvec(self.axis * value).as_matrix()
        elif self.kind == "prismatic":
            matrix[:3, 3] = self.axis * value
        return matrix


@dataclass(frozen=True)
class UrdfModel:
    """A robot: its links by name, its joints from the root outwards (a parent before its children)."""

    name: str
    path: Path
    root: str
    links: dict[str, Link]
    joints: tuple[Joint, ...]

    @property
    def moving_joints(self) -> tuple[Joint, ...]:
        return tuple(joint for joint in self.joints if joint.kind in MOVING_JOINTS)

    def link_poses(self, joint_positions: Mapping[str, float] | None = None) -> dict[str, np.ndarray]:
        """Every link's pose in the root-link frame for ``joint_positions`` (joint name → rad or m)."""
        values = joint_positions or {}
        poses = {self.root: np.eye(4)}
        for joint in self.joints:
            value = float(values.get(joint.name, 0.0))
            poses[joint.child] = poses[joint.parent] @ joint.origin @ joint.motion(value)
        return poses

    def moved_links(self, joint_names: set[str]) -> set[str]:
        """The links whose pose depends on any of ``joint_names`` (their children, all the way down)."""
        moved: set[str] = set()
        for joint in self.joints:  # parents come first: a link is moved when its joint or its parent is
            if joint.name in joint_names or joint.parent in moved:
                moved.add(joint.child)
        return moved


def pose_matrix(xyz: tuple[float, float, float], rpy: tuple[float, float, float]) -> np.ndarray:
    """A URDF ``<origin>``: translation ``xyz`` and fixed-axis roll, pitch, yaw (about x, then y, then z)."""
    matrix = np.eye(4)
    matrix[:3, :3] = Rotation.from_euler("xyz", rpy).as_matrix()
    matrix[:3, 3] = xyz
    return matrix


def read_urdf(path: Path, *, mast_raised_m: float = 0.0) -> UrdfModel:
    """Parse the URDF at ``path`` (a crane's mast ``mast_raised_m`` taller, as the site erected it:
    :mod:`bimbot.shared.crane_mast`); an :class:`InputError` saying what is wrong when it cannot be used."""
    parser = etree.XMLParser(remove_comments=True, resolve_entities=False, no_network=True)
    try:
        text = path.read_bytes()
        if mast_raised_m > 0.0:
            text = raised_mast_urdf(text, mast_raised_m, source=path)
        robot = etree.fromstring(text, parser, base_url=str(path))
    except (OSError, etree.XMLSyntaxError) as exc:
        raise InputError(f"robot URDF {path}: {exc}") from None
    if robot.tag != "robot":
        raise InputError(f"robot URDF {path}: the root element is <{robot.tag}>, not <robot>")
    materials: dict[str, tuple] = {}
    for material in robot.findall("material"):
        name, rgba = material.get("name"), _rgba(material)
        if name and rgba is not None:
            materials[name] = rgba
    links = {}
    for element in robot.findall("link"):
        name = element.get("name")
        if not name:
            raise InputError(f"robot URDF {path}: a <link> without a name")
        visuals = tuple(
            geometry
            for visual in element.findall("visual")
            if (geometry := _geometry(visual, path, materials)) is not None
        )
        collisions = tuple(
            geometry
            for collision in element.findall("collision")
            if (geometry := _geometry(collision, path, materials)) is not None
        )
        links[name] = Link(name, visuals, collisions)
    joints = [_joint(element, path) for element in robot.findall("joint")]
    for joint in joints:
        for end in (joint.parent, joint.child):
            if end not in links:
                raise InputError(f"robot URDF {path}: joint {joint.name!r} names an unknown link {end!r}")
    children = {joint.child for joint in joints}
    roots = [name for name in links if name not in children]
    if len(roots) != 1:
        raise InputError(f"robot URDF {path}: {len(roots)} root links {roots}; a robot has one")
    return UrdfModel(robot.get("name", path.stem), path, roots[0], links, _tree_order(roots[0], joints, path))


def _tree_order(root: str, joints: list[Joint], path: Path) -> tuple[Joint, ...]:
    """The joints, each after the joint that moves its parent (breadth first from the root)."""
    by_parent: dict[str, list[Joint]] = {}
    for joint in joints:
        by_parent.setdefault(joint.parent, []).append(joint)
    ordered: list[Joint] = []
    frontier = [root]
    while frontier:
        link = frontier.pop(0)
        for joint in by_parent.get(link, []):
            ordered.append(joint)
            frontier.append(joint.child)
    if len(ordered) != len(joints):
        raise InputError(f"robot URDF {path}: its joints do not form one tree from {root!r}")
    return tuple(ordered)


def _joint(element: etree._Element, path: Path) -> Joint:
    name = element.get("name", "")
    parent, child = element.find("parent"), element.find("child")
    if parent is None or child is None or not parent.get("link") or not child.get("link"):
        raise InputError(f"robot URDF {path}: joint {name!r} needs a <parent link> and a <child link>")
    kind = element.get("type", "fixed")
    axis_element = element.find("axis")
    axis = np.array(_triple(axis_element.get("xyz") if axis_element is not None else None, (1.0, 0.0, 0.0)))
    norm = float(np.linalg.norm(axis))
    if kind in MOVING_JOINTS and norm < 1e-9:
        raise InputError(f"robot URDF {path}: joint {name!r} has a zero axis")
    return Joint(
        name=name,
        kind=kind,
        parent=str(parent.get("link")),
        child=str(child.get("link")),
        origin=_origin(element),
        axis=axis / norm if norm > 0 else axis,
    )


def _origin(element: etree._Element) -> np.ndarray:
    origin = element.find("origin")
    if origin is None:
        return np.eye(4)
    zero = (0.0, 0.0, 0.0)
    return pose_matrix(_triple(origin.get("xyz"), zero), _triple(origin.get("rpy"), zero))


def _geometry(element: etree._Element, urdf: Path, materials: dict[str, tuple]) -> Geometry | None:
    """A ``<visual>`` or ``<collision>`` as a :class:`Geometry` (None when it has no known shape)."""
    shape = element.find("geometry")
    if shape is None or len(shape) == 0:
        return None
    first = shape[0]
    origin = _origin(element)
    rgba = _material_rgba(element.find("material"), materials)
    if first.tag == "box":
        return Geometry("box", origin, _triple(first.get("size"), (0.1, 0.1, 0.1)), rgba=rgba)
    if first.tag == "cylinder":
        size = (_number(first.get("radius"), 0.05), _number(first.get("length"), 0.1))
        return Geometry("cylinder", origin, size, rgba=rgba)
    if first.tag == "sphere":
        return Geometry("sphere", origin, (_number(first.get("radius"), 0.05),), rgba=rgba)
    if first.tag == "mesh" and first.get("filename"):
        uri = str(first.get("filename"))
        scale = _triple(first.get("scale"), (1.0, 1.0, 1.0))
        return Geometry("mesh", origin, mesh_file=mesh_path(uri, urdf), mesh_uri=uri, scale=scale, rgba=rgba)
    _log.debug("%s: <%s> geometry is not drawn", urdf, first.tag)
    return None


def mesh_path(uri: str, urdf: Path) -> Path:
    """A mesh ``filename`` as a path: ``file://`` and absolute as given; relative to the URDF's folder;
    ``package://<pkg>/rest`` as ``rest`` in the URDF's folder or the first folder above it that holds it."""
    if uri.startswith("file://"):
        return Path(uri.removeprefix("file://"))
    if uri.startswith("package://"):
        rest = uri.removeprefix("package://").partition("/")[2]
        for folder in (urdf.parent, *urdf.parent.parents):
            if (folder / rest).is_file():
                return folder / rest
        return urdf.parent / rest
    path = Path(uri)
    return path if path.is_absolute() else urdf.parent / path


def _material_rgba(material: etree._Element | None, materials: dict[str, tuple]) -> tuple:
    if material is None:
        return DEFAULT_RGBA
    inline = _rgba(material)
    if inline is not None:
        return inline
    return materials.get(material.get("name") or "", DEFAULT_RGBA)


def _rgba(material: etree._Element) -> tuple[float, float, float, float] | None:
    color = material.find("color")
    if color is None or not color.get("rgba"):
        return None
    values = [float(v) for v in _NUMBER.findall(str(color.get("rgba")))]
    if len(values) != 4:
        return None
    r, g, b, a = (min(max(v, 0.0), 1.0) for v in values)
    return (r, g, b, a)


def _triple(text: str | None, default: tuple[float, float, float]) -> tuple[float, float, float]:
    """Three numbers of an attribute (the last three when a xacro left-over wraps them); else ``default``."""
    if not text:
        return default
    values = [float(v) for v in _NUMBER.findall(text)]
    if len(values) < 3:
        return default
    x, y, z = values[-3:]
    return (x, y, z)


def _number(text: str | None, default: float) -> float:
    values = _NUMBER.findall(text or "")
    return float(values[-1]) if values else default
