"""Split one building element out of an IFC model into a standalone IFC file (paper §4.3.1).

Every smart component carries its own ``<GUID>.ifc``: a valid IFC file of the source's schema that holds
exactly that one element and the context needed to read it on its own. The file is built with
ifcopenshell's entity copying (``ifcopenshell.file.add``, which copies an instance with everything it
references and, within one target file, copies each source instance only once), never by copying STEP text.

What comes along:

* the header's author, organisation, originating system, authorisation and time stamp (kept from the source,
  so splitting is deterministic), the source's view definitions, and a description naming the source;
* the IfcProject with its units, representation contexts and map conversion (IFC4 georeferencing), and
  the spatial chain that holds the element (e.g. storey → building → site → project, or through a space),
  each with its own placement, attributes and property sets but without its shape (a site's terrain is no
  context a component needs), joined by the source's IfcRelAggregates (same GlobalId) cut to the chain;
* the element itself: same GlobalId, class, name, placement chain and representation;
* the relationships that point at a kept object (the element, its type, its openings, the chain):
  IfcRelContainedInSpatialStructure, IfcRelAggregates, IfcRelDefines (property sets, quantities, type),
  IfcRelAssociates (material, classification, documents …) and IfcRelVoidsElement. Each keeps its GlobalId
  and attributes, but every list of objects in it is cut down to the kept objects (which attributes name
  objects is read from the schema; the kept members of a list are found from the inverse side, so a list
  of 10,000 contained elements is never walked). A relationship that needs an object which is not kept
  (the whole of an assembly, a window filling an opening, a connected wall) is left out, so no other
  building element is ever pulled in;
* the element's type with its property sets and representation maps;
* its openings (IfcOpeningElement through IfcRelVoidsElement), as features of the element, so its
  geometry keeps its voids and its volume equals the source's; fillings (doors, windows) do not come along;
* the material's property sets (IfcMaterialProperties) and styling (IfcMaterialDefinitionRepresentation),
  which reference the material rather than being referenced by it;
* the surface styles (IfcStyledItem, IFC4 colour and texture maps) of the representation items.

What does not: other building elements, fillings, connections, nested ports, groups, systems, tasks,
presentation layers, space boundaries, type declarations (IfcRelDeclares) and the wholes of assemblies.

Parts and hosted elements: an element that is a part of an assembly, nested in a host or filling an
opening reaches the spatial structure only through its host. Its file holds the chain of the host's
container but not the host, and a new IfcRelContainedInSpatialStructure (GlobalId derived from the
element's GlobalId) contains the element directly in that container. Its placement chain is unchanged: it
may still be relative to the host's IfcLocalPlacement, which is copied as a placement, not as an object.
"""

from __future__ import annotations

import functools
import logging
import re
import uuid
from collections.abc import Iterable, Iterator, Mapping
from typing import Any, cast

import ifcopenshell
import ifcopenshell.guid
import ifcopenshell.ifcopenshell_wrapper
import ifcopenshell.util.element
import ifcopenshell.util.schema

logger = logging.getLogger(__name__)

Entity = ifcopenshell.entity_instance

#: Relationship classes (and their subclasses) re-created in a split file when they involve a kept object.
COPIED_RELATIONSHIPS: tuple[str, ...] = (
    "IfcRelAggregates",
    "IfcRelContainedInSpatialStructure",
    "IfcRelDefines",
    "IfcRelAssociates",
    "IfcRelVoidsElement",
)
#: Resources that reference a material (found through the material's inverse attributes).
MATERIAL_ANNOTATIONS: tuple[str, ...] = ("IfcMaterialProperties", "IfcMaterialDefinitionRepresentation")
#: Resources that reference a representation item to style it.
ITEM_STYLES: tuple[str, ...] = ("IfcStyledItem", "IfcIndexedColourMap", "IfcIndexedTextureMap")
#: Resources that reference a representation context (IFC4 georeferencing: IfcMapConversion).
CONTEXT_OPERATIONS: tuple[str, ...] = ("IfcCoordinateOperation",)
#: Namespace of the GlobalIds bimbot derives for relationships it has to create.
GUID_NAMESPACE = uuid.UUID("6f2d1b0e-3c1a-5b7e-9a55-b1b0b07c0de5")


def split_element(
    model: ifcopenshell.file, element: Entity, *, chains: dict[int, list[Entity]] | None = None
) -> ifcopenshell.file:
    """Return a new IFC file (same schema as ``model``) that holds ``element`` alone in its spatial chain.

    Pure: nothing is read or written on disk; write the result with ``new.write(path)`` or its
    ``to_string()``. ``chains`` (kept by the caller across elements of one model) remembers the spatial
    chain above each parent, which elements of a storey share.
    """
    # The annotation allows only the general names (IFC4X3), but file() keeps any full identifier as given
    # (IFC4X3_ADD2, IFC2X3_TC1), which the split file must repeat.
    new = ifcopenshell.file(schema=cast(ifcopenshell.util.schema.IFC_SCHEMA, model.schema_identifier))
    copy_header(model, new, element)
    chain = spatial_chain(model, element, chains)
    chain_ids = {spatial.id() for spatial in chain}
    kept = kept_objects(element, chain)
    copies = {obj.id(): copy_object(new, obj, with_shape=obj.id() not in chain_ids) for obj in kept}
    copied = copy_relationships(model, new, kept, copies)
    if not is_spatial(element):
        contain_through_host(new, element, chain, copies)
    materials = [rel.RelatingMaterial for rel in copied if rel.is_a("IfcRelAssociatesMaterial")]
    copy_referencing(model, new, material_definitions(model, materials), MATERIAL_ANNOTATIONS)
    shaped = [obj for obj in kept if obj.id() not in chain_ids]
    copy_referencing(model, new, [item for obj in shaped for item in representation_items(obj)], ITEM_STYLES)
    copy_referencing(model, new, representation_contexts(kept), CONTEXT_OPERATIONS)
    logger.debug("split %s %s with %d relationships", element.is_a(), element.GlobalId, len(copied))
    return new


def copy_header(model: ifcopenshell.file, new: ifcopenshell.file, element: Entity) -> None:
    """Copy the source header's authorship fields and describe the split file as made by bimbot."""
    source_name, target_name = model.header.file_name, new.header.file_name
    target_name.name = f"{element.GlobalId}.ifc"
    if source_name.time_stamp:
        target_name.time_stamp = source_name.time_stamp
    target_name.author = source_name.author
    target_name.organization = source_name.organization
    target_name.originating_system = source_name.originating_system
    target_name.authorization = source_name.authorization
    target_name.preprocessor_version = f"IfcOpenShell {ifcopenshell.version} (bimbot split_ifc)"
    source_file = re.split(r"[\\/]", source_name.name or "")[-1] or "an unnamed IFC file"
    source_description = model.header.file_description
    view_definitions = tuple(text for text in source_description.description if text)
    new.header.file_description.description = (
        *(view_definitions or new.header.file_description.description),
        f"Split by bimbot from {source_file}: {element.is_a()} {element.GlobalId}",
    )
    new.header.file_description.implementation_level = source_description.implementation_level


def is_spatial(obj: Entity) -> bool:
    """Whether ``obj`` is part of the spatial structure (project, site, building, storey, space, …)."""
    return obj.is_a("IfcProject") or obj.is_a("IfcSpatialStructureElement") or obj.is_a("IfcSpatialElement")


def spatial_chain(
    model: ifcopenshell.file, element: Entity, chains: dict[int, list[Entity]] | None = None
) -> list[Entity]:
    """Spatial objects from the element's (possibly indirect) container up to the IfcProject, in that order.

    Hosts on the way (the whole of an assembly, a nest host, an opening and the element it voids) are
    skipped. The project is appended even when the chain does not reach it, since every file needs one.
    ``chains``: a cache by the element's parent (the chain depends only on it, when the element is not
    its own ancestor).
    """
    node = ifcopenshell.util.element.get_parent(element)
    if chains is not None and node is not None and node.id() in chains:
        return list(chains[node.id()])
    chain: list[Entity] = []
    seen = {element.id()}
    parent_id = node.id() if node is not None else None
    while node is not None and node.id() not in seen:
        seen.add(node.id())
        if is_spatial(node):
            chain.append(node)
        node = ifcopenshell.util.element.get_parent(node)
    cycle = node is not None  # the walk came back to the element: its chain is its own, not cached
    if not (chain and chain[-1].is_a("IfcProject")):
        chain.extend(model.by_type("IfcProject")[:1])
    if chains is not None and parent_id is not None and not cycle:
        chains[parent_id] = list(chain)
    return chain


def kept_objects(element: Entity, chain: list[Entity]) -> list[Entity]:
    """The objects a split file holds, top-down: the chain, the element, its type and its openings."""
    kept = [*reversed(chain), element]
    element_type = ifcopenshell.util.element.get_type(element)
    if element_type is not None and element_type != element:
        kept.append(element_type)
    kept.extend(rel.RelatedOpeningElement for rel in getattr(element, "HasOpenings", None) or ())
    return kept


def copy_object(new: ifcopenshell.file, obj: Entity, with_shape: bool = True) -> Entity:
    """Copy a kept object, without its representation unless ``with_shape``.

    The spatial chain comes without shape: its placements are kept (the element's placement chain runs
    through them), but a site's terrain or a space's volume is no context a component needs, and can be
    far larger than the component.
    """
    if with_shape or getattr(obj, "Representation", None) is None:
        return new.add(obj)
    names = obj.get_attribute_names()
    values = [
        None if name == "Representation" else copied_resource(new, obj[i], {}) for i, name in enumerate(names)
    ]
    return new.create_entity(obj.is_a(), *values)


#: A relationship and, per attribute index, the kept objects that attribute names.
Reference = tuple[Entity, dict[int, list[Entity]]]


def copy_relationships(
    model: ifcopenshell.file, new: ifcopenshell.file, kept: list[Entity], copies: Mapping[int, Entity]
) -> list[Entity]:
    """Re-create, restricted to the kept objects, every relationship of a copied class that can be; return
    the source relationships that were copied."""
    copied = []
    for rel, kept_by_index in related_relationships(model, kept).values():
        values = restricted_attributes(model.schema_identifier, rel, kept_by_index)
        if values is not None:
            new.create_entity(rel.is_a(), *(copied_resource(new, value, copies) for value in values))
            copied.append(rel)
    return copied


def related_relationships(model: ifcopenshell.file, objects: Iterable[Entity]) -> dict[int, Reference]:
    """Relationships of the copied classes that name any of ``objects``, by id in file order, each with the
    kept objects it names per attribute (from the inverse side, so long lists of others are never read)."""
    found: dict[int, Reference] = {}
    for obj in objects:
        for inverse, index in model.get_inverse(obj, allow_duplicate=True, with_attribute_indices=True):
            if any(inverse.is_a(ifc_class) for ifc_class in COPIED_RELATIONSHIPS):
                named = found.setdefault(inverse.id(), (inverse, {}))[1].setdefault(index, [])
                if all(other.id() != obj.id() for other in named):
                    named.append(obj)
    return {rel_id: found[rel_id] for rel_id in sorted(found)}


def _is_subtype(declaration: Any, ancestor: Any) -> bool:
    while declaration is not None:
        if declaration.name() == ancestor.name():
            return True
        declaration = declaration.supertype()
    return False


def _may_hold_object(parameter_type: Any, target: Any) -> bool:
    """Whether an attribute of this schema type can hold an IfcObjectDefinition (``target``)."""
    if (aggregation := parameter_type.as_aggregation_type()) is not None:
        return _may_hold_object(aggregation.type_of_element(), target)
    if (named := parameter_type.as_named_type()) is None:
        return False
    declaration = named.declared_type()
    if (select := declaration.as_select_type()) is not None:
        return any(
            member.as_entity() is not None and _declares_object(member.as_entity(), target)
            for member in select.select_list()
        )
    return declaration.as_entity() is not None and _declares_object(declaration.as_entity(), target)


def _declares_object(entity: Any, target: Any) -> bool:
    return _is_subtype(entity, target) or _is_subtype(target, entity)  # IFC2X3 relates "IfcRoot"s


@functools.cache
def object_attributes(schema: str, rel_class: str) -> dict[int, bool]:
    """Attributes of ``rel_class`` that name objects, per the schema: index → whether it holds a list."""
    declarations = ifcopenshell.ifcopenshell_wrapper.schema_by_name(schema)
    target = declarations.declaration_by_name("IfcObjectDefinition")
    relationship = declarations.declaration_by_name(rel_class)
    # a relationship class is an entity declaration (not a defined, select or enumeration type)
    assert isinstance(relationship, ifcopenshell.ifcopenshell_wrapper.entity), rel_class
    attributes = relationship.all_attributes()
    return {
        index: attribute.type_of_attribute().as_aggregation_type() is not None
        for index, attribute in enumerate(attributes)
        if _may_hold_object(attribute.type_of_attribute(), target)
    }


def restricted_attributes(
    schema: str, rel: Entity, kept_by_index: Mapping[int, list[Entity]]
) -> list[object] | None:
    """``rel``'s attribute values with each list of objects cut down to the kept objects it names.

    None when the relationship names an object that is not kept, or a list none of whose objects is kept
    (object lists are mandatory in every relationship class copied). Object lists are not read: the kept
    objects in them are known from the inverse side.
    """
    object_indices = object_attributes(schema, rel.is_a())
    values: list[object] = []
    for index in range(len(rel)):
        kept = kept_by_index.get(index, [])
        if index not in object_indices:
            values.append(rel[index])
        elif object_indices[index]:
            if not kept:
                return None
            values.append(tuple(kept))
        elif kept:
            values.append(kept[0])
        elif rel[index] is None:
            values.append(None)
        else:
            return None
    return values


def copied_resource(new: ifcopenshell.file, value: object, copies: Mapping[int, Entity]) -> object:
    """``value`` in ``new``: kept objects map to their copies, other instances are added (once) by ``add``."""
    if isinstance(value, ifcopenshell.entity_instance):
        copy = copies.get(value.id())
        return new.add(value) if copy is None else copy
    if isinstance(value, tuple):
        return tuple(copied_resource(new, member, copies) for member in value)
    return value


def derived_guid(guid: str, purpose: str) -> str:
    """A GlobalId derived reproducibly from ``guid`` for a relationship bimbot creates for ``purpose``."""
    return ifcopenshell.guid.compress(uuid.uuid5(GUID_NAMESPACE, f"{guid}/{purpose}").hex)


def contain_through_host(
    new: ifcopenshell.file, element: Entity, chain: list[Entity], copies: Mapping[int, Entity]
) -> Entity | None:
    """Contain the copied element directly in its first spatial container if it reaches that container
    only through a host (an assembly, a nest, a voided element); return the new relationship, if any."""
    containers = [spatial for spatial in chain if not spatial.is_a("IfcProject")]
    if not containers:
        logger.warning("%s %s is in no spatial structure", element.is_a(), element.GlobalId)
        return None
    if ifcopenshell.util.element.get_container(element, should_get_direct=True) is not None:
        return None
    return new.create_entity(
        "IfcRelContainedInSpatialStructure",
        GlobalId=derived_guid(element.GlobalId, "contained-in-structure"),
        OwnerHistory=new.add(element.OwnerHistory) if element.OwnerHistory is not None else None,
        Name="bimbot split: contained through its host",
        RelatedElements=[copies[element.id()]],
        RelatingStructure=copies[containers[0].id()],
    )


def material_definitions(model: ifcopenshell.file, materials: Iterable[Entity]) -> list[Entity]:
    """Every material and material set reached from the given material selects (usages, sets, layers …)."""
    found: dict[int, Entity] = {}
    for material in materials:
        for resource in model.traverse(material):
            if resource.is_a("IfcMaterial") or resource.is_a("IfcMaterialDefinition"):
                found[resource.id()] = resource
    return list(found.values())


def representation_contexts(objects: Iterable[Entity]) -> list[Entity]:
    """The representation contexts of the IfcProject among ``objects``."""
    return [
        context for obj in objects if obj.is_a("IfcProject") for context in obj.RepresentationContexts or ()
    ]


def _representations(obj: Entity) -> list[Entity]:
    if getattr(obj, "Representation", None) is not None:
        return list(obj.Representation.Representations)
    return [source.MappedRepresentation for source in getattr(obj, "RepresentationMaps", None) or ()]


def representation_items(obj: Entity) -> Iterator[Entity]:
    """Top-level representation items of a product or type, through mapped items and boolean operands."""
    pending = [item for representation in _representations(obj) for item in representation.Items]
    seen: set[int] = set()
    while pending:
        item = pending.pop()
        if item.id() in seen:
            continue
        seen.add(item.id())
        yield item
        if item.is_a("IfcMappedItem"):
            pending.extend(item.MappingSource.MappedRepresentation.Items)
        elif item.is_a("IfcBooleanResult"):
            pending.extend(
                operand
                for operand in (item.FirstOperand, item.SecondOperand)
                if operand.is_a("IfcRepresentationItem")
            )


def copy_referencing(
    model: ifcopenshell.file, new: ifcopenshell.file, targets: Iterable[Entity], classes: tuple[str, ...]
) -> None:
    """Copy the instances of ``classes`` that reference any of ``targets``, which ``add`` cannot reach.

    A style references its item, a material property set its material, a map conversion its context.
    """
    for target in targets:
        for inverse in model.get_inverse(target):
            if any(inverse.is_a(ifc_class) for ifc_class in classes):
                new.add(inverse)
