"""One component as a model for other simulators: URDF (one link), or the converter's SDF model folder.

The converter writes every component as an SDF model (``models/<folder>/``: model.sdf, model.config and
its meshes), which Gazebo and other SDFormat readers load as is: ``--sdf`` copies that folder out. URDF
readers (Isaac Sim's importer, MoveIt, pybullet) get one link with the manifest's mass, centre of mass and
inertia, the visual mesh and the convex collision parts, the meshes copied beside the URDF.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from lxml import etree

from bimbot.shared.errors import UserError
from bimbot.shared.manifest import Component, Manifest


def find_component(manifest: Manifest, guid: str | None) -> Component:
    """The component with GlobalId ``guid`` (:class:`UserError` naming it when absent)."""
    if not guid:
        raise UserError("--urdf and --sdf export one component: name it with --component GUID")
    try:
        return manifest.component(guid)
    except KeyError:
        raise UserError(f"--component {guid}: no component of the build has this GlobalId") from None


def write_urdf(component: Component, build_dir: Path, out: Path) -> Path:
    """``out`` (a .urdf) with its meshes in ``<out stem>_meshes/`` beside it."""
    out.parent.mkdir(parents=True, exist_ok=True)
    meshes = out.parent / f"{out.stem}_meshes"
    meshes.mkdir(exist_ok=True)
    robot = etree.Element("robot", name=f"component_{component.folder}")
    link = etree.SubElement(robot, "link", name="body")
    inertial = etree.SubElement(link, "inertial")
    etree.SubElement(inertial, "origin", xyz=_xyz(component.com_local_m), rpy="0 0 0")
    etree.SubElement(inertial, "mass", value=f"{component.mass_kg:.6g}")
    inertia = component.inertia_kg_m2
    moments = {name: f"{getattr(inertia, name):.6g}" for name in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
    etree.SubElement(inertial, "inertia", attrib=moments)
    visual = etree.SubElement(link, "visual")
    etree.SubElement(
        etree.SubElement(visual, "geometry"),
        "mesh",
        filename=_copy(build_dir, component.files.visual_obj, meshes),
    )
    for part in component.files.collision:
        collision = etree.SubElement(link, "collision")
        etree.SubElement(
            etree.SubElement(collision, "geometry"), "mesh", filename=_copy(build_dir, part, meshes)
        )
    out.write_bytes(etree.tostring(robot, pretty_print=True, xml_declaration=True, encoding="UTF-8"))
    return out


def copy_sdf_model(component: Component, build_dir: Path, out_dir: Path) -> Path:
    """The converter's SDF model folder of ``component`` copied to ``out_dir``; the model.sdf's path."""
    source = build_dir / component.files.model_dir
    if not source.is_dir():
        raise UserError(f"{source}: the component's model folder is missing from the build")
    shutil.copytree(source, out_dir, dirs_exist_ok=True)
    return out_dir / Path(component.files.sdf_file).relative_to(component.files.model_dir)


def _copy(build_dir: Path, relative: str, meshes: Path) -> str:
    source = build_dir / relative
    if not source.is_file():
        raise UserError(f"{source}: a mesh of the component is missing from the build")
    shutil.copy2(source, meshes / source.name)
    return f"{meshes.name}/{source.name}"


def _xyz(values: tuple[float, float, float]) -> str:
    return " ".join(f"{value:.6g}" for value in values)
