"""Tessellate the selected elements with ifcopenshell, each in its own frame, identical geometry once.

Settings: ``use-world-coords`` off, so vertices come in the element's object-placement frame, in metres
(ifcopenshell converts IFC length units), and the shape's transformation is that placement, also in
metres. ifcopenshell's iterator already shares one tessellation between elements whose representations
map the same geometry (``shape.geometry.id``); :class:`Tessellation` keeps that sharing so every later
step (meshes, mass properties, convex decomposition) runs once per distinct geometry.

Elements the iterator does not return (curve-only welds, unsupported representations) and those whose
tessellation has no triangles are reported with the reason ifcopenshell gives when asked for that element
alone, so one bad element never stops a conversion.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import cast

import ifcopenshell
import ifcopenshell.geom
import ifcopenshell.util.shape
import numpy as np
from ifcopenshell import ifcopenshell_wrapper

_log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Geometry:
    """One distinct tessellation in its element frame: vertices in metres, triangles as vertex indices."""

    geometry_id: str
    vertices_local_m: np.ndarray
    faces: np.ndarray
    # per face, the STEP id of its surface style (-1: none); empty when the geometry has one style or none
    face_style_ids: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))


@dataclass(frozen=True)
class ElementShape:
    step_id: int
    placement_world_m: np.ndarray  # 4×4, element frame → IFC world frame, metres
    geometry: Geometry


@dataclass
class Tessellation:
    shapes: dict[int, ElementShape] = field(default_factory=dict)
    failures: dict[int, str] = field(default_factory=dict)

    @property
    def geometries(self) -> dict[str, Geometry]:
        return {shape.geometry.geometry_id: shape.geometry for shape in self.shapes.values()}


def geometry_settings() -> ifcopenshell.geom.settings:
    """The settings every bimbot tessellation uses (the benchmark uses them too)."""
    settings = ifcopenshell.geom.settings()
    settings.set("use-world-coords", False)
    settings.set("weld-vertices", True)
    return settings


def default_threads() -> int:
    return max(1, os.cpu_count() or 1)


def tessellate(
    model: ifcopenshell.file,
    elements: Sequence[ifcopenshell.entity_instance],
    *,
    threads: int | None = None,
) -> Tessellation:
    """Tessellate ``elements`` with ``threads`` iterator threads (default: all cores)."""
    result = Tessellation()
    if not elements:
        return result
    settings = geometry_settings()
    cache: dict[str, Geometry] = {}
    iterator = ifcopenshell.geom.iterator(
        settings, model, threads or default_threads(), include=list(elements)
    )
    if iterator.initialize():
        while True:
            shape = iterator.get()
            element_shape = _element_shape(shape, cache)
            if element_shape is not None:
                result.shapes[element_shape.step_id] = element_shape
            if not iterator.next():
                break
    for element in elements:
        if element.id() not in result.shapes:
            result.failures[element.id()] = _failure_reason(settings, element)
    return result


def _element_shape(
    shape: ifcopenshell_wrapper.triangulation_element, cache: dict[str, Geometry]
) -> ElementShape | None:
    """``shape``: what the iterator yields with :func:`geometry_settings` (triangles, no OpenCascade)."""
    geometry_id = str(shape.geometry.id)
    geometry = cache.get(geometry_id)
    if geometry is None:
        faces = ifcopenshell.util.shape.get_faces(shape.geometry)
        if len(faces) == 0:
            return None
        vertices = ifcopenshell.util.shape.get_vertices(shape.geometry)
        geometry = Geometry(
            geometry_id,
            np.ascontiguousarray(vertices, float),
            np.ascontiguousarray(faces, np.int64),
            _face_style_ids(shape.geometry, len(faces)),
        )
        cache[geometry_id] = geometry
    matrix = np.asarray(ifcopenshell.util.shape.get_shape_matrix(shape), dtype=np.float64)
    return ElementShape(int(shape.id), matrix, geometry)


def _face_style_ids(geometry: ifcopenshell_wrapper.triangulation, face_count: int) -> np.ndarray:
    """Per face, the STEP id of its surface style (-1: none), when the faces have two styles or more (a
    window of glass, wood and stone: :mod:`.face_materials` weighs each with its material); else empty."""
    styles = list(geometry.materials)
    if len(styles) < 2:
        return np.zeros(0, dtype=np.int64)
    indices = np.asarray(ifcopenshell.util.shape.get_faces_material_style_ids(geometry), dtype=np.int64)
    if len(indices) != face_count:
        return np.zeros(0, dtype=np.int64)
    ids = np.array([int(style.instance_id()) for style in styles] + [-1], dtype=np.int64)
    return ids[indices]  # index -1 (no style) picks the trailing -1


def _failure_reason(settings: ifcopenshell.geom.settings, element: ifcopenshell.entity_instance) -> str:
    """Why ifcopenshell gives no triangles for this element, in one line."""
    try:
        shape = ifcopenshell.geom.create_shape(settings, element)
    except RuntimeError as error:
        first_line = str(error).splitlines()[0] if str(error) else "unknown error"
        return f"no triangulated geometry: ifcopenshell could not build it ({_shorten(first_line)})"
    # create_shape is annotated with what every kind of input gives; a product with these settings gives a
    # triangulation_element, whose geometry is a triangulation
    geometry = cast(ifcopenshell_wrapper.triangulation, getattr(shape, "geometry", shape))
    if len(ifcopenshell.util.shape.get_faces(geometry)) == 0:
        edges = len(ifcopenshell.util.shape.get_edges(geometry)) if hasattr(geometry, "edges") else 0
        kind = "curve-only" if edges else "empty"
        return f"no triangulated geometry: {kind} representation cannot be meshed"
    return "no triangulated geometry returned by the ifcopenshell iterator"


def _shorten(text: str, limit: int = 160) -> str:
    return text if len(text) <= limit else text[: limit - 1] + "…"
