"""Convert an opened IFC model into bimbot's SDF robot world: the converter's library entry point.

``convert_model(model, source_path, out_dir)`` writes::

    OUT/manifest.json                      every component and every skipped element
    OUT/worlds/<site>.world                the SDF world (building as designed, every component inlined)
    OUT/models/<folder>/model.config       Gazebo model metadata
    OUT/models/<folder>/model.sdf          the component (movable, BIM pose, inertial, collision parts)
    OUT/models/<folder>/meshes/            visual DAE/OBJ/GLB and convex collision OBJs, element frame, metres
    OUT/models/<folder>/<GUID>.ifc         the component split out as a standalone IFC
    OUT/sequence.xml                       construction sequence (the IFC schedule, else derived)

Work that depends only on geometry (mesh cleanup, mass properties, convex decomposition, mesh files) runs
once per distinct tessellation; everything per element is cheap. One element that fails is listed under
``skipped`` with its reason and the conversion goes on.
"""

from __future__ import annotations

import logging
import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import ifcopenshell
import ifcopenshell.util.element
import ifcopenshell.util.unit
import numpy as np

from bimbot import __version__
from shared.identifiers import guid_to_folder, guid_to_key, is_valid_guid, slugify
from shared.manifest import (
    BoundingBox,
    Component,
    ComponentFiles,
    Inertia,
    Manifest,
    SkippedElement,
    SourceModel,
    write_manifest,
)
from shared.sequence import SEQUENCE_FILE_NAME, write_sequence

from . import mass as mass_chain
from .collision import CollisionShape, collision_shape
from .connections import element_connections
from .ifc_input import file_sha256
from .mass_properties import MassProperties, mass_properties, mesh_from_arrays
from .mesh_files import GeometryFiles, link_geometry_files, write_geometry_files
from .placement import choose_local_origin, pose_from_rigid, split_rigid
from .sdf_writer import ModelSpec, model_config, model_sdf, world_sdf
from .selection import select_elements
from .sequencing import construction_sequence
from .split_ifc import split_element
from .tessellation import ElementShape, tessellate

_log = logging.getLogger(__name__)

ProgressCallback = Callable[[str, int, int], None]  # (stage, done, total)


@dataclass(frozen=True)
class ConvertOptions:
    include: tuple[str, ...] = ()
    exclude: tuple[str, ...] = ()
    threads: int | None = None
    far_from_origin_m: float = 1000.0


@dataclass
class _GeometryWork:
    """Per distinct geometry: computed once, shared by every element that uses it."""

    props: MassProperties
    collision: CollisionShape
    files: GeometryFiles | None = None
    files_dir: Path | None = None


@dataclass
class _Placed:
    element: ifcopenshell.entity_instance
    shape: ElementShape
    geometry_key: str
    rotation: np.ndarray
    translation_m: np.ndarray
    vertices_local_m: np.ndarray
    bbox_ifc_world_m: np.ndarray  # (2, 3) in IFC world coordinates (before the local-origin shift)


@dataclass
class ConversionStats:
    seconds_by_stage: dict[str, float] = field(default_factory=dict)


def convert_model(
    model: ifcopenshell.file,
    source_path: Path,
    out_dir: Path,
    options: ConvertOptions | None = None,
    *,
    progress: ProgressCallback | None = None,
    stats: ConversionStats | None = None,
) -> Manifest:
    out_dir = Path(out_dir)
    options = options or ConvertOptions()
    stats = stats if stats is not None else ConversionStats()
    clock = _StageClock(stats)
    selection = select_elements(model, options.include, options.exclude)
    elements = list(selection.elements)
    skipped = [_skipped(rejection.element, rejection.reason) for rejection in selection.rejected]
    warnings: list[str] = []
    clock.lap("select")

    done = 0

    def on_shape(_: ElementShape) -> None:
        nonlocal done
        done += 1
        if progress is not None:
            progress("tessellate", done, len(elements))

    tessellation = tessellate(model, elements, threads=options.threads, on_shape=on_shape)
    clock.lap("tessellate")
    by_id = {element.id(): element for element in elements}
    for step_id, reason in tessellation.failures.items():
        skipped.append(_skipped(by_id[step_id], reason))
    placed = [_place(by_id[step_id], shape) for step_id, shape in sorted(tessellation.shapes.items())]
    origin = choose_local_origin(
        np.concatenate([item.bbox_ifc_world_m for item in placed]) if placed else np.zeros((0, 3)),
        options.far_from_origin_m,
    )
    if np.any(origin):
        warnings.append(f"model far from the IFC origin: world shifted by local origin {origin.tolist()} m")
    clock.lap("place")

    _prepare_out_dir(out_dir)
    unit_scale_m = ifcopenshell.util.unit.calculate_unit_scale(model)
    geometry_work: dict[str, _GeometryWork] = {}
    components: list[Component] = []
    specs: list[ModelSpec] = []
    for index, item in enumerate(placed, start=1):
        try:
            work = geometry_work.get(item.geometry_key)
            if work is None:
                work = geometry_work[item.geometry_key] = _geometry_work(item, unit_scale_m)
            component, spec = _write_component(model, item, work, origin, out_dir)
        except Exception as error:  # one bad element never stops the conversion; the reason is kept
            _log.warning(
                "%s %s: %s", item.element.is_a(), item.element.GlobalId, error, exc_info=_log.isEnabledFor(10)
            )
            skipped.append(_skipped(item.element, f"conversion failed: {type(error).__name__}: {error}"))
            continue
        components.append(component)
        specs.append(spec)
        if progress is not None:
            progress("write", index, len(placed))
    clock.lap("components")

    site_name = _site_name(model)
    site = slugify(site_name)
    world_path = out_dir / "worlds" / f"{site}.world"
    world_path.parent.mkdir(parents=True, exist_ok=True)
    world_path.write_bytes(world_sdf(site, specs, extent_m=_world_extent_m(components)))
    sequence, sequence_warnings = construction_sequence(model, components)
    warnings.extend(sequence_warnings)
    write_sequence(sequence, out_dir / SEQUENCE_FILE_NAME)
    clock.lap("world_and_sequence")

    manifest = Manifest(
        generator=f"bimbot {__version__} (ifcopenshell {ifcopenshell.version})",
        site=site,
        site_name=site_name,
        source=SourceModel(
            path=str(source_path),
            schema_name=str(getattr(model, "schema_identifier", model.schema)),
            sha256=file_sha256(source_path),
            length_unit_m=unit_scale_m,
        ),
        local_origin_m=tuple(float(v) for v in origin),
        world_file=world_path.relative_to(out_dir).as_posix(),
        sequence_file=SEQUENCE_FILE_NAME,
        sequence_source=sequence.source,
        components=components,
        skipped=sorted(skipped, key=lambda item: (item.ifc_class, item.guid)),
        warnings=warnings + [f"{c.guid}: {w}" for c in components for w in c.warnings],
    )
    write_manifest(manifest, out_dir)
    clock.lap("manifest")
    return manifest


class _StageClock:
    def __init__(self, stats: ConversionStats) -> None:
        self._stats = stats
        self._last = time.perf_counter()

    def lap(self, stage: str) -> None:
        now = time.perf_counter()
        self._stats.seconds_by_stage[stage] = self._stats.seconds_by_stage.get(stage, 0.0) + now - self._last
        self._last = now


def _prepare_out_dir(out_dir: Path) -> None:
    """Start from a clean models/ and worlds/ so no stale component survives a re-conversion."""
    out_dir.mkdir(parents=True, exist_ok=True)
    for sub in ("models", "worlds"):
        if (out_dir / sub).exists():
            shutil.rmtree(out_dir / sub)
    (out_dir / "models").mkdir()


def _skipped(element: ifcopenshell.entity_instance, reason: str) -> SkippedElement:
    return SkippedElement(
        guid=str(element.GlobalId or f"#{element.id()}"),
        ifc_class=element.is_a(),
        name=element.Name,
        reason=reason,
    )


def _place(element: ifcopenshell.entity_instance, shape: ElementShape) -> _Placed:
    rigid = split_rigid(shape.placement_world_m)
    vertices = shape.geometry.vertices_local_m
    key = shape.geometry.geometry_id
    if rigid.residual is not None:  # scaled or mirrored placement: bake the non-rigid part into the mesh
        vertices = vertices @ rigid.residual.T
        key = f"{key}:{element.id()}"
    world = vertices @ rigid.rotation.T + rigid.translation_m
    bbox = np.array([world.min(axis=0), world.max(axis=0)])
    return _Placed(element, shape, key, rigid.rotation, rigid.translation_m, vertices, bbox)


def _geometry_work(item: _Placed, unit_scale_m: float) -> _GeometryWork:
    mesh = mesh_from_arrays(item.vertices_local_m, item.shape.geometry.faces)
    return _GeometryWork(
        props=mass_properties(mesh), collision=collision_shape(item.element, mesh, unit_scale_m)
    )


def _write_component(
    model: ifcopenshell.file, item: _Placed, work: _GeometryWork, origin: np.ndarray, out_dir: Path
) -> tuple[Component, ModelSpec]:
    element = item.element
    guid = str(element.GlobalId)
    folder = guid_to_folder(guid)
    model_dir = out_dir / "models" / folder
    model_dir.mkdir(parents=True, exist_ok=True)
    if work.files is None or work.files_dir is None:
        visual = mesh_from_arrays(item.vertices_local_m, item.shape.geometry.faces)
        work.files = write_geometry_files(model_dir, visual, work.collision.parts)
        work.files_dir = model_dir
    else:
        link_geometry_files(work.files_dir, model_dir, work.files)
    props = work.props
    warnings: list[str] = []
    mass = mass_chain.element_mass(element, props.volume_m3)
    warnings.extend(mass.warnings)
    if not props.watertight:
        warnings.append("mesh is not watertight: inertia from its bounding box, volume from its convex hull")
    if work.collision.note:
        warnings.append(work.collision.note)
    inertia = props.inertia_kg_m2(mass.mass_kg)
    pose = pose_from_rigid(item.rotation, item.translation_m, origin)
    split_name = f"{guid if is_valid_guid(guid) else folder}.ifc"
    split_element(model, element).write(str(model_dir / split_name))
    spec = ModelSpec(
        guid=guid,
        folder=folder,
        ifc_class=element.is_a(),
        ifc_name=element.Name,
        pose_world=pose,
        mass_kg=mass.mass_kg,
        com_local_m=tuple(props.com_local_m),
        inertia_kg_m2=inertia,
        visual_mesh=work.files.visual_dae,
        collision_meshes=work.files.collision,
    )
    (model_dir / "model.sdf").write_bytes(model_sdf(spec))
    (model_dir / "model.config").write_bytes(model_config(spec))
    rel_dir = model_dir.relative_to(out_dir).as_posix()
    component = Component(
        guid=guid,
        key=guid_to_key(guid),
        folder=folder,
        ifc_class=element.is_a(),
        predefined_type=_predefined_type(element),
        name=element.Name,
        storey=_storey_name(element),
        material=mass_chain.material_label(element),
        target_pose_world=pose,
        bbox_world=BoundingBox(
            min_m=tuple(float(v) for v in item.bbox_ifc_world_m[0] - origin),
            max_m=tuple(float(v) for v in item.bbox_ifc_world_m[1] - origin),
        ),
        bbox_local=BoundingBox(
            min_m=tuple(float(v) for v in props.bbox_local_m[0]),
            max_m=tuple(float(v) for v in props.bbox_local_m[1]),
        ),
        volume_m3=props.volume_m3,
        watertight=props.watertight,
        mass_kg=mass.mass_kg,
        mass_source=mass.source,
        com_local_m=tuple(float(v) for v in props.com_local_m),
        inertia_kg_m2=Inertia(
            ixx=inertia[0, 0],
            ixy=inertia[0, 1],
            ixz=inertia[0, 2],
            iyy=inertia[1, 1],
            iyz=inertia[1, 2],
            izz=inertia[2, 2],
        ),
        inertia_source=props.source,
        collision_method=work.collision.method,
        collision_parts=len(work.collision.parts),
        files=ComponentFiles(
            model_dir=rel_dir,
            sdf_file=f"{rel_dir}/model.sdf",
            config_file=f"{rel_dir}/model.config",
            split_ifc=f"{rel_dir}/{split_name}",
            visual_dae=f"{rel_dir}/{work.files.visual_dae}",
            visual_obj=f"{rel_dir}/{work.files.visual_obj}",
            visual_glb=f"{rel_dir}/{work.files.visual_glb}",
            collision=[f"{rel_dir}/{name}" for name in work.files.collision],
        ),
        connections=element_connections(element),
        warnings=warnings,
    )
    return component, spec


def _predefined_type(element: ifcopenshell.entity_instance) -> str | None:
    value = ifcopenshell.util.element.get_predefined_type(element)
    return str(value) if value else None


def _storey_name(element: ifcopenshell.entity_instance) -> str | None:
    container = ifcopenshell.util.element.get_container(element)
    if container is None:
        aggregate = ifcopenshell.util.element.get_aggregate(element)
        container = ifcopenshell.util.element.get_container(aggregate) if aggregate is not None else None
    return str(container.Name) if container is not None and container.Name else None


def _site_name(model: ifcopenshell.file) -> str | None:
    sites = model.by_type("IfcSite")
    return str(sites[0].Name) if sites and sites[0].Name else None


def _world_extent_m(components: list[Component]) -> float:
    if not components:
        return 0.0
    corners = np.array([c.bbox_world.min_m for c in components] + [c.bbox_world.max_m for c in components])
    return float(4.0 * np.abs(corners[:, :2]).max() + 20.0)
