"""SDFormat 1.9 documents: one component model (``model.sdf``), its ``model.config``, and the site world.

Built with lxml. Every document must pass the reference parser (``ign sdf -k``); the tests check that.

* ``model.sdf``: model and link named by the component's GlobalId (as in the paper), the BIM pose as
  ``<pose>`` (world frame, metres, roll-pitch-yaw), ``<static>false`` so it can be carried, a full
  ``<inertial>`` (CoM pose, mass, inertia tensor), one visual mesh (the DAE, else the first visual format
  written) and one ``<collision>`` per convex part.
  Mesh URIs are ``model://<folder>/meshes/…`` (Gazebo's model path; PyBullet resolves them too).
* the world: physics, gravity, magnetic field, atmosphere, scene, a sun, a ground plane, and every
  component inlined at its BIM pose, static: the world shows the building as designed. Its mesh URIs are
  relative to the world file (``../models/<folder>/meshes/…``) so that PyBullet's ``loadSDF``, which
  ignores ``<include>``, loads it whole.
* IFC semantics travel in a ``bimbot:`` namespaced element (SDF's custom-element mechanism).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from lxml import etree

from bimbot.shared.manifest import Pose

from .placement import sdf_pose_text

SDF_VERSION = "1.9"
BIMBOT_XMLNS = "https://github.com/bimbot/bimbot/sdf"
GRAVITY_MPS2 = 9.80665
PHYSICS_STEP_S = 0.001
GROUND_SIZE_MIN_M = 100.0
# RGBA by IFC class (first match by isinstance-style prefix); steel grey otherwise.
CLASS_COLOURS: tuple[tuple[str, tuple[float, float, float, float]], ...] = (
    ("IfcFooting", (0.62, 0.62, 0.60, 1.0)),
    ("IfcSlab", (0.70, 0.70, 0.68, 1.0)),
    ("IfcWall", (0.85, 0.82, 0.75, 1.0)),
    ("IfcColumn", (0.25, 0.42, 0.65, 1.0)),
    ("IfcBeam", (0.80, 0.45, 0.15, 1.0)),
    ("IfcMember", (0.55, 0.35, 0.60, 1.0)),
    ("IfcPlate", (0.45, 0.60, 0.45, 1.0)),
    ("IfcWindow", (0.55, 0.75, 0.90, 0.6)),
)
DEFAULT_COLOUR = (0.55, 0.57, 0.60, 1.0)


@dataclass(frozen=True)
class ModelSpec:
    """What an SDF component model needs; mesh paths are relative to the model folder (``meshes/…``)."""

    guid: str
    folder: str
    ifc_class: str
    ifc_name: str | None
    pose_world: Pose
    mass_kg: float
    com_local_m: Sequence[float]
    inertia_kg_m2: np.ndarray  # (3, 3)
    visual_mesh: str  # the visual mesh file (meshes/visual.dae, else .obj, else .glb); empty: no <visual>
    collision_meshes: Sequence[str]


def colour_for_class(ifc_class: str) -> tuple[float, float, float, float]:
    for prefix, colour in CLASS_COLOURS:
        if ifc_class.startswith(prefix):
            return colour
    return DEFAULT_COLOUR


def model_sdf(spec: ModelSpec) -> bytes:
    root = _sdf_root()
    root.append(_model_element(spec, f"model://{spec.folder}/", static=False))
    return _serialise(root)


def world_sdf(
    world_name: str, specs: Iterable[ModelSpec], *, extent_m: float, models_dir: str = "../models"
) -> bytes:
    """The site world: environment, ground plane sized to ``extent_m``, every model inlined and static."""
    root = _sdf_root()
    world = etree.SubElement(root, "world", name=world_name)
    physics = etree.SubElement(world, "physics", name="default_physics", default="true", type="ode")
    _text(physics, "max_step_size", repr(PHYSICS_STEP_S))
    _text(physics, "real_time_factor", "1")
    _text(physics, "real_time_update_rate", repr(1.0 / PHYSICS_STEP_S))
    _text(world, "gravity", f"0 0 {-GRAVITY_MPS2!r}")
    _text(world, "magnetic_field", "5.5645e-06 2.28758e-05 -4.23884e-05")
    etree.SubElement(world, "atmosphere", type="adiabatic")
    scene = etree.SubElement(world, "scene")
    _text(scene, "ambient", "0.4 0.4 0.4 1")
    _text(scene, "background", "0.7 0.75 0.8 1")
    _text(scene, "shadows", "true")
    world.append(_sun())
    world.append(_ground_plane(max(GROUND_SIZE_MIN_M, extent_m)))
    for spec in specs:
        world.append(_model_element(spec, f"{models_dir}/{spec.folder}/", static=True))
    return _serialise(root)


def model_config(spec: ModelSpec, *, sdf_file: str = "model.sdf", version: str = "1.0") -> bytes:
    root = etree.Element("model")
    _text(root, "name", spec.guid)
    _text(root, "version", version)
    etree.SubElement(root, "sdf", version=SDF_VERSION).text = sdf_file
    author = etree.SubElement(root, "author")
    _text(author, "name", "bimbot converter")
    _text(author, "email", "bimbot@localhost")
    _text(root, "description", _description(spec))
    return etree.tostring(root, pretty_print=True, xml_declaration=True, encoding="UTF-8")


def _description(spec: ModelSpec) -> str:
    name = spec.ifc_name or "(unnamed)"
    return f"{spec.ifc_class} {name} (IFC GlobalId {spec.guid}), converted from IFC by bimbot"


def _sdf_root() -> etree._Element:
    return etree.Element("sdf", version=SDF_VERSION, nsmap={"bimbot": BIMBOT_XMLNS})


def _serialise(root: etree._Element) -> bytes:
    return etree.tostring(root, pretty_print=True, xml_declaration=True, encoding="UTF-8")


def _text(parent: etree._Element, tag: str, text: str) -> etree._Element:
    element = etree.SubElement(parent, tag)
    element.text = text
    return element


def _model_element(spec: ModelSpec, uri_prefix: str, *, static: bool) -> etree._Element:
    model = etree.Element("model", name=spec.guid)
    _text(model, "static", "true" if static else "false")
    _text(model, "pose", sdf_pose_text(spec.pose_world))
    semantics = etree.SubElement(model, f"{{{BIMBOT_XMLNS}}}ifc")
    semantics.set("guid", spec.guid)
    semantics.set("ifc_class", spec.ifc_class)
    if spec.ifc_name:  # sdformat rejects an empty value for any attribute called "name"
        semantics.set("ifc_name", spec.ifc_name)
    link = etree.SubElement(model, "link", name=spec.guid)
    link.append(_inertial(spec))
    if spec.visual_mesh:  # empty when no visual format was asked for: the link has no visual
        visual = etree.SubElement(link, "visual", name="visual")
        _mesh_geometry(visual, uri_prefix + spec.visual_mesh)
        material = etree.SubElement(visual, "material")
        colour = " ".join(repr(c) for c in colour_for_class(spec.ifc_class))
        _text(material, "ambient", colour)
        _text(material, "diffuse", colour)
    for index, mesh in enumerate(spec.collision_meshes):
        collision = etree.SubElement(link, "collision", name=f"collision_{index}")
        _mesh_geometry(collision, uri_prefix + mesh)
    return model


def _inertial(spec: ModelSpec) -> etree._Element:
    inertial = etree.Element("inertial")
    com = " ".join(repr(float(v)) for v in spec.com_local_m)
    _text(inertial, "pose", f"{com} 0 0 0")
    _text(inertial, "mass", repr(float(spec.mass_kg)))
    inertia = etree.SubElement(inertial, "inertia")
    tensor = np.asarray(spec.inertia_kg_m2, dtype=float)
    for tag, (row, col) in (
        ("ixx", (0, 0)),
        ("ixy", (0, 1)),
        ("ixz", (0, 2)),
        ("iyy", (1, 1)),
        ("iyz", (1, 2)),
        ("izz", (2, 2)),
    ):
        _text(inertia, tag, repr(float(tensor[row, col])))
    return inertial


def _mesh_geometry(parent: etree._Element, uri: str) -> None:
    geometry = etree.SubElement(parent, "geometry")
    mesh = etree.SubElement(geometry, "mesh")
    _text(mesh, "uri", uri)


def _sun() -> etree._Element:
    light = etree.Element("light", type="directional", name="sun")
    _text(light, "cast_shadows", "true")
    _text(light, "pose", "0 0 100 0 0 0")
    _text(light, "diffuse", "0.8 0.8 0.8 1")
    _text(light, "specular", "0.2 0.2 0.2 1")
    attenuation = etree.SubElement(light, "attenuation")
    for tag, value in (("range", "1000"), ("constant", "0.9"), ("linear", "0.01"), ("quadratic", "0.001")):
        _text(attenuation, tag, value)
    _text(light, "direction", "-0.5 0.1 -0.9")
    return light


def _ground_plane(size_m: float) -> etree._Element:
    model = etree.Element("model", name="ground_plane")
    _text(model, "static", "true")
    link = etree.SubElement(model, "link", name="link")
    for kind in ("collision", "visual"):
        element = etree.SubElement(link, kind, name=kind)
        geometry = etree.SubElement(element, "geometry")
        plane = etree.SubElement(geometry, "plane")
        _text(plane, "normal", "0 0 1")
        _text(plane, "size", f"{size_m!r} {size_m!r}")
        if kind == "collision":
            surface = etree.SubElement(element, "surface")
            friction = etree.SubElement(etree.SubElement(surface, "friction"), "ode")
            _text(friction, "mu", "1.0")
            _text(friction, "mu2", "1.0")
        else:
            material = etree.SubElement(element, "material")
            _text(material, "ambient", "0.35 0.4 0.3 1")
            _text(material, "diffuse", "0.35 0.4 0.3 1")
    return model
