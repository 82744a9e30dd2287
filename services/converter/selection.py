"""Choose which IFC elements become components, and say why every other element is left out.

The rule, as in the paper (building components are what robots assemble):

* **Built by default:** building elements — ``IfcBuildingElement`` in IFC2X3/IFC4, ``IfcBuiltElement`` in
  IFC4X3, with every subclass (walls, slabs, beams, columns, members, plates, footings, windows, doors,
  proxies, …) — their parts (``IfcElementComponent``: plates, fasteners, accessories, building element
  parts) and prefabricated assemblies (``IfcElementAssembly``) that have a body of their own.
* **Left out by default:** furniture (``IfcFurnishingElement``), MEP (``IfcDistributionElement``, and in
  IFC2X3 ``IfcElectricalElement``/``IfcEquipmentElement``), transport, geographic, civil and geotechnical
  elements. ``include`` adds classes back, ``exclude`` takes classes away, ``only`` replaces the default
  rule by a list of classes; all three take subclasses (``IfcWall`` takes ``IfcWallStandardCase``).
  ``exclude`` also takes GlobalIds: single elements left out (one of two that clash in the model).
* **Left out as well:** a proxy (``IfcBuildingElementProxy``) whose UniFormat classification names it
  equipment, furnishings, services or planting, which exports with classes of their own would class as
  above (:mod:`.classified_proxies`: Revit's kitchen equipment and trees); ``--include
  IfcBuildingElementProxy`` builds them.
* **Never built:** feature elements (openings, projections, surface features) and virtual elements; spaces
  and annotations are not ``IfcElement``\\ s at all.
* An element that aggregates parts which are built (a curtain wall of plates and members, a roof of slabs)
  is left out: its parts are the components, building it as well would put its geometry there twice.
  Unless it has a body of its own and its parts are only fittings (fasteners, accessories, plates: a
  column aggregating its base plate): then it is built and they go in with it (``with_host``).

Every ``IfcElement`` that is not chosen comes back as a :class:`Rejection` with a reason a user can act on
(``"not a building element (IfcFurnishingElement); --include IfcFurnishingElement to build it"``), so the
manifest lists it under ``skipped``. A reason starts with a short head (up to the first ``;`` or ``:``)
that :func:`reason_head` returns, for summaries that count elements by reason.

The class tree comes from ifcopenshell's schema API, so the rule holds for IFC2X3, IFC4 and IFC4X3 alike.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import ifcopenshell

from .classified_proxies import proxy_trade
from .method_ifc import is_fitting

BUILDABLE_ROOTS = ("IfcBuildingElement", "IfcBuiltElement", "IfcElementComponent", "IfcElementAssembly")
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


@dataclass(frozen=True)
class ClassRule:
    """Which classes are built: the default building elements (or ``only``), plus ``include``, minus
    ``exclude``. Class names as the schema spells them (:func:`check_classes`)."""

    include: tuple[str, ...] = ()
    exclude: tuple[str, ...] = ()
    only: tuple[str, ...] = ()
    exclude_guids: frozenset[str] = frozenset()  # single elements left out by their GlobalId


def parse_class_list(text: str | None) -> tuple[str, ...]:
    """``"IfcBeam, IfcColumn"`` → ``("IfcBeam", "IfcColumn")``."""
    if not text:
        return ()
    return tuple(part.strip() for part in text.split(",") if part.strip())


def _schema(model: ifcopenshell.file) -> ifcopenshell.ifcopenshell_wrapper.schema_definition:
    return ifcopenshell.ifcopenshell_wrapper.schema_by_name(model.schema_identifier)  # IFC4X3_ADD2, …


def _class_spellings(model: ifcopenshell.file) -> dict[str, str]:
    """Every declaration of the model's schema, lower-case name → the schema's spelling."""
    return {declaration.name().lower(): declaration.name() for declaration in _schema(model).declarations()}


def check_classes(model: ifcopenshell.file, classes: Iterable[str]) -> tuple[str, ...]:
    """Return the classes with the schema's spelling; ``ValueError`` naming any class the schema lacks."""
    known = _class_spellings(model)
    unknown = [name for name in classes if name.lower() not in known]
    if unknown:
        raise ValueError(f"unknown IFC class(es) for {model.schema}: {', '.join(unknown)}")
    return tuple(known[name.lower()] for name in classes)


def check_exclusions(
    model: ifcopenshell.file, names: Iterable[str], option: str = "--exclude"
) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """``--exclude``'s classes (the schema's spelling) and GlobalIds of single elements (one of a clash in
    the IFC, a part a user builds otherwise); ``ValueError`` naming any that is neither a class of the
    schema nor the GlobalId of an element in the model."""
    known = _class_spellings(model)
    classes: list[str] = []
    guids: list[str] = []
    unknown: list[str] = []
    for name in names:
        if name.lower() in known:
            classes.append(known[name.lower()])
        elif _is_element_guid(model, name):
            guids.append(name)
        else:
            unknown.append(name)
    if unknown:
        cut = [name for name in unknown if name and len(name) < 22 and _guids_starting(model, name)]
        hint = ""
        if cut:
            matches = _guids_starting(model, cut[0])
            example = f"'{matches[0]}'" if len(matches) == 1 else "'…$…' (whole, in single quotes)"
            hint = (
                f" ({cut[0]}: the start of {len(matches)} GlobalId(s) with a $ after it, which the shell cut "
                f"off: quote the GlobalId, {option} {example})"
            )
        raise ValueError(
            f"{option}: neither an IFC class of {model.schema} nor the GlobalId of an element in the model: "
            + ", ".join(unknown)
            + hint
        )
    return tuple(classes), tuple(guids)


def check_in_place(
    model: ifcopenshell.file, names: Iterable[str], keyword: str
) -> tuple[bool, tuple[str, ...], list[str]]:
    """``--in-place``'s tokens: whether ``keyword`` (``foundations``) is among them, the GlobalIds of the
    elements named by class or GlobalId, and a warning per class the model has no element of;
    ``ValueError`` as :func:`check_exclusions`, with the keyword's spelling when a token is close to it."""
    names = list(names)
    keyworded = any(name.lower() == keyword for name in names)
    try:
        classes, guids = check_exclusions(model, [n for n in names if n.lower() != keyword], "--in-place")
    except ValueError as error:
        near = any(name.lower().rstrip("s") == keyword.rstrip("s") for name in names)
        raise ValueError(f"{error} (the keyword is '{keyword}')" if near else str(error)) from None
    warnings = [
        f"--in-place {name}: the model has no element of that class"
        for name in classes
        if not model.by_type(name)
    ]
    guids += tuple(str(element.GlobalId) for name in classes for element in model.by_type(name))
    return keyworded, guids, warnings


def _guids_starting(model: ifcopenshell.file, prefix: str) -> list[str]:
    """The GlobalIds of elements that start with ``prefix`` followed by a ``$``: what an unquoted GlobalId
    leaves after the shell expanded ``$…`` to nothing."""
    return sorted(
        str(element.GlobalId)
        for element in model.by_type("IfcElement")
        if element.GlobalId.startswith(prefix) and element.GlobalId[len(prefix) : len(prefix) + 1] == "$"
    )


def _is_element_guid(model: ifcopenshell.file, guid: str) -> bool:
    if len(guid) != 22:
        return False
    try:
        return bool(model.by_guid(guid).is_a("IfcElement"))
    except RuntimeError:  # no instance with that GlobalId
        return False


def buildable_roots(model: ifcopenshell.file) -> tuple[str, ...]:
    """The classes built by default that exist in ``model``'s schema."""
    names = {declaration.name() for declaration in _schema(model).declarations()}
    return tuple(name for name in BUILDABLE_ROOTS if name in names)


def element_category(model: ifcopenshell.file, ifc_class: str) -> str:
    """The class directly below ``IfcElement`` that ``ifc_class`` descends from (``IfcFurniture`` →
    ``IfcFurnishingElement``); ``ifc_class`` itself when it is not an ``IfcElement``."""
    declaration = _schema(model).declaration_by_name(ifc_class)
    # the class of an element is an entity declaration (not a defined, select or enumeration type)
    assert isinstance(declaration, ifcopenshell.ifcopenshell_wrapper.entity), ifc_class
    supertype = declaration.supertype()
    while supertype is not None and supertype.name() != "IfcElement":
        declaration, supertype = supertype, supertype.supertype()
    return declaration.name() if supertype is not None else ifc_class


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


def reason_head(reason: str) -> str:
    """The short head of a skip reason (up to its first ``;`` or ``:``), for counting by reason."""
    return re.split(r"[;:]", reason, maxsplit=1)[0].strip()


SELECTION_HEADS = (
    "virtual element",
    "feature element",
    "left out by --exclude",
    "not in --only",
    "not a building",
)


# every reason :func:`select_elements` gives (the class rule's and the element's own: a duplicate, no
# body, an aggregate whose parts are built), and the parser's damage (taken out with them): an element left
# out before the conversion's count ("N IFC elements to convert") begins
SELECTED_OUT_HEADS = (
    *SELECTION_HEADS,
    "damaged in the file",
    "duplicate GlobalId",
    "no geometry of its own",
    "no representation",
    "no body representation",
    "an aggregate",
)


def selected_out(reason: str) -> bool:
    """Whether a skip ``reason`` is the selection's (:data:`SELECTED_OUT_HEADS`): the element was never
    among those to convert; else it was, and the conversion skipped it (drawn twice, no triangles, …)."""
    return reason.startswith(SELECTED_OUT_HEADS)


def left_out_by_selection(reason: str) -> bool:
    """Whether a skip ``reason`` is the class selection's (:func:`class_rejection`: what the user chose or the
    defaults leave out), not a problem with the element (no geometry, a duplicate GlobalId, …)."""
    return reason.startswith(SELECTION_HEADS)


def class_rejection(
    model: ifcopenshell.file, element: ifcopenshell.entity_instance, rule: ClassRule, roots: Sequence[str]
) -> str | None:
    """Why ``rule`` leaves ``element`` out, or None when its class is built."""
    if any(element.is_a(name) for name in NEVER_COMPONENTS):
        category = element_category(model, element.is_a())
        kind = "virtual element" if category == "IfcVirtualElement" else "feature element"
        return f"{kind} ({element.is_a()}): a void or mark on its host, never built as a component"
    if element.GlobalId in rule.exclude_guids:
        return f"left out by --exclude {element.GlobalId}"
    for name in rule.exclude:
        if element.is_a(name):
            return f"left out by --exclude {name}"
    if any(element.is_a(name) for name in rule.include):
        return None
    if rule.only:
        if any(element.is_a(name) for name in rule.only):
            return None
        return f"not in --only {','.join(rule.only)}; --include {element.is_a()} to build it"
    if any(element.is_a(name) for name in roots):
        return proxy_trade(element)
    category = element_category(model, element.is_a())
    return f"not a building element ({category}); --include {category} to build it"


def select_elements(
    model: ifcopenshell.file,
    include: Sequence[str] = (),
    exclude: Sequence[str] = (),
    only: Sequence[str] = (),
    exclude_guids: Iterable[str] = (),
) -> Selection:
    """Components to convert, in STEP id order, and every other ``IfcElement`` with the reason it is left
    out (see the module docstring for the rule)."""
    rule = ClassRule(tuple(include), tuple(exclude), tuple(only), frozenset(exclude_guids))
    roots = buildable_roots(model)
    candidates: list[ifcopenshell.entity_instance] = []
    rejected: list[Rejection] = []
    seen_guids: dict[str, ifcopenshell.entity_instance] = {}
    for element in sorted(model.by_type("IfcElement"), key=lambda item: item.id()):
        reason = class_rejection(model, element, rule, roots)
        if reason is not None:
            rejected.append(Rejection(element, reason))
            continue
        guid = element.GlobalId
        if guid in seen_guids:
            first = seen_guids[guid]
            rejected.append(
                Rejection(element, f"duplicate GlobalId; already used by #{first.id()} {first.is_a()}")
            )
            continue
        seen_guids[guid] = element
        candidates.append(element)
    with_body = {element.id() for element in candidates if has_body_representation(element)}
    chosen: list[ifcopenshell.entity_instance] = []
    for element in candidates:
        parts = [part for part in _parts(element) if part.id() in with_body]
        if element.id() in with_body and parts and all(is_fitting(part) for part in parts):
            chosen.append(element)  # a member and its fittings: they are built into it
            continue
        built_parts = len(parts)
        if element.id() not in with_body:
            if built_parts:
                reason = f"no geometry of its own; its {built_parts} part(s) are built as components"
            elif element.Representation is None:
                reason = "no representation; nothing to build"
            else:
                reason = "no body representation (only axis, box or footprint)"
            rejected.append(Rejection(element, reason))
        elif built_parts:
            rejected.append(
                Rejection(element, f"an aggregate; its {built_parts} part(s) are built as components instead")
            )
        else:
            chosen.append(element)
    return Selection(tuple(chosen), tuple(rejected))


def _parts(element: ifcopenshell.entity_instance) -> list[ifcopenshell.entity_instance]:
    """Every element ``element`` aggregates, at any depth (IfcRelAggregates / IfcRelDecomposes)."""
    parts: list[ifcopenshell.entity_instance] = []
    stack = [element]
    while stack:
        for relation in getattr(stack.pop(), "IsDecomposedBy", None) or ():
            for part in relation.RelatedObjects or ():
                if part.is_a("IfcElement"):
                    parts.append(part)
                    stack.append(part)
    return parts
