"""A cast-in-place element's work: its formwork area and volume from its mesh, its times from the rates.

Formwork is needed on the sides and the soffit, never on the top (the concrete's free surface, screeded):
a face counts by the direction of its normal in the world frame, up within ``TOP_FACE_COS`` of vertical
being the top, down within it the soffit. An element whose target lies in the ground is cast on the soil
(or blinding), and a poured topping, underlayment or screed (:func:`.material_kind.is_poured`) on the floor
beneath it: their soffits need no form. Times: formwork area over the crew's formwork rate, the pour's
setup plus the volume over the pour rate, and the cure until what rests on it may be placed, at the rates
of the element's ``cast_in_place.by_class`` entry (:func:`rates_class`; else the general ones).
"""

from __future__ import annotations

import ifcopenshell
import ifcopenshell.util.element
import numpy as np

from bimbot.shared.construction_methods import CastWork
from bimbot.shared.methods_file import CastInPlace

from .material_kind import is_poured, material_texts
from .mesh import TriMesh

TOP_FACE_COS = 0.7  # a face whose normal is within ~45° of vertical is a top (up) or a soffit (down)
HOUR_S = 3600.0


def formwork_area_m2(mesh: TriMesh, rotation: np.ndarray, *, on_base: bool) -> float:
    """Area of the faces of ``mesh`` (element frame; ``rotation`` to the world) that need formwork;
    ``on_base``: cast on the soil or a floor, so its soffit needs none."""
    if len(mesh.faces) == 0:
        return 0.0
    up = (mesh.face_normals @ np.asarray(rotation, dtype=float).T)[:, 2]
    formed = up < TOP_FACE_COS
    if on_base:
        formed &= up > -TOP_FACE_COS
    return float(mesh.area_faces[formed].sum())


GROUND_SLAB = "IfcSlab.BASESLAB"


def rates_class(
    element: ifcopenshell.entity_instance, rates: CastInPlace, *, in_ground: bool = False
) -> str | None:
    """The ``by_class`` key of ``element``'s rates: the first ``Class.PREDEFINED_TYPE`` it is, else the first
    class it is an instance of (with subclasses); None for the general rates. A slab that lies in the ground
    (``in_ground``) is a ground slab whatever its predefined type (Revit's house types its ground floor
    ``FLOOR``): edge forms, no decking to strike, as the ground slab's rates say."""
    if in_ground and element.is_a("IfcSlab") and GROUND_SLAB in rates.by_class:
        return GROUND_SLAB
    predefined = str(ifcopenshell.util.element.get_predefined_type(element) or "").upper()
    typed = [name for name in rates.by_class if "." in name]
    for name in typed:
        ifc_class, kind = name.split(".", 1)
        if kind == predefined and element.is_a(ifc_class):
            return name
    return next((name for name in rates.by_class if "." not in name and element.is_a(name)), None)


def cast_work(
    element: ifcopenshell.entity_instance,
    mesh: TriMesh,
    rotation: np.ndarray,
    volume_m3: float,
    rates: CastInPlace,
    *,
    in_ground: bool,
) -> CastWork:
    """The :class:`CastWork` of ``element`` (its welded mesh in its own frame, ``rotation`` to the world)."""
    on_base = in_ground or is_poured(material_texts(element))
    area = formwork_area_m2(mesh, rotation, on_base=on_base)
    formwork_rate, pour_rate, setup_h, cure_h = rates.rates(rates_class(element, rates, in_ground=in_ground))
    return CastWork(
        formwork_area_m2=area,
        volume_m3=volume_m3,
        formwork_s=area / formwork_rate * HOUR_S,
        pour_s=(setup_h + volume_m3 / pour_rate) * HOUR_S,
        cure_s=cure_h * HOUR_S,
    )
