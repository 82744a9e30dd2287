"""What the IFC says about how an element is built, where it says it (``method_source`` ``ifc``).

In the order tried, the first statement wins:

* existing work (``in_place``): ``Pset_*Common.Status`` ``EXISTING`` (IFC4), or Revit's phase
  ``PSet_Revit_Phasing."Phase Created"`` ``Existing`` (the Janesville restaurant is an addition to a
  standing building: 440 of its elements exist);
* an element built into another (``with_host``): fasteners, accessories and reinforcement
  (``IfcFastener``, ``IfcMechanicalFastener``, ``IfcDiscreteAccessory``, ``IfcReinforcingElement``), the
  plates of a steel connection (``IfcPlate`` of a base, flange, web, stiffener, gusset, cover or splice
  predefined type), a part (``IfcBuildingElementPart``) of a built element, and any element aggregated or
  nested into a built element that is not an assembly (a column aggregating its base plate). The host the
  relations name is kept in the decision (:func:`relation_hosts`); the converter checks it once
  everything is built, and finds one by geometry where no relation names one;
* ``Pset_ConcreteElementGeneral.CastingMethod``: ``INSITU`` is cast in place, ``PRECAST`` lifted;
  ``Pset_PrecastConcreteElementGeneral`` (any property) lifted;
* a pile's ``ConstructionType`` (``CAST_IN_PLACE`` is cast; ``PRECAST_CONCRETE``, ``PREFAB_STEEL`` are
  driven) or type (``BORED`` piles are cast, ``DRIVEN`` ones driven);
* a material whose name says it: cast-in-place or in situ, poured (a floor's topping, underlayment or
  screed: cast in place), precast or prefabricated (:mod:`.material_kind`);
* a part of a prefabricated assembly (``IfcElementAssembly``): lifted, but a fitting of it (a plate) goes
  with the assembly's main member (``with_host``).
"""

from __future__ import annotations

from collections.abc import Collection

import ifcopenshell
import ifcopenshell.util.element

from bimbot.shared.construction_methods import ConstructionMethod, MethodDecision, MethodSource
from bimbot.shared.methods_file import MethodsFile

from .material_kind import CAST_IN_PLACE_WORDS, POURED_WORDS, PRECAST_WORDS

GUEST_CLASSES = ("IfcFastener", "IfcMechanicalFastener", "IfcDiscreteAccessory", "IfcReinforcingElement")
CONNECTION_PLATE_TYPES = frozenset(
    {
        "BASE_PLATE",
        "FLANGE_PLATE",
        "WEB_PLATE",
        "STIFFENER_PLATE",
        "GUSSET_PLATE",
        "COVER_PLATE",
        "SPLICE_PLATE",
    }
)
# property sets that state a method or existing work (Pset_*Common's Status is read too)
STATING_PSETS = frozenset(
    {"Pset_ConcreteElementGeneral", "Pset_PrecastConcreteElementGeneral", "PSet_Revit_Phasing"}
)
PILE_CAST = frozenset({"CAST_IN_PLACE", "BORED"})
PILE_DRIVEN = frozenset({"PRECAST_CONCRETE", "PREFAB_STEEL", "DRIVEN"})


def ifc_statement(
    element: ifcopenshell.entity_instance,
    texts: list[str],
    built: Collection[int],
    methods: MethodsFile,
) -> MethodDecision | None:
    """What the IFC says of ``element`` (see the module docstring), or None. ``texts``: its material names
    (:func:`.material_kind.material_texts`); ``built``: the STEP ids of the elements converted."""
    psets = _psets(element)
    if methods.existing_in_place:
        existing = _existing(psets)
        if existing:
            return _ifc(ConstructionMethod.IN_PLACE, existing)
    guest = _guest(element, built)
    if guest is not None:
        return guest
    casting = str(psets.get("Pset_ConcreteElementGeneral", {}).get("CastingMethod") or "").upper()
    if casting == "INSITU":
        return _ifc(ConstructionMethod.CAST_IN_PLACE, "Pset_ConcreteElementGeneral.CastingMethod = INSITU")
    if casting == "PRECAST":
        return _ifc(ConstructionMethod.LIFTED, "Pset_ConcreteElementGeneral.CastingMethod = PRECAST")
    if any(name == "Pset_PrecastConcreteElementGeneral" for name in psets):
        return _ifc(ConstructionMethod.LIFTED, "a precast element (Pset_PrecastConcreteElementGeneral)")
    if element.is_a("IfcPile"):
        pile = _pile(element)
        if pile is not None:
            return pile
    for text in texts:
        if CAST_IN_PLACE_WORDS.search(text):
            return _ifc(ConstructionMethod.CAST_IN_PLACE, f"material {text!r}")
        if POURED_WORDS.search(text):
            return _ifc(ConstructionMethod.CAST_IN_PLACE, f"material {text!r}: poured on the floor beneath")
        if PRECAST_WORDS.search(text):
            return _ifc(ConstructionMethod.LIFTED, f"material {text!r}")
    assembly = ifcopenshell.util.element.get_aggregate(element)
    if assembly is not None and assembly.is_a("IfcElementAssembly"):
        kind = ifcopenshell.util.element.get_predefined_type(assembly)
        what = f" ({kind})" if kind and kind not in ("NOTDEFINED", "USERDEFINED") else ""
        if is_fitting(element):  # a plate of a shop-welded assembly goes with its main member
            return _ifc(ConstructionMethod.WITH_HOST, f"a fitting of the assembly {_named(assembly)}{what}")
        return _ifc(
            ConstructionMethod.LIFTED, f"a part of the prefabricated assembly {_named(assembly)}{what}"
        )
    return None


def relation_hosts(
    element: ifcopenshell.entity_instance, built: Collection[int]
) -> list[tuple[ifcopenshell.entity_instance, str]]:
    """The built elements the IFC relations name as ``element``'s host, with the relation: its aggregate
    or nest parent (not an assembly), the elements of the connection it realises, the element voided by
    the opening it fills, the elements it is connected to, the main members (not fittings) of the
    assembly it is part of; in that order, each once."""
    found = _parents(element, built)
    for rel in getattr(element, "IsConnectionRealization", ()) or ():
        found += [(other, rel.is_a()) for other in (rel.RelatingElement, rel.RelatedElement) if other]
    for fills in getattr(element, "FillsVoids", ()) or ():
        for voids in getattr(fills.RelatingOpeningElement, "VoidsElements", ()) or ():
            found.append((voids.RelatingBuildingElement, "IfcRelFillsElement"))
    for rel in getattr(element, "ConnectedTo", ()) or ():
        found.append((rel.RelatedElement, rel.is_a()))
    for rel in getattr(element, "ConnectedFrom", ()) or ():
        found.append((rel.RelatingElement, rel.is_a()))
    assembly = ifcopenshell.util.element.get_aggregate(element)
    if assembly is not None and assembly.is_a("IfcElementAssembly"):  # its main members, not its fittings
        for part in ifcopenshell.util.element.get_parts(assembly) or ():
            if part.is_a("IfcElement") and not is_fitting(part):
                found.append((part, "IfcRelAggregates"))
    unique: dict[int, tuple[ifcopenshell.entity_instance, str]] = {}
    for other, relation in found:
        if other is not None and other.id() in built and other.id() != element.id():
            unique.setdefault(other.id(), (other, relation))
    return list(unique.values())


def _parents(
    element: ifcopenshell.entity_instance, built: Collection[int]
) -> list[tuple[ifcopenshell.entity_instance, str]]:
    """The built element (not an assembly) ``element`` is aggregated or nested into, with the relation."""
    found = []
    for rel in [*(getattr(element, "Decomposes", ()) or ()), *(getattr(element, "Nests", ()) or ())]:
        parent = rel.RelatingObject
        nested = rel.is_a("IfcRelAggregates") or rel.is_a("IfcRelNests")
        element_parent = parent.is_a("IfcElement") and not parent.is_a("IfcElementAssembly")
        if nested and element_parent and parent.id() in built:
            found.append((parent, rel.is_a()))
    return found


def is_guest_class(element: ifcopenshell.entity_instance) -> bool:
    """A fastener, accessory, reinforcement or connection plate: built into a host, never on its own."""
    if any(element.is_a(name) for name in GUEST_CLASSES):
        return True
    return element.is_a("IfcPlate") and _predefined(element) in CONNECTION_PLATE_TYPES


def is_fitting(element: ifcopenshell.entity_instance) -> bool:
    """A part that an element with a body of its own carries (its fasteners, accessories, plates), so the
    element is built with it rather than left out for its parts: a guest class, or a plate that is not a
    curtain panel or a sheet."""
    if is_guest_class(element):
        return True
    return element.is_a("IfcPlate") and _predefined(element) not in ("CURTAIN_PANEL", "SHEET")


def _guest(element: ifcopenshell.entity_instance, built: Collection[int]) -> MethodDecision | None:
    hosts = relation_hosts(element, built)
    parented = [host for host, _ in _parents(element, built)]
    if is_guest_class(element):
        what = _predefined(element) or element.is_a()
        host, relation = hosts[0] if hosts else (None, "")
        note = f"{element.is_a()} ({what})" if what != element.is_a() else element.is_a()
        if host is not None:
            note += f", built into {_named(host)} ({relation})"
        return _ifc(ConstructionMethod.WITH_HOST, note, host)
    if element.is_a("IfcBuildingElementPart") and parented:
        return _ifc(ConstructionMethod.WITH_HOST, f"a part of {_named(parented[0])}", parented[0])
    if parented:
        return _ifc(ConstructionMethod.WITH_HOST, f"aggregated into {_named(parented[0])}", parented[0])
    return None


def _existing(psets: dict[str, dict[str, object]]) -> str | None:
    for name, props in psets.items():
        status = props.get("Status")
        values = status if isinstance(status, list | tuple) else [status]
        if name.startswith("Pset_") and name.endswith("Common") and "EXISTING" in map(str, values):
            return f"existing work ({name}.Status = EXISTING)"
    phase = psets.get("PSet_Revit_Phasing", {}).get("Phase Created")
    if isinstance(phase, str) and phase.strip().lower() == "existing":
        return "existing work (Revit phase created: Existing)"
    return None


def _pile(element: ifcopenshell.entity_instance) -> MethodDecision | None:
    for attribute in ("ConstructionType", "PredefinedType"):
        value = str(getattr(element, attribute, None) or "")
        if value in PILE_CAST:
            return _ifc(ConstructionMethod.CAST_IN_PLACE, f"IfcPile.{attribute} = {value}")
        if value in PILE_DRIVEN:
            return _ifc(ConstructionMethod.DRIVEN, f"IfcPile.{attribute} = {value}")
    return None


def _psets(element: ifcopenshell.entity_instance) -> dict[str, dict[str, object]]:
    """The property sets that may state a method (:data:`STATING_PSETS`, ``Pset_*Common``), name → property
    → value (an enumeration's values as a list); the element's own over its type's. Reading only these is
    5 times faster than ``get_psets`` on the Revit restaurant, whose elements carry eight sets each."""
    definitions = []
    element_type = ifcopenshell.util.element.get_type(element)
    if element_type is not None:
        definitions += list(getattr(element_type, "HasPropertySets", None) or ())
    for rel in getattr(element, "IsDefinedBy", ()) or ():
        if rel.is_a("IfcRelDefinesByProperties"):
            definitions.append(rel.RelatingPropertyDefinition)
    found: dict[str, dict[str, object]] = {}
    for definition in definitions:
        if definition is None or not definition.is_a("IfcPropertySet"):
            continue
        name = str(definition.Name or "")
        if name not in STATING_PSETS and not (name.startswith("Pset_") and name.endswith("Common")):
            continue
        values = found.setdefault(name, {})
        for prop in definition.HasProperties or ():
            if prop.is_a("IfcPropertySingleValue") and prop.NominalValue is not None:
                values[str(prop.Name)] = prop.NominalValue.wrappedValue
            elif prop.is_a("IfcPropertyEnumeratedValue"):
                values[str(prop.Name)] = [value.wrappedValue for value in prop.EnumerationValues or ()]
    return found


def _predefined(element: ifcopenshell.entity_instance) -> str | None:
    value = ifcopenshell.util.element.get_predefined_type(element)
    return str(value) if value else None


def _named(element: ifcopenshell.entity_instance) -> str:
    name = f" {element.Name!r}" if element.Name else ""
    return f"{element.is_a()}{name} ({element.GlobalId})"


def _ifc(
    method: ConstructionMethod, note: str, host: ifcopenshell.entity_instance | None = None
) -> MethodDecision:
    return MethodDecision(
        method=method, source=MethodSource.IFC, note=note, host_guid=host.GlobalId if host else None
    )
