"""As-built results and precast panels written into the exported IFC4 model (``ifcopenshell.api``).

Every component gets a property set ``Bimbot_AsBuilt``: its final state, construction method, robots,
attempts, final position and angle error against its BIM target (mm, degrees), its task's sim times and,
when it was not built, the reason. A panel (a component cut from an element, ``Component.parent_guid``) is
not in the source model: it is made here as an IfcBuildingElementPart (PRECASTPANEL) with the panel's
GlobalId, placed at its target pose and shaped by the converter's mesh, and aggregated into its element.
"""

from __future__ import annotations

import logging
from pathlib import Path

import ifcopenshell
import ifcopenshell.api.aggregate
import ifcopenshell.api.attribute
import ifcopenshell.api.context
import ifcopenshell.api.geometry
import ifcopenshell.api.pset
import ifcopenshell.api.root
import ifcopenshell.util.representation
import numpy as np
import trimesh
from scipy.spatial.transform import Rotation

from bimbot.export.meshes import load_triangles
from bimbot.export.sim_schedule import ComponentWork
from bimbot.shared.manifest import Component, Manifest

_log = logging.getLogger(__name__)

AS_BUILT_PSET = "Bimbot_AsBuilt"


def as_built_properties(work: ComponentWork) -> dict[str, object]:
    """The property set's values (None values are left out)."""
    values: dict[str, object | None] = {
        "State": work.state,
        "Method": work.method.value,
        "Robots": ", ".join(work.robot_ids) or None,
        "Attempts": work.attempts,
        "FinalPositionErrorMm": work.final_position_error_mm,
        "FinalAngleErrorDeg": work.final_angle_error_deg,
        "TaskIdentification": work.task_id,
        "StartSimTimeS": work.start_s,
        "FinishSimTimeS": work.finish_s,
    }
    return {name: value for name, value in values.items() if value is not None}


def add_as_built_pset(
    model: ifcopenshell.file, product: ifcopenshell.entity_instance, work: ComponentWork
) -> ifcopenshell.entity_instance:
    pset = ifcopenshell.api.pset.add_pset(model, product=product, name=AS_BUILT_PSET)
    properties: dict[str, object] = dict(as_built_properties(work))
    if work.reason:
        properties["Reason"] = model.create_entity("IfcText", work.reason)
    ifcopenshell.api.pset.edit_pset(model, pset=pset, properties=properties)
    return pset


def add_panels(
    model: ifcopenshell.file, manifest: Manifest, build_dir: Path
) -> dict[str, ifcopenshell.entity_instance]:
    """Each panel of ``manifest.panelised`` as a part of its element; GUID → the part."""
    parts: dict[str, ifcopenshell.entity_instance] = {}
    by_guid = {component.guid: component for component in manifest.components}
    for element in manifest.panelised:
        host = _by_guid(model, element.guid)
        if host is None:
            _log.warning(
                "panelised element %s is not in the source model: its panels are left out", element.guid
            )
            continue
        made = [
            _panel(model, by_guid[guid], manifest, build_dir)
            for guid in element.panel_guids
            if guid in by_guid
        ]
        if made:
            ifcopenshell.api.aggregate.assign_object(model, products=made, relating_object=host)
            parts.update({part.GlobalId: part for part in made})
    return parts


def _by_guid(model: ifcopenshell.file, guid: str) -> ifcopenshell.entity_instance | None:
    try:
        return model.by_guid(guid)
    except RuntimeError:
        return None


def _panel(
    model: ifcopenshell.file, panel: Component, manifest: Manifest, build_dir: Path
) -> ifcopenshell.entity_instance:
    part = ifcopenshell.api.root.create_entity(
        model,
        ifc_class="IfcBuildingElementPart",
        name=panel.name or panel.guid,
        predefined_type="PRECASTPANEL",
    )
    ifcopenshell.api.attribute.edit_attributes(model, product=part, attributes={"GlobalId": panel.guid})
    pose = panel.target_pose_world
    matrix = np.eye(4)
    matrix[:3, :3] = Rotation.from_quat(pose.quat_xyzw).as_matrix()
    matrix[:3, 3] = np.add(pose.position_m, manifest.local_origin_m)  # the IFC's world coordinates, metres
    ifcopenshell.api.geometry.edit_object_placement(model, product=part, matrix=matrix, is_si=True)
    mesh = load_triangles(build_dir / panel.files.visual_obj) if panel.files.visual_obj else None
    if mesh is not None:
        _add_mesh(model, part, mesh)
    return part


def _add_mesh(model: ifcopenshell.file, part: ifcopenshell.entity_instance, mesh: trimesh.Trimesh) -> None:
    context = ifcopenshell.util.representation.get_context(model, "Model", "Body", "MODEL_VIEW")
    if context is None:
        model_context = ifcopenshell.util.representation.get_context(model, "Model") or (
            ifcopenshell.api.context.add_context(model, context_type="Model")
        )
        context = ifcopenshell.api.context.add_context(
            model,
            context_type="Model",
            context_identifier="Body",
            target_view="MODEL_VIEW",
            parent=model_context,
        )
    representation = ifcopenshell.api.geometry.add_mesh_representation(
        model,
        context=context,
        vertices=[mesh.vertices.tolist()],
        faces=[mesh.faces.tolist()],  # vertices in metres: scaled to the model's length unit
    )
    ifcopenshell.api.geometry.assign_representation(model, product=part, representation=representation)
