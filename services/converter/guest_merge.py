"""Build each ``with_host`` component into its host: one body, and no longer a component of its own.

The host's component gets its guests' collision parts (moved into the host's frame; at most
``MAX_COLLISION_PARTS``: each guest's parts merged into one hull, then hulls merged along the body if still
too many), their mass added with the combined centre of mass and inertia (each part's inertia moved to the
common centre of mass by the parallel-axis theorem), its bounding boxes and volume grown, and a
:class:`GuestElement` per guest in ``guests``. Its collision files and ``model.sdf`` are written again
(the old files unlinked first: they may be hard links shared with elements of the same geometry). A
guest's own model folder stays, with its visual meshes, which its ``GuestElement`` names with its pose in
the host's frame. A guest without a host (:mod:`.guest_hosts`) stays a lifted component, with a warning.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

from bimbot.shared.construction_methods import ConstructionMethod, GuestElement, MethodSource
from bimbot.shared.manifest import MAX_COLLISION_PARTS, BoundingBox, Component, Inertia

from .collision import merge_parts
from .guest_hosts import Hosting
from .mesh import TriMesh, convex_hull
from .mesh_files import collision_file, read_obj, write_obj
from .placement import matrix_from_quat, quat_from_matrix, quat_xyzw, vec3
from .sdf_writer import ModelSpec, model_sdf

_log = logging.getLogger(__name__)


def build_guests_into_hosts(
    components: Sequence[Component],
    specs: Sequence[ModelSpec],
    hostings: dict[str, Hosting],
    missing: dict[str, str],
    out_dir: Path,
) -> tuple[list[Component], list[ModelSpec]]:
    """``(components, specs)`` with each hosted guest built into its host and left out; each guest in
    ``missing`` (guest → why it has no host) lifted on its own, its warning saying why."""
    guests_of: dict[str, list[Component]] = {}
    for component in components:
        if component.guid in hostings:
            guests_of.setdefault(hostings[component.guid].host_guid, []).append(component)
    out_components: list[Component] = []
    out_specs: list[ModelSpec] = []
    for component, spec in zip(components, specs, strict=True):
        if component.guid in hostings:
            continue
        built, built_spec = component, spec
        if component.guid in missing:
            built = _unhosted(component, missing[component.guid])
        elif component.guid in guests_of:
            built, built_spec = _with_guests(component, spec, guests_of[component.guid], hostings, out_dir)
        out_components.append(built)
        out_specs.append(built_spec)
    return out_components, out_specs


def _unhosted(component: Component, why: str) -> Component:
    note = f"{component.method_note}; " if component.method_note else ""
    return component.model_copy(
        update={
            "method": ConstructionMethod.LIFTED,
            "method_source": MethodSource.RULE,
            "method_note": f"{note}no host: {why}; lifted on its own",
            "warnings": [*component.warnings, f"built with its host, but {why}: lifted on its own"],
        }
    )


def _with_guests(
    host: Component, spec: ModelSpec, guests: list[Component], hostings: dict[str, Hosting], out_dir: Path
) -> tuple[Component, ModelSpec]:
    host_rotation = matrix_from_quat(host.target_pose_world.quat_xyzw)
    host_position = np.asarray(host.target_pose_world.position_m, dtype=float)
    parts = [read_obj(out_dir / path) for path in host.files.collision]
    guest_parts: list[list[TriMesh]] = []
    masses = [host.mass_kg]
    centres = [np.asarray(host.com_local_m, dtype=float)]
    inertias = [_tensor(host.inertia_kg_m2)]
    boxes = [np.array([host.bbox_local.min_m, host.bbox_local.max_m], dtype=float)]
    entries: list[GuestElement] = []
    for guest in guests:
        rotation = host_rotation.T @ matrix_from_quat(guest.target_pose_world.quat_xyzw)
        offset = host_rotation.T @ (
            np.asarray(guest.target_pose_world.position_m, dtype=float) - host_position
        )
        moved = [
            TriMesh(mesh.vertices @ rotation.T + offset, mesh.faces)
            for mesh in (read_obj(out_dir / path) for path in guest.files.collision)
        ]
        guest_parts.append(moved)
        masses.append(guest.mass_kg)
        centres.append(rotation @ np.asarray(guest.com_local_m, dtype=float) + offset)
        inertias.append(rotation @ _tensor(guest.inertia_kg_m2) @ rotation.T)
        corners = _corners(np.array([guest.bbox_local.min_m, guest.bbox_local.max_m])) @ rotation.T + offset
        boxes.append(np.array([corners.min(axis=0), corners.max(axis=0)]))
        entries.append(
            GuestElement(
                guid=guest.guid,
                ifc_class=guest.ifc_class,
                name=guest.name,
                mass_kg=guest.mass_kg,
                relation=hostings[guest.guid].relation,
                visual_glb=guest.files.visual_glb,
                visual_obj=guest.files.visual_obj,
                position_in_host_m=vec3(offset),
                quat_in_host_xyzw=quat_xyzw(quat_from_matrix(rotation)),
            )
        )
    parts = _within_limit(parts, guest_parts)
    mass_kg = float(sum(masses))
    weights = np.asarray(masses, dtype=float)
    com = (weights[:, None] * np.array(centres)).sum(axis=0) / mass_kg
    inertia = np.zeros((3, 3))
    for m, centre, tensor in zip(masses, centres, inertias, strict=True):
        inertia += tensor + m * _shift(centre - com)
    model_dir = out_dir / host.files.model_dir
    for path in host.files.collision:  # may be hard links shared with same-geometry elements
        (out_dir / path).unlink(missing_ok=True)
    names = [collision_file(index) for index in range(len(parts))]
    for part, name in zip(parts, names, strict=True):
        write_obj(model_dir / name, part)
    spec = replace(
        spec, mass_kg=mass_kg, com_local_m=tuple(com), inertia_kg_m2=inertia, collision_meshes=names
    )
    (model_dir / "model.sdf").write_bytes(model_sdf(spec))
    local = np.array([np.min([b[0] for b in boxes], axis=0), np.max([b[1] for b in boxes], axis=0)])
    world = _corners(local) @ host_rotation.T + host_position
    updated = host.model_copy(
        update={
            "mass_kg": mass_kg,
            "com_local_m": vec3(com),
            "inertia_kg_m2": Inertia(
                ixx=inertia[0, 0],
                ixy=inertia[0, 1],
                ixz=inertia[0, 2],
                iyy=inertia[1, 1],
                iyz=inertia[1, 2],
                izz=inertia[2, 2],
            ),
            "volume_m3": host.volume_m3 + sum(guest.volume_m3 for guest in guests),
            "bbox_local": BoundingBox(min_m=vec3(local[0]), max_m=vec3(local[1])),
            "bbox_world": BoundingBox(min_m=vec3(world.min(axis=0)), max_m=vec3(world.max(axis=0))),
            "collision_parts": len(parts),
            "files": host.files.model_copy(
                update={"collision": [f"{host.files.model_dir}/{n}" for n in names]}
            ),
            "guests": [*host.guests, *entries],
        }
    )
    _log.debug("%s: %d guest(s) built in", host.guid, len(guests))
    return updated, spec


def _within_limit(host_parts: list[TriMesh], guest_parts: list[list[TriMesh]]) -> list[TriMesh]:
    """The host's parts and the guests', at most ``MAX_COLLISION_PARTS`` (see the module docstring)."""
    every = [part for parts in guest_parts for part in parts]
    if len(host_parts) + len(every) <= MAX_COLLISION_PARTS:
        return host_parts + every
    hulls = [convex_hull(np.vstack([part.vertices for part in parts])) for parts in guest_parts if parts]
    merged = host_parts + [hull for hull in hulls if hull is not None]
    return merged if len(merged) <= MAX_COLLISION_PARTS else merge_parts(merged, MAX_COLLISION_PARTS)


def _tensor(inertia: Inertia) -> np.ndarray:
    return np.array(
        [
            [inertia.ixx, inertia.ixy, inertia.ixz],
            [inertia.ixy, inertia.iyy, inertia.iyz],
            [inertia.ixz, inertia.iyz, inertia.izz],
        ]
    )


def _shift(offset: np.ndarray) -> np.ndarray:
    """The parallel-axis term per kg for a centre ``offset`` from the common one (SDF's tensor signs)."""
    return float(offset @ offset) * np.eye(3) - np.outer(offset, offset)


def _corners(box: np.ndarray) -> np.ndarray:
    return np.array([[box[i][0], box[j][1], box[k][2]] for i in (0, 1) for j in (0, 1) for k in (0, 1)])
