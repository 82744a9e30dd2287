"""How the report tells what each component's construction method did: counts by method, the elements split
into panels (built when all their panels are, with the joints between them) and the elements built into
their hosts (constructed with them). Pure, over the report's component entries (:mod:`.report`)."""

from __future__ import annotations

from collections import Counter
from typing import Any

from bimbot.shared.construction_methods import ConstructionMethod
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import ComponentState

CONSTRUCTED = ComponentState.CONSTRUCTED.value


def methods_count(components: list[dict[str, Any]], manifest: Manifest) -> dict[str, dict[str, int]]:
    """Per method: how many components it has and how many were constructed (guests and in-place work
    counted apart, under ``with_host`` and ``in_place``)."""
    total: Counter[str] = Counter(c["method"] for c in components)
    built: Counter[str] = Counter(c["method"] for c in components if c["state"] == CONSTRUCTED)
    states = {c["guid"]: c["state"] for c in components}
    for component in manifest.components:
        for _ in component.guests:
            total[ConstructionMethod.WITH_HOST.value] += 1
            built[ConstructionMethod.WITH_HOST.value] += int(states.get(component.guid) == CONSTRUCTED)
    if manifest.in_place:
        total[ConstructionMethod.IN_PLACE.value] += len(manifest.in_place)
        built[ConstructionMethod.IN_PLACE.value] += len(manifest.in_place)
    return {method: {"components": total[method], "constructed": built[method]} for method in sorted(total)}


def panelised_elements(manifest: Manifest, components: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Each element split into panels: constructed once every panel is, when the last one was."""
    by_guid = {c["guid"]: c for c in components}
    elements = []
    for element in manifest.panelised:
        panels = [by_guid[guid] for guid in element.panel_guids if guid in by_guid]
        done = len(panels) == len(element.panel_guids) and all(p["state"] == CONSTRUCTED for p in panels)
        elements.append(
            {
                "guid": element.guid,
                "name": element.name,
                "ifc_class": element.ifc_class,
                "mass_kg": element.mass_kg,
                "panels": list(element.panel_guids),
                "panels_constructed": sum(p["state"] == CONSTRUCTED for p in panels),
                "constructed": done,
                "constructed_s": max(p["constructed_s"] for p in panels) if done and panels else None,
                "joints": [joint.model_dump(mode="json") for joint in element.joints],
                "why": element.why,
            }
        )
    return elements


def with_host_elements(manifest: Manifest, components: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Each element built into its host, constructed with it."""
    by_guid = {c["guid"]: c for c in components}
    guests = []
    for host in manifest.components:
        entry = by_guid.get(host.guid, {})
        for guest in host.guests:
            guests.append(
                {
                    "guid": guest.guid,
                    "name": guest.name,
                    "ifc_class": guest.ifc_class,
                    "method": ConstructionMethod.WITH_HOST.value,
                    "host_guid": host.guid,
                    "relation": guest.relation,
                    "constructed": entry.get("state") == CONSTRUCTED,
                    "constructed_s": entry.get("constructed_s"),
                }
            )
    return guests
