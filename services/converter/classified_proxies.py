"""Proxies whose classification names them as what IFC leaves out of a building: equipment, services, plants,
and entourage.

Why: an authoring tool exports a family with no IFC class of its own as ``IfcBuildingElementProxy``. Revit
does so with kitchen equipment, sinks and urinals, and trees; it keeps their UniFormat code in the type's
"Assembly Code" (the Revit restaurant's walk-in refrigerator: ``E1090330`` "Food Service - Walk-in
Refrigerators"). The same objects exported with their own classes are furniture, distribution elements or
geographic elements, which the converter leaves out by default (:mod:`.selection`): they are installed by
their vendor or trade once the building stands, not built by its robots. A proxy whose UniFormat code
says so is left out the same way. Read: ``IfcClassificationReference``\\ s of a UniFormat classification
(the element's, then its type's), then an "Assembly Code" property (Revit's).

Without a UniFormat code, the authoring tool's own category says the same: Revit exports its category as
the standard ``Pset_ProductRequirements.Category`` (and in its "Other" set). A proxy of a category Revit
keeps for equipment, devices, fixtures, furniture or planting (the public Revit office from ifc-mcp: 13
fridge and freezer fronts of "Electrical Equipment", 8 wall displays of "Communication Devices", lifts,
cook tops and solar panels of "Specialty Equipment"; the public Revit basic house's cook top and
refrigerators) is what IFC classes as a distribution element or furniture, and is left out as those are.
"Generic Models" says nothing and is built.

Older Revit exports state no category. There the family's parameters still tell: Revit gives the "Electrical
- Loads" group (``Panel``, ``Circuit Number``) to families of the categories that take an electrical
connector, equipment and fixtures, not to walls, floors or generic models. In the four Revit models at hand
every proxy that carries it is equipment: the office's fridge fronts, displays, lifts and solar panels (their
category says so too), the basic house's cook top and refrigerators, and the restaurant's ranges, fryer,
toilet partitions, sign and fire-extinguisher cabinet (the last two drawn 305 mm into each other; the run
failed the cabinet "unstable" after its third try). A proxy with no category and that group is left out as
equipment.

A marker is not built either: SketchUp's IFC-manager exports a model's coordination origin (a 1 m cube)
and its geo-reference point as proxies of a material named ``virtual_white`` and ``virtual_black`` (ifc-mcp's
Building-Structural: the cube was "lifted" by the crane, the point "cast in place" 30 m off the building).

Entourage too: the people, cars and plants an architect places for renderings are no part of the building.
Revit draws them with ArchVision's RPC content and exports them as proxies whose "Render Appearance"
property names the RPC item (``RPC-8-…``; the restaurant's "RPC Male" and "RPC Female" figures, flat
billboards of no volume). A proxy with such an appearance and no UniFormat code is left out as entourage.
"""

from __future__ import annotations

import re

import ifcopenshell
import ifcopenshell.util.classification
import ifcopenshell.util.element

# UniFormat II groups whose elements IFC does not class as building elements, and what they are
LEFT_OUT_GROUPS: tuple[tuple[str, str], ...] = (
    ("D", "services"),  # conveying, plumbing, HVAC, fire protection, electrical
    ("E10", "equipment"),
    ("E20", "furnishings"),
    ("G2050", "landscaping"),
)
# Revit categories whose elements IFC classes as distribution elements, furniture or geography, and what
# they are (the exporter's own classes for them: flow terminals, electric appliances, furniture)
LEFT_OUT_CATEGORIES: dict[str, str] = {
    **{
        name: "services"
        for name in (
            "Electrical Equipment",
            "Electrical Fixtures",
            "Mechanical Equipment",
            "Plumbing Fixtures",
            "Lighting Fixtures",
            "Lighting Devices",
            "Communication Devices",
            "Data Devices",
            "Fire Alarm Devices",
            "Security Devices",
            "Nurse Call Devices",
            "Telephone Devices",
            "Sprinklers",
            "Air Terminals",
        )
    },
    **{name: "equipment" for name in ("Specialty Equipment", "Food Service Equipment", "Medical Equipment")},
    **{name: "furnishings" for name in ("Furniture", "Furniture Systems", "Casework")},
    "Planting": "landscaping",
}  # fmt: skip (entourage: by its render appearance below, whatever its category)
CATEGORY_PROPERTY = "Category"  # Pset_ProductRequirements.Category (IFC's), Revit's "Other" set too
UNIFORMAT_CODE = re.compile(r"^[A-G]\d{0,8}$")
CODE_PROPERTY = "Assembly Code"  # Revit's UniFormat code of a type
DESCRIPTION_PROPERTY = "Assembly Description"
RENDER_PROPERTY = "Render Appearance"  # Revit's render appearance of a type: an RPC item's id for entourage
ELECTRICAL_LOADS_SET = "Electrical - Loads"  # a Revit group, exported as "PSet_Revit_Electrical - Loads"
ELECTRICAL_LOADS_PROPERTIES = ("Panel", "Circuit Number")
RPC_ITEM = re.compile(r"^RPC-[0-9A-Z]+(-[0-9A-Z]+)*$", re.IGNORECASE)


def proxy_trade(element: ifcopenshell.entity_instance) -> str | None:
    """For a proxy classified in a group of :data:`LEFT_OUT_GROUPS`, of a category in
    :data:`LEFT_OUT_CATEGORIES`, of no category but Revit's electrical loads, a marker, or unclassified and
    rendered as RPC entourage, the reason it is left out (a :mod:`.selection` reason: its head is "not a
    building element (…)"); None for anything else."""
    if not element.is_a("IfcBuildingElementProxy"):
        return None
    virtual = virtual_material(element)
    if virtual is not None:
        return (
            f"not a building element (a marker); its material {virtual!r} is virtual: "
            f"{element.Description or element.ObjectType or 'a reference point of the model'}; --include "
            "IfcBuildingElementProxy to build it"
        )
    found = uniformat_code(element)
    if found is None:
        category = revit_category(element)
        if category in LEFT_OUT_CATEGORIES:
            kind = LEFT_OUT_CATEGORIES[category]
            return (
                f"not a building element (a proxy classified as {kind}); its category {category!r}, "
                "installed by its vendor or trade, not built by the robots; --include "
                "IfcBuildingElementProxy to build it"
            )
        if category is None and electrical_loads(element):
            return (
                "not a building element (a proxy of an equipment family); it carries Revit's "
                f"{ELECTRICAL_LOADS_SET!r} parameters ({', '.join(ELECTRICAL_LOADS_PROPERTIES)}), which "
                "Revit gives to equipment and fixtures, installed by their vendor or trade, not built by the "
                "robots; --include IfcBuildingElementProxy to build it"
            )
        rpc = rpc_item(element)
        if rpc is None:
            return None
        return (
            f"not a building element (entourage); rendered as {rpc} of ArchVision's RPC content, a person, "
            "vehicle or plant drawn for renderings, not built by the robots; --include "
            "IfcBuildingElementProxy to build it"
        )
    code, description = found
    what = next((kind for group, kind in LEFT_OUT_GROUPS if code.startswith(group)), None)
    if what is None:
        return None
    named = f" {description!r}" if description else ""
    return (
        f"not a building element (a proxy classified as {what}); UniFormat {code}{named}, installed by "
        "its vendor or trade, not built by the robots; --include IfcBuildingElementProxy to build it"
    )


def uniformat_code(element: ifcopenshell.entity_instance) -> tuple[str, str] | None:
    """(code, description) of the element's UniFormat classification, or None."""
    for reference in _references(element):
        source = _source_name(reference)
        code = getattr(reference, "Identification", None) or getattr(reference, "ItemReference", None)
        code = str(code or "").strip().upper()
        if "uniformat" in source.lower() and UNIFORMAT_CODE.match(code):
            return code, str(reference.Name or "")
    code, description = _assembly_code(element)
    if code and UNIFORMAT_CODE.match(code):
        return code, description
    return None


def virtual_material(element: ifcopenshell.entity_instance) -> str | None:
    """The name of the element's material when every material it has is named as virtual (``virtual_white``:
    SketchUp's IFC-manager draws a model's coordination origin and geo-reference point as proxies of such a
    material), else None."""
    names = [
        str(material.Name or "")
        for material in ifcopenshell.util.element.get_materials(element)
        if material.is_a("IfcMaterial")
    ]
    if names and all(name.lower().startswith("virtual") for name in names):
        return names[0]
    return None


def revit_category(element: ifcopenshell.entity_instance) -> str | None:
    """The element's category as its authoring tool exported it: ``Pset_ProductRequirements.Category``,
    else a "Category" property of any of its (or its type's) property sets; None when it states none."""
    properties = ifcopenshell.util.element.get_psets(element, psets_only=True)
    standard = (properties.get("Pset_ProductRequirements") or {}).get(CATEGORY_PROPERTY)
    if standard:
        return str(standard).strip()
    for values in properties.values():
        value = values.get(CATEGORY_PROPERTY)
        if value:
            return str(value).strip()
    return None


def electrical_loads(element: ifcopenshell.entity_instance) -> bool:
    """Whether a property set of the element (or its type) is Revit's "Electrical - Loads" group with its
    ``Panel`` or ``Circuit Number`` parameter."""
    for name, values in ifcopenshell.util.element.get_psets(element, psets_only=True).items():
        if name.removeprefix("PSet_Revit_").strip() != ELECTRICAL_LOADS_SET:
            continue
        if any(prop in values for prop in ELECTRICAL_LOADS_PROPERTIES):
            return True
    return False


def rpc_item(element: ifcopenshell.entity_instance) -> str | None:
    """The RPC item an entourage proxy is rendered as (its "Render Appearance", element's or type's), or
    None."""
    for properties in ifcopenshell.util.element.get_psets(element, psets_only=True).values():
        value = str(properties.get(RENDER_PROPERTY) or "").strip()
        if RPC_ITEM.match(value):
            return value
    return None


def _references(element: ifcopenshell.entity_instance) -> list[ifcopenshell.entity_instance]:
    found = list(ifcopenshell.util.classification.get_references(element))
    element_type = ifcopenshell.util.element.get_type(element)
    if element_type is not None:
        found += ifcopenshell.util.classification.get_references(element_type)
    return found


def _source_name(reference: ifcopenshell.entity_instance) -> str:
    source = getattr(reference, "ReferencedSource", None)
    if source is None:
        return ""
    return str(getattr(source, "Name", None) or "")


def _assembly_code(element: ifcopenshell.entity_instance) -> tuple[str, str]:
    """Revit's "Assembly Code" and "Assembly Description" from any property set of the element or its
    type (upper-cased code; empty strings when absent)."""
    values: dict[str, str] = {}
    for properties in ifcopenshell.util.element.get_psets(element, psets_only=True).values():
        for name in (CODE_PROPERTY, DESCRIPTION_PROPERTY):
            value = properties.get(name)
            if value and name not in values:
                values[name] = str(value).strip()
    return values.get(CODE_PROPERTY, "").upper(), values.get(DESCRIPTION_PROPERTY, "")
