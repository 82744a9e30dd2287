"""Choose which IFC elements become components.

By default every ``IfcElement`` with a body representation (columns, beams, members, plates, slabs, walls,
footings, fasteners, …) is a component; feature elements (openings, projections, surface features),
virtual elements, spaces and annotations never are (spaces and annotations are not ``IfcElement``s).
``include``/``exclude`` lists of IFC classes narrow that down, with subclasses (``IfcWall`` takes
``IfcWallStandardCase``). Elements that are left out for a reason a user should see come back as
:class:`Rejection`\\ s so the manifest can list them under ``skipped``.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import ifcopenshell

NEVER_COMPONENTS = ("IfcFeatureElement", "IfcVirtualElement")
BODY_IDENTIFIERS = frozenset({"Body", "Facetation", "Brep", "SweptSolid", "Body-FallBack"})


@dataclass(frozen=True)
class Rejection:
    element: ifcopenshell.entity_instance
    reason: str


@dataclass(frozen=True)
class Selection:
    elements: tuple[ifcopenshell.entity_instance, ...]
    rejected: tuple[Rejection, ...]


def parse_class_list(text: str | None) -> tuple[str, ...]:
    """``"IfcBeam, IfcColumn"`` → ``("IfcBeam", "IfcColumn")``."""
    if not text:
        return ()
    return tuple(part.strip() for part in text.split(",") if part.strip())


def check_classes(model: ifcopenshell.file, classes: Iterable[str]) -> tuple[str, ...]:
    """Return the classes with the schema's spelling; ``ValueError`` naming any class the schema lacks."""
    schema = ifcopenshell.ifcopenshell_wrapper.schema_by_name(model.schema)
    known = {declaration.name().lower(): declaration.name() for declaration in schema.declarations()}
    unknown = [name for name in classes if name.lower() not in known]
    if unknown:
        raise ValueError(f"unknown IFC class(es) for {model.schema}: {', '.join(unknown)}")
    return tuple(known[name.lower()] for name in classes)


def has_body_representation(element: ifcopenshell.entity_instance) -> bool:
    """True when the element has a 3D shape representation meant as its body (not only an axis or a box)."""
    product_shape = element.Representation
    if product_shape is None:
        return False
    for representation in product_shape.Representations or ():
        if not representation.is_a("IfcShapeRepresentation"):
            continue
        identifier = representation.RepresentationIdentifier
        if identifier in BODY_IDENTIFIERS:
            return True
        context = representation.ContextOfItems
        if identifier is None and getattr(context, "ContextType", None) in ("Model", "Design", None):
            return True
    return False


def select_elements(
    model: ifcopenshell.file, include: Sequence[str] = (), exclude: Sequence[str] = ()
) -> Selection:
    """Components to convert, in STEP id order, and the elements left out with a reason worth reporting."""
    chosen: list[ifcopenshell.entity_instance] = []
    rejected: list[Rejection] = []
    seen_guids: dict[str, ifcopenshell.entity_instance] = {}
    for element in sorted(model.by_type("IfcElement"), key=lambda item: item.id()):
        if any(element.is_a(name) for name in NEVER_COMPONENTS):
            continue
        if include and not any(element.is_a(name) for name in include):
            continue
        if exclude and any(element.is_a(name) for name in exclude):
            continue
        if not has_body_representation(element):
            if element.Representation is not None:
                rejected.append(Rejection(element, "no body representation (only axis, box or footprint)"))
            continue
        guid = element.GlobalId
        if guid in seen_guids:
            first = seen_guids[guid]
            rejected.append(
                Rejection(element, f"duplicate GlobalId, already used by #{first.id()} {first.is_a()}")
            )
            continue
        seen_guids[guid] = element
        chosen.append(element)
    return Selection(tuple(chosen), tuple(rejected))
