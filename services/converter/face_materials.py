"""How much of an element each of its materials makes, from the faces its mesh styles with each material.

Why: an element of several materials given with no thicknesses or fractions (an ``IfcMaterialList``: the
Revit house's windows list "Vidrio", "Madera - Castaño" and "Piedra - Gris") was weighed all at its first
material's density: glass, 2,500 kg/m³, 535 kg for a window whose frame is mostly wood. Exports give each
material a surface style (``IfcMaterialDefinitionRepresentation``) and style each body of the element
with its material's, so every face of the tessellation names its material. Each piece of the mesh (faces
connected through shared edges: one body) is weighed with the material most of its faces are styled as
(:func:`.mass.layered_density` takes the volumes as the parts' shares). A style that names no material of
the element counts as unknown material.
"""

from __future__ import annotations

from collections.abc import Mapping

import ifcopenshell
import ifcopenshell.util.element
import numpy as np

from .mass_properties import is_solid, piece_volume_m3
from .mesh import TriMesh, submesh


def style_materials(model: ifcopenshell.file) -> dict[int, ifcopenshell.entity_instance]:
    """Surface style STEP id → the material it represents (``IfcMaterialDefinitionRepresentation``; IFC2X3
    through ``IfcPresentationStyleAssignment``); the first material wins a style two share."""
    found: dict[int, ifcopenshell.entity_instance] = {}
    for definition in model.by_type("IfcMaterialDefinitionRepresentation"):
        material = definition.RepresentedMaterial
        for representation in definition.Representations or ():
            for item in getattr(representation, "Items", None) or ():
                for style in _surface_styles(item):
                    found.setdefault(style.id(), material)
    return found


def _surface_styles(item: ifcopenshell.entity_instance) -> list[ifcopenshell.entity_instance]:
    styles = []
    for style in getattr(item, "Styles", None) or ():
        if style.is_a("IfcPresentationStyleAssignment"):  # IFC2X3
            styles += [inner for inner in style.Styles or () if inner.is_a("IfcSurfaceStyle")]
        elif style.is_a("IfcSurfaceStyle"):
            styles.append(style)
    return styles


def volumes_by_style(
    mesh: TriMesh, face_style_ids: np.ndarray, surface_volume_m3: float | None = None
) -> dict[int, float]:
    """Surface style STEP id (-1: none) → the volume of the pieces of ``mesh`` most of whose faces have it
    (``face_style_ids``: per face of ``mesh``); empty when the styles do not match the faces.
    ``surface_volume_m3``: the whole surface's exact volume when it closes though its pieces do not
    (:func:`.mass_properties.mass_properties`): the closed pieces keep their own, and the open ones share
    the rest in proportion to their estimates, so a frame's hull does not outweigh the glass it holds."""
    if len(face_style_ids) != len(mesh.faces):
        return {}
    pieces: list[tuple[int, float, bool]] = []
    for faces in mesh.piece_faces():
        styles, counts = np.unique(face_style_ids[faces], return_counts=True)
        piece = submesh(mesh.vertices, mesh.faces[faces])
        pieces.append((int(styles[np.argmax(counts)]), piece_volume_m3(piece), is_solid(piece)))
    open_m3 = sum(volume for _, volume, closed in pieces if not closed)
    closed_m3 = sum(volume for _, volume, closed in pieces if closed)
    scale = 1.0
    if surface_volume_m3 is not None and open_m3 > 0 and surface_volume_m3 >= closed_m3:
        scale = (surface_volume_m3 - closed_m3) / open_m3
    volumes: dict[int, float] = {}
    for style, volume, closed in pieces:
        volumes[style] = volumes.get(style, 0.0) + (volume if closed else volume * scale)
    return volumes


def material_volumes(
    element: ifcopenshell.entity_instance,
    by_style: Mapping[int, float],
    materials_of_styles: Mapping[int, ifcopenshell.entity_instance],
) -> list[tuple[ifcopenshell.entity_instance | None, float]]:
    """(material, m³) of ``element`` from its volumes by style: a style of one of the element's own
    materials counts as that material, any other as None (unknown); empty when fewer than two of its
    materials are found (one material needs no split)."""
    own = {material.id(): material for material in _own_materials(element)}
    volumes: dict[int | None, float] = {}
    for style, volume in by_style.items():
        material = materials_of_styles.get(style)
        key = material.id() if material is not None and material.id() in own else None
        volumes[key] = volumes.get(key, 0.0) + volume
    if sum(1 for key in volumes if key is not None) < 2:
        return []
    return [(own[key] if key is not None else None, volume) for key, volume in volumes.items() if volume > 0]


def _own_materials(element: ifcopenshell.entity_instance) -> list[ifcopenshell.entity_instance]:
    try:
        return list(ifcopenshell.util.element.get_materials(element))
    except (AttributeError, RuntimeError, TypeError):  # malformed material associations
        return []
