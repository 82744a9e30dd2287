"""Convert one element into its component model folder: the per-element half of the converter.

For each tessellated element: its rigid placement and pose (:mod:`.placement`), work that depends only on
its geometry and is shared by every element with the same tessellation (the welded mesh, mass properties,
collision parts, mesh files written once and hard-linked after), its mass from the IFC, its split IFC,
``model.sdf``, ``model.config`` and its manifest entry. Each mesh is built once and serves every use.
Pure apart from writing the model folder. An element split into panels is written by :mod:`.panel_writer`,
one model folder per panel, through :func:`write_entry`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import partial
from typing import TYPE_CHECKING

import ifcopenshell
import ifcopenshell.util.element
import numpy as np

from bimbot.shared.construction_methods import MethodDecision
from bimbot.shared.identifiers import guid_to_folder, guid_to_key, is_valid_guid
from bimbot.shared.manifest import (
    BoundingBox,
    Component,
    ComponentFiles,
    Inertia,
    InertiaSource,
    MassSource,
    SkippedElement,
)

from . import mass as mass_chain
from .collision import CollisionShape, collision_shape
from .component_methods import method_fields, settled_method
from .component_work import GeometryWork, PlacedElement, ShardContext
from .connections import element_connections
from .face_materials import material_volumes, volumes_by_style
from .face_slope import face_slope_deg
from .mass_properties import MassProperties, mass_properties, mesh_from_arrays
from .mesh import TriMesh
from .mesh_files import GeometryFiles, link_geometry_files, write_geometry_files
from .placement import pose_from_rigid, split_rigid, vec3
from .sdf_writer import ModelSpec, model_config, model_sdf
from .split_ifc import split_element
from .tessellation import ElementShape

if TYPE_CHECKING:
    pass


def skipped_entry(element: ifcopenshell.entity_instance, reason: str) -> SkippedElement:
    return SkippedElement(
        guid=str(element.GlobalId or f"#{element.id()}"),
        ifc_class=element.is_a(),
        name=element.Name,
        reason=reason,
    )


def place_element(element: ifcopenshell.entity_instance, shape: ElementShape) -> PlacedElement:
    rigid = split_rigid(shape.placement_world_m)
    vertices = shape.geometry.vertices_local_m
    key = shape.geometry.geometry_id
    if rigid.residual is not None:  # scaled or mirrored placement: bake the non-rigid part into the mesh
        vertices = vertices @ rigid.residual.T
        key = f"{key}:{element.id()}"
    world = vertices @ rigid.rotation.T + rigid.translation_m
    bbox = np.array([world.min(axis=0), world.max(axis=0)])
    return PlacedElement(element, shape, key, rigid.rotation, rigid.translation_m, vertices, bbox)


def geometry_work(item: PlacedElement, context: ShardContext) -> GeometryWork:
    geometry = item.shape.geometry
    mesh = mesh_from_arrays(item.vertices_local_m, geometry.faces)
    props = mass_properties(mesh)
    surface_m3 = props.volume_m3 if _surface_closes(props) else None
    return GeometryWork(
        mesh=mesh,
        props=props,
        find_collision=partial(
            collision_shape, item.element, mesh, context.unit_scale_m, sections=context.sections
        ),
        volumes_by_style=volumes_by_style(mesh, geometry.face_style_ids, surface_m3)
        if len(geometry.face_style_ids)
        else {},
    )


def _surface_closes(props: MassProperties) -> bool:
    """The mesh is not watertight by its edges, yet its surface closes (its exact integrals were taken)."""
    return not props.watertight and props.source == InertiaSource.MESH


def element_mass(item: PlacedElement, work: GeometryWork, context: ShardContext) -> mass_chain.MassResult:
    """The element's mass (:mod:`.mass`), its materials weighed by the volumes its faces style with each
    (:mod:`.face_materials`) where it has several without shares."""
    element = item.element
    parts = material_volumes(element, work.volumes_by_style, context.style_materials)
    return mass_chain.element_mass(
        element, work.props.volume_m3, unit_kg=context.mass_unit_kg, material_volumes=parts
    )


def write_component(
    model: ifcopenshell.file,
    item: PlacedElement,
    work: GeometryWork,
    context: ShardContext,
    *,
    mass: mass_chain.MassResult | None = None,
    warnings: tuple[str, ...] = (),
    decision: MethodDecision | None = None,
) -> tuple[Component, ModelSpec]:
    """Write the model folder of ``item`` (visual mesh formats of ``context``, see :mod:`.mesh_files`).
    ``mass``: the element's, when the caller has it already; ``warnings``: more for its manifest entry;
    ``decision``: its settled construction method, when the caller has it (:mod:`.component_methods`)."""
    element = item.element
    guid = str(element.GlobalId)
    folder = guid_to_folder(guid)
    model_dir = context.out_dir / "models" / folder
    (model_dir / "meshes").mkdir(parents=True, exist_ok=True)
    if work.files is None or work.files_dir is None:
        work.files = write_geometry_files(model_dir, work.mesh, work.collision.parts, context.formats)
        work.files_dir = model_dir
    else:
        link_geometry_files(work.files_dir, model_dir, work.files)
    props = work.props
    if mass is None:
        mass = element_mass(item, work, context)
    if decision is None:
        decision = settled_method(item, work, mass.mass_kg, context)
    notes = [*mass.warnings, *item.notes, *warnings]
    if not props.watertight and not _surface_closes(props):
        notes.append(
            "mesh is not watertight: inertia from its bounding box, volume from its closed pieces and the "
            "convex hulls of its open ones"
        )
    if work.collision.note:
        notes.append(work.collision.note)
    split_name = f"{guid if is_valid_guid(guid) else folder}.ifc" if context.split_ifc else ""
    if split_name:
        # to_string and one write: file.write() costs 0.9 ms a file here against 0.3 ms for the same bytes
        split = split_element(model, element, chains=context.chains)
        (model_dir / split_name).write_bytes(split.to_string().encode())
    return write_entry(
        element,
        EntryParts(
            guid=guid,
            name=element.Name,
            rotation=item.rotation,
            translation_m=item.translation_m,
            bbox_ifc_world_m=item.bbox_ifc_world_m,
            props=props,
            mass_kg=mass.mass_kg,
            mass_source=mass.source,
            collision=work.collision,
            files=work.files,
            split_ifc=split_name,
            face_slope_deg=face_slope_deg(work.mesh, item.rotation),
            warnings=notes,
            extra=method_fields(decision, item, work, context),
        ),
        context,
    )


@dataclass
class EntryParts:
    """What one component's ``model.sdf``, ``model.config`` and manifest entry are made of (an element's or
    a panel's); its mesh files are already in its model folder."""

    guid: str
    name: str | None
    rotation: np.ndarray  # component frame → world axes
    translation_m: np.ndarray  # component frame origin, IFC world frame, metres
    bbox_ifc_world_m: np.ndarray  # (2, 3), IFC world frame
    props: MassProperties
    mass_kg: float
    mass_source: MassSource
    collision: CollisionShape
    files: GeometryFiles
    split_ifc: str = ""  # file name in the model folder; empty: not written
    face_slope_deg: float = 0.0  # :func:`.face_slope.face_slope_deg`
    warnings: list[str] = field(default_factory=list)
    extra: dict[str, object] = field(default_factory=dict)  # more manifest fields (a panel's parent_guid…)


def write_entry(
    element: ifcopenshell.entity_instance, parts: EntryParts, context: ShardContext
) -> tuple[Component, ModelSpec]:
    """Write ``model.sdf`` and ``model.config`` of a component of ``element`` and make its manifest entry."""
    origin = context.origin
    guid = parts.guid
    folder = guid_to_folder(guid)
    props = parts.props
    inertia = props.inertia_kg_m2(parts.mass_kg)
    pose = pose_from_rigid(parts.rotation, parts.translation_m, origin)
    spec = ModelSpec(
        guid=guid,
        folder=folder,
        ifc_class=element.is_a(),
        ifc_name=parts.name,
        pose_world=pose,
        mass_kg=parts.mass_kg,
        com_local_m=tuple(props.com_local_m),
        inertia_kg_m2=inertia,
        visual_mesh=parts.files.visual_mesh,
        collision_meshes=parts.files.collision,
    )
    model_dir = context.out_dir / "models" / folder
    (model_dir / "model.sdf").write_bytes(model_sdf(spec))
    (model_dir / "model.config").write_bytes(model_config(spec))
    rel_dir = f"models/{folder}"
    component = Component(
        guid=guid,
        key=guid_to_key(guid),
        folder=folder,
        ifc_class=element.is_a(),
        predefined_type=_predefined_type(element),
        name=parts.name,
        storey=_storey_name(element),
        material=mass_chain.material_label(element),
        target_pose_world=pose,
        bbox_world=BoundingBox(
            min_m=vec3(parts.bbox_ifc_world_m[0] - origin),
            max_m=vec3(parts.bbox_ifc_world_m[1] - origin),
        ),
        bbox_local=BoundingBox(
            min_m=vec3(props.bbox_local_m[0]),
            max_m=vec3(props.bbox_local_m[1]),
        ),
        volume_m3=props.volume_m3,
        watertight=props.watertight,
        mass_kg=parts.mass_kg,
        mass_source=parts.mass_source,
        com_local_m=vec3(props.com_local_m),
        inertia_kg_m2=Inertia(
            ixx=inertia[0, 0],
            ixy=inertia[0, 1],
            ixz=inertia[0, 2],
            iyy=inertia[1, 1],
            iyz=inertia[1, 2],
            izz=inertia[2, 2],
        ),
        inertia_source=props.source,
        collision_method=parts.collision.method,
        collision_parts=len(parts.collision.parts),
        part_boxes_local=_part_boxes(parts.collision.parts),
        face_slope_deg=parts.face_slope_deg,
        files=ComponentFiles(
            model_dir=rel_dir,
            sdf_file=f"{rel_dir}/model.sdf",
            config_file=f"{rel_dir}/model.config",
            split_ifc=_in_folder(rel_dir, parts.split_ifc),
            visual_dae=_in_folder(rel_dir, parts.files.visual_dae),
            visual_obj=_in_folder(rel_dir, parts.files.visual_obj),
            visual_glb=_in_folder(rel_dir, parts.files.visual_glb),
            collision=[f"{rel_dir}/{name}" for name in parts.files.collision],
        ),
        connections=element_connections(element),
        warnings=parts.warnings,
        **parts.extra,  # type: ignore[arg-type]
    )
    return component, spec


def _part_boxes(parts: Sequence[TriMesh]) -> list[BoundingBox]:
    """The box of each collision part (component frame), when there is more than one."""
    if len(parts) < 2:
        return []
    return [
        BoundingBox(min_m=vec3(part.vertices.min(axis=0)), max_m=vec3(part.vertices.max(axis=0)))
        for part in parts
    ]


def _in_folder(rel_dir: str, name: str) -> str:
    """``rel_dir/name``; empty for a file not written (a visual format or the split IFC not asked for)."""
    return f"{rel_dir}/{name}" if name else ""


def _predefined_type(element: ifcopenshell.entity_instance) -> str | None:
    value = ifcopenshell.util.element.get_predefined_type(element)
    return str(value) if value else None


def _storey_name(element: ifcopenshell.entity_instance) -> str | None:
    container = ifcopenshell.util.element.get_container(element)
    if container is None:
        aggregate = ifcopenshell.util.element.get_aggregate(element)
        container = ifcopenshell.util.element.get_container(aggregate) if aggregate is not None else None
    return str(container.Name) if container is not None and container.Name else None
