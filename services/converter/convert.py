"""Convert an opened IFC model into bimbot's SDF robot world: the converter's library entry point.

``convert_model(model, source_path, out_dir)`` writes::

    OUT/manifest.json                      every component and every skipped element
    OUT/worlds/<site>.world                the SDF world (building as designed, every component inlined)
    OUT/models/<folder>/model.config       Gazebo model metadata
    OUT/models/<folder>/model.sdf          the component (movable, BIM pose, inertial, collision parts)
    OUT/models/<folder>/meshes/            visual DAE/OBJ/GLB (the formats asked for) and convex collision
                                           OBJs, element frame, metres
    OUT/models/<folder>/<GUID>.ifc         the component split out as a standalone IFC (unless not asked for)
    OUT/sequence.xml                       construction sequence (the IFC schedule, else derived)

Elements are converted in shards, one forked worker per core (:mod:`.shards`); within a shard, work that
depends only on geometry (mass properties, convex decomposition, mesh files) runs once per distinct
tessellation (:mod:`.component_writer`). One element that fails is listed under ``skipped`` with its reason
and the conversion goes on. The local origin is chosen from the elements' placements before the shards
start, so every worker writes final poses.
"""

from __future__ import annotations

import logging
import shutil
import time
import warnings
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from importlib.metadata import version
from pathlib import Path
from typing import TextIO

import ifcopenshell
import ifcopenshell.util.placement
import ifcopenshell.util.unit
import numpy as np

from bimbot.shared.construction_methods import MethodDecision, MethodLimits
from bimbot.shared.crane_count import sized_cranes
from bimbot.shared.crane_erection import erected_for
from bimbot.shared.fleet import Fleet, default_fleet
from bimbot.shared.identifiers import slugify
from bimbot.shared.idle_machines import site_fleet
from bimbot.shared.ifc_input import file_sha256
from bimbot.shared.ifc_parse_damage import ParseDamage, damaged_elements, describe_unreadable
from bimbot.shared.joints import JointSettings, default_joint_settings
from bimbot.shared.manifest import Component, Manifest, SourceModel, write_manifest
from bimbot.shared.methods_file import MethodsFile, load_methods
from bimbot.shared.sequence import SEQUENCE_FILE_NAME, write_sequence

from .built_in_boards import build_in_boards
from .component_work import ShardContext
from .component_writer import skipped_entry
from .connection_kinds import decide_connections
from .crane_reach import crane_lift_limits, tightened
from .duplicates import drop_duplicates
from .face_materials import style_materials
from .final_method import method_limits
from .guest_hosts import find_hosts
from .guest_merge import build_guests_into_hosts
from .in_place import split_in_place
from .joints import find_joints
from .left_out import without_left_out
from .mass import mass_unit_kg
from .mesh_files import VISUAL_FORMATS
from .method_decisions import decide_methods
from .panel_links import link_panels
from .placement import axis2placement_matrix, choose_local_origin, vec3
from .room_contents import room_floors
from .sdf_writer import world_sdf
from .selection import left_out_by_selection, select_elements
from .sequencing import construction_sequence
from .shards import ShardResult, run_shards, without_elements
from .tessellation import default_threads

_log = logging.getLogger(__name__)

REACH_ROUNDS = 2  # cut again for the crane's reach, then once more if the finer parts moved the crane

ProgressCallback = Callable[[str, int, int], None]  # (stage, done, total)


@dataclass(frozen=True)
class ConvertOptions:
    include: tuple[str, ...] = ()  # classes built on top of the default building elements (with subclasses)
    exclude: tuple[str, ...] = ()  # classes left out (with subclasses)
    exclude_guids: tuple[str, ...] = ()  # single elements left out, by GlobalId
    only: tuple[str, ...] = ()  # when given, these classes replace the default building elements
    threads: int | None = None  # worker processes (default: all cores)
    far_from_origin_m: float = 1000.0
    formats: tuple[str, ...] = VISUAL_FORMATS  # visual mesh formats written (collision OBJs always are)
    split_ifc: bool = True  # each component's standalone <GUID>.ifc (paper §4.3.1); no run reads it
    in_place_guids: tuple[str, ...] = ()  # in place before the robots come (.in_place), by GlobalId
    foundations_in_place: bool = False  # every component in the ground is in place too
    methods: MethodsFile | None = None  # how each element is built (default: the prefab preset)
    fleet: Fleet | None = None  # what lifts the parts: too heavy is decided against it (default fleet)
    decisions: Mapping[str, MethodDecision] = field(default_factory=dict)  # by GlobalId, over the file's
    limits: MethodLimits | None = None  # what a lift and a truck take (default: the fleet's, the file's)
    joints: JointSettings | None = None  # what an overlap must be to be a joint (None: the default rules)
    build_context: bool = False  # build the context massing too (.context_massing), not leave it out


@dataclass
class ConversionStats:
    """Wall seconds per stage; ``tessellate``/``components`` are summed over the workers (CPU-like)."""

    seconds_by_stage: dict[str, float] = field(default_factory=dict)


def convert_model(
    model: ifcopenshell.file,
    source_path: Path,
    out_dir: Path,
    options: ConvertOptions | None = None,
    *,
    progress: ProgressCallback | None = None,
    stats: ConversionStats | None = None,
    damage: ParseDamage | None = None,
) -> Manifest:
    """Convert ``model`` (read from ``source_path``) into ``out_dir``. ``damage``: what the parser could
    not read in the file (:func:`.ifc_input.read_model`); the elements it leaves incomplete are skipped."""
    with numeric_warnings_logged():
        return _convert(model, source_path, out_dir, options, progress=progress, stats=stats, damage=damage)


@contextmanager
def numeric_warnings_logged() -> Iterator[None]:
    """numpy's and trimesh's RuntimeWarnings (a division by a zero volume in trimesh's oriented box of a
    flat mesh) go to the log at DEBUG, not to the user's terminal; the workers forked meanwhile inherit
    it. Other warnings are shown as before."""
    with warnings.catch_warnings():
        shown = warnings.showwarning

        def show(  # noqa: PLR0917 (warnings.showwarning's signature)
            message: Warning | str,
            category: type[Warning],
            filename: str,
            lineno: int,
            file: TextIO | None = None,
            line: str | None = None,
        ) -> None:
            if issubclass(category, RuntimeWarning):
                _log.debug("%s:%d: %s: %s", filename, lineno, category.__name__, message)
            else:
                shown(message, category, filename, lineno, file, line)

        warnings.showwarning = show
        yield


def _convert(
    model: ifcopenshell.file,
    source_path: Path,
    out_dir: Path,
    options: ConvertOptions | None,
    *,
    progress: ProgressCallback | None,
    stats: ConversionStats | None,
    damage: ParseDamage | None,
) -> Manifest:
    out_dir = Path(out_dir)
    options = options or ConvertOptions()
    stats = stats if stats is not None else ConversionStats()
    started = time.perf_counter()
    selection = select_elements(model, options.include, options.exclude, options.only, options.exclude_guids)
    elements = list(selection.elements)
    warnings: list[str] = []
    damaged: dict[int, str] = {}
    if damage:  # what the damage took overrides the reason it made (a body lost reads as "no body")
        warnings += describe_unreadable(damage)
        candidates = elements + [r.element for r in selection.rejected if not left_out_by_selection(r.reason)]
        damaged = damaged_elements(model, damage, candidates)
    skipped = [
        skipped_entry(rejection.element, damaged.get(rejection.element.id(), rejection.reason))
        for rejection in selection.rejected
    ]
    skipped += [
        skipped_entry(element, damaged[element.id()]) for element in elements if element.id() in damaged
    ]
    elements = [element for element in elements if element.id() not in damaged]
    unit_scale_m = ifcopenshell.util.unit.calculate_unit_scale(model)
    origin = _placement_origin(elements, unit_scale_m, options.far_from_origin_m)
    if np.any(origin):
        warnings.append(f"model far from the IFC origin: world shifted by local origin {origin.tolist()} m")
    _prepare_out_dir(out_dir)
    methods = options.methods or load_methods()
    decisions = {**decide_methods(elements, methods), **options.decisions}
    stats.seconds_by_stage["select"] = time.perf_counter() - started

    shards_started = time.perf_counter()
    workers = options.threads or default_threads()
    context = ShardContext(
        out_dir=out_dir,
        origin=origin,
        unit_scale_m=unit_scale_m,
        mass_unit_kg=mass_unit_kg(model),
        formats=options.formats,
        split_ifc=options.split_ifc,
        decisions=decisions,
        limits=options.limits or method_limits(options.fleet or default_fleet(), methods),
        methods=methods,
        storey_levels_m=_storey_levels_m(model, unit_scale_m),
        style_materials=style_materials(model),
        room_floors=room_floors(model, elements),
    )
    results = run_shards(model, elements, context, workers=workers, progress=progress)
    stats.seconds_by_stage["shards_wall"] = time.perf_counter() - shards_started
    results, left_out = without_left_out(elements, results, out_dir, build_context=options.build_context)
    skipped += left_out
    reach_started = time.perf_counter()
    results = _cut_within_crane_reach(
        model,
        elements,
        results,
        context,
        options=options,
        fleet=options.fleet or default_fleet(),
        workers=workers,
    )
    stats.seconds_by_stage["crane_reach"] = time.perf_counter() - reach_started
    merged = sorted(  # element order; an element's panels in their order
        (
            (step_id, index, component, spec)
            for result in results
            for index, (step_id, component, spec) in enumerate(
                zip(result.step_ids, result.components, result.specs, strict=True)
            )
        ),
        key=lambda row: (row[0], row[1]),
    )
    panelised = sorted((entry for result in results for entry in result.panelised), key=lambda e: e.guid)
    merged_components = [component for _, _, component, _ in merged]
    converted = build_in_boards(link_panels(merged_components, panelised))  # blocking inside its wall
    hostings, unhosted = find_hosts(model, converted)
    converted, specs = build_guests_into_hosts(
        converted, [spec for _, _, _, spec in merged], hostings, unhosted, out_dir
    )
    converted, repeated = drop_duplicates(converted)
    if repeated:
        copies = {entry.guid for entry in repeated}
        for copy in (component for component in merged_components if component.guid in copies):
            shutil.rmtree(out_dir / copy.files.model_dir, ignore_errors=True)  # its files may be hard links
        specs = [spec for spec in specs if spec.guid not in copies]
        skipped.extend(repeated)
    components, in_place = split_in_place(
        converted, options.in_place_guids, foundations=options.foundations_in_place
    )
    for result in results:
        skipped.extend(result.skipped)
        for stage, seconds in result.seconds_by_stage.items():
            stats.seconds_by_stage[stage] = stats.seconds_by_stage.get(stage, 0.0) + seconds
    bboxes = [box for result in results for box in result.bboxes_ifc_world_m]
    if bboxes and np.any(choose_local_origin(np.concatenate(bboxes), options.far_from_origin_m) != origin):
        warnings.append("geometry lies far from its placements: the local origin follows the placements")

    joints_started = time.perf_counter()
    found = find_joints(model, [*components, *in_place], out_dir, options.joints or default_joint_settings())
    components = decide_connections(
        components, [*components, *in_place], found.joints, methods.connections, methods.temporary_supports
    )
    stats.seconds_by_stage["joints"] = time.perf_counter() - joints_started

    finishing = time.perf_counter()
    site_name = _site_name(model)
    site = slugify(site_name)
    world_path = out_dir / "worlds" / f"{site}.world"
    world_path.parent.mkdir(parents=True, exist_ok=True)
    world_path.write_bytes(world_sdf(site, specs, extent_m=_world_extent_m([*components, *in_place])))
    sequence, sequence_warnings = construction_sequence(model, components, found.joints)
    warnings.extend(sequence_warnings)
    write_sequence(sequence, out_dir / SEQUENCE_FILE_NAME)
    manifest = Manifest(
        generator=f"bimbot {version('bimbot')} (ifcopenshell {ifcopenshell.version})",
        site=site,
        site_name=site_name,
        source=SourceModel(
            path=str(source_path),
            schema_name=str(getattr(model, "schema_identifier", model.schema)),
            sha256=file_sha256(source_path),
            length_unit_m=unit_scale_m,
        ),
        local_origin_m=vec3(origin),
        world_file=world_path.relative_to(out_dir).as_posix(),
        sequence_file=SEQUENCE_FILE_NAME,
        sequence_source=sequence.source,
        components=components,
        in_place=in_place,
        panelised=panelised,
        joints=found.joints,
        clashes=found.clashes,
        skipped=sorted(skipped, key=lambda item: (item.ifc_class, item.guid)),
        warnings=warnings + [f"{_named(c)}: {w}" for c in [*components, *in_place] for w in c.warnings],
    )
    write_manifest(manifest, out_dir)
    stats.seconds_by_stage["world_sequence_manifest"] = time.perf_counter() - finishing
    return manifest


def _cut_within_crane_reach(
    model: ifcopenshell.file,
    elements: list[ifcopenshell.entity_instance],
    results: list[ShardResult],
    context: ShardContext,
    *,
    options: ConvertOptions,
    fleet: Fleet,
    workers: int,
) -> list[ShardResult]:
    """``results`` with the elements some part of which no crane lifts where it goes converted again with
    the lift a crane has there (:mod:`.crane_reach`), their first model folders removed; checked again after
    each round (finer parts fill the yard differently, which may move the crane), :data:`REACH_ROUNDS`
    rounds at most."""
    by_guid = {str(element.GlobalId): element for element in elements}
    for _ in range(REACH_ROUNDS):
        built = [component for result in results for component in result.components]
        to_build, _ = split_in_place(built, options.in_place_guids, foundations=options.foundations_in_place)
        # the site as the run plans it: without the machines it leaves off site for want of work
        # and its cranes erected as high as the building needs, as physics erects them
        # and as many cranes as its footprint needs, as bimbot run sizes them
        on_site = erected_for(
            sized_cranes(site_fleet(fleet, (item.method for item in to_build)), to_build), to_build
        )
        found = {
            guid: limit
            for guid, limit in crane_lift_limits(to_build, on_site.robot_types()).items()
            if guid in by_guid
            and (guid not in context.lift_limits or limit.lift_kg < context.lift_limits[guid].lift_kg)
        }
        if not found:
            break
        _log.info("%d element(s) cut again for the crane's lift where they go", len(found))
        context.lift_limits = tightened(context.lift_limits, found)
        again = [by_guid[guid] for guid in found]
        step_ids = {element.id() for element in again}
        for result in results:
            for step_id, component in zip(result.step_ids, result.components, strict=True):
                if step_id in step_ids:
                    shutil.rmtree(context.out_dir / component.files.model_dir, ignore_errors=True)
        results = [without_elements(result, step_ids, set(found)) for result in results]
        results += run_shards(model, again, context, workers=workers)
    return results


def _placement_origin(
    elements: list[ifcopenshell.entity_instance], unit_scale_m: float, far_from_origin_m: float
) -> np.ndarray:
    """The local origin from where the elements are placed (known before any geometry is built)."""
    memo: dict[int, np.ndarray] = {}
    points = [
        _placement_matrix(element.ObjectPlacement, memo)[:3, 3] * unit_scale_m
        for element in elements
        if element.ObjectPlacement is not None
    ]
    return choose_local_origin(np.array(points).reshape(-1, 3), far_from_origin_m)


def _placement_matrix(placement: ifcopenshell.entity_instance, memo: dict[int, np.ndarray]) -> np.ndarray:
    """ifcopenshell's ``get_local_placement``, each placement of the chain computed once (elements share
    their storey's and building's placements; recomputing them was most of this step)."""
    key = placement.id()
    matrix = memo.get(key)
    if matrix is None:
        if placement.is_a("IfcLocalPlacement"):
            relative = axis2placement_matrix(placement.RelativePlacement)
            parent = placement.PlacementRelTo
            matrix = relative if parent is None else np.dot(_placement_matrix(parent, memo), relative)
        else:
            matrix = ifcopenshell.util.placement.get_local_placement(placement)
        memo[key] = matrix
    return matrix


def _storey_levels_m(model: ifcopenshell.file, unit_scale_m: float) -> tuple[float, ...]:
    """The storeys' elevations (IFC world z of their placements, metres): where wall panels are cut."""
    memo: dict[int, np.ndarray] = {}
    levels = {
        round(float(_placement_matrix(storey.ObjectPlacement, memo)[2, 3]) * unit_scale_m, 6)
        for storey in model.by_type("IfcBuildingStorey")
        if storey.ObjectPlacement is not None
    }
    return tuple(sorted(levels))


def _prepare_out_dir(out_dir: Path) -> None:
    """Start from a clean models/ and worlds/ so no stale component survives a re-conversion."""
    out_dir.mkdir(parents=True, exist_ok=True)
    for sub in ("models", "worlds"):
        if (out_dir / sub).exists():
            shutil.rmtree(out_dir / sub)
    (out_dir / "models").mkdir()


def _site_name(model: ifcopenshell.file) -> str | None:
    sites = model.by_type("IfcSite")
    return str(sites[0].Name) if sites and sites[0].Name else None


def _world_extent_m(components: list[Component]) -> float:
    if not components:
        return 0.0
    corners = np.array([c.bbox_world.min_m for c in components] + [c.bbox_world.max_m for c in components])
    return float(4.0 * np.abs(corners[:, :2]).max() + 20.0)


def _named(component: Component) -> str:
    """``IfcWindow 'Ventana fija:1200 x 1500:161371' (2idC0G3ezCdhA9WVjWe$V2)``: a warning a user can act on
    says which element, not only its GUID."""
    name = f" {component.name!r}" if component.name else ""
    return f"{component.ifc_class}{name} ({component.guid})"
