"""An element's relationships to other elements, for the manifest (and the support graph).

Collected: IfcRelConnectsElements and its subtypes (IfcRelConnectsPathElements,
IfcRelConnectsWithRealizingElements), in both directions; the elements that *realise* a connection
(fasteners, welds) and the connections they realise; aggregation (the assembly an element is part of,
and its parts); and hosting: a window or door that fills an opening of a wall (IfcRelFillsElement →
IfcOpeningElement → IfcRelVoidsElement) names the wall (role ``filling``) and the wall names it (``host``),
so the support graph puts the window after its wall.
"""

from __future__ import annotations

import ifcopenshell

from bimbot.shared.manifest import Connection


def element_connections(element: ifcopenshell.entity_instance) -> list[Connection]:
    found: list[Connection] = []
    for rel in getattr(element, "ConnectedTo", ()) or ():  # this element is RelatingElement
        found.append(_connection(rel, "relating", rel.RelatedElement))
    for rel in getattr(element, "ConnectedFrom", ()) or ():  # this element is RelatedElement
        found.append(_connection(rel, "related", rel.RelatingElement))
    for rel in getattr(element, "IsConnectionRealization", ()) or ():
        found.extend(
            _connection(rel, "realizing", other) for other in (rel.RelatingElement, rel.RelatedElement)
        )
    for rel in [*(getattr(element, "ConnectedTo", ()) or ()), *(getattr(element, "ConnectedFrom", ()) or ())]:
        if rel.is_a("IfcRelConnectsWithRealizingElements"):
            found.extend(_connection(rel, "realized_by", other) for other in rel.RealizingElements or ())
    for rel in getattr(element, "Decomposes", ()) or ():
        if rel.is_a("IfcRelAggregates"):
            found.append(_connection(rel, "aggregate_child", rel.RelatingObject))
    for rel in getattr(element, "IsDecomposedBy", ()) or ():
        if rel.is_a("IfcRelAggregates"):
            found.extend(_connection(rel, "aggregate_parent", other) for other in rel.RelatedObjects or ())
    found.extend(_hosting(element))
    return [item for item in found if item.other_guid]


def _hosting(element: ifcopenshell.entity_instance) -> list[Connection]:
    """Filling ↔ host through the opening between them (the opening itself is never a component)."""
    found: list[Connection] = []
    for fills in getattr(element, "FillsVoids", ()) or ():  # this element fills an opening
        opening = fills.RelatingOpeningElement
        for voids in getattr(opening, "VoidsElements", ()) or ():
            found.append(_connection(fills, "filling", voids.RelatingBuildingElement))
    for voids in getattr(element, "HasOpenings", ()) or ():  # this element hosts openings
        for fills in getattr(voids.RelatedOpeningElement, "HasFillings", ()) or ():
            found.append(_connection(fills, "host", fills.RelatedBuildingElement))
    return found


def _connection(
    rel: ifcopenshell.entity_instance, role: str, other: ifcopenshell.entity_instance | None
) -> Connection:
    return Connection(
        relation=rel.is_a(),
        role=role,
        other_guid=getattr(other, "GlobalId", None) or "",
        other_class=other.is_a() if other is not None else "",
    )
