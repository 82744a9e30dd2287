"""The IFC relationships of a panelised element, passed on to the panels that carry them.

A wall split into panels is no component, but the IFC still relates it: the window in its opening, the
wall it meets at its end. Each such connection is passed on to the panels that touch the other component
(bounding boxes within ``CONTACT_TOLERANCE_M``), and a panel keeps, of its element's connections, those to
the components it touches. For the window in an opening the host is the panels around the opening that stand
no higher than the window (a panel of the storey above that rests on the window's head is no host: the
window is set before it), so the support graph (:mod:`bimbot.shared.support_graph`), whose other edges run
from a lower bottom to a higher one, stays without cycles.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from bimbot.shared.construction_methods import PanelisedElement
from bimbot.shared.manifest import Component, Connection
from bimbot.shared.support_graph import CONNECTION_RELATIONS, CONTACT_TOLERANCE_M, HOSTING_RELATION

_PLACED_RELATIONS = (*CONNECTION_RELATIONS, HOSTING_RELATION)  # relations that say where parts meet


def link_panels(
    components: Sequence[Component],
    panelised: Sequence[PanelisedElement],
    tolerance_m: float = CONTACT_TOLERANCE_M,
) -> list[Component]:
    """``components`` with connections to panelised elements passed on to their panels (see the module)."""
    panels_of = {entry.guid: entry.panel_guids for entry in panelised}
    if not panels_of:
        return list(components)
    boxes = {c.guid: (np.array(c.bbox_world.min_m), np.array(c.bbox_world.max_m)) for c in components}

    def touch(a: str, b: str) -> bool:
        (low_a, high_a), (low_b, high_b) = boxes[a], boxes[b]
        return bool(np.all(low_a <= high_b + tolerance_m) and np.all(low_b <= high_a + tolerance_m))

    linked = []
    for component in components:
        connections: list[Connection] = []
        for connection in component.connections:
            other = connection.other_guid
            placed = connection.relation in _PLACED_RELATIONS
            if other in panels_of:
                panels = [p for p in panels_of[other] if p in boxes and p != component.guid]
                if connection.role == "filling":
                    bottom = boxes[component.guid][0][2] + tolerance_m
                    hosts = [p for p in panels if boxes[p][0][2] <= bottom]
                    panels = [p for p in hosts if touch(component.guid, p)] or hosts
                elif placed:
                    panels = [p for p in panels if touch(component.guid, p)]
                connections.extend(connection.model_copy(update={"other_guid": p}) for p in panels)
            elif component.parent_guid and placed and other in boxes and not touch(component.guid, other):
                continue  # a panel keeps its element's connections to what it touches
            else:
                connections.append(connection)
        changed = connections != component.connections
        linked.append(component.model_copy(update={"connections": connections}) if changed else component)
    return linked
