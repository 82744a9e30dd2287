"""Elements the model draws twice: the same class, place and shape under two GlobalIds.

Exporters repeat elements: Revit writes a door of a curtain wall once inside the wall's aggregation and once
more on its own, at the same place. A site builds it once. Left in, the second copy is set into the first,
physics pushes the two apart, and everything that rests on it waits for a component that cannot be built.
So of each group of elements that coincide (same IFC class, world bounding boxes within
:data:`SAME_PLACE_M`, volumes within :data:`SAME_VOLUME_FRACTION`), one is kept: the one the IFC relates to
most (its aggregation, its host), then the lower GlobalId. The others are skipped with the kept one's name.
Panels of a panelised element are never compared (their parent is).
"""

from __future__ import annotations

from collections import defaultdict

import numpy as np

from bimbot.shared.identifiers import named_guid
from bimbot.shared.manifest import Component, SkippedElement

SAME_PLACE_M = 0.001
SAME_VOLUME_FRACTION = 0.005


def drop_duplicates(components: list[Component]) -> tuple[list[Component], list[SkippedElement]]:
    """(``components`` without the repeated copies, a skipped entry for each copy dropped)."""
    groups: dict[tuple[str, tuple[int, ...]], list[Component]] = defaultdict(list)
    for component in components:
        if component.parent_guid is None:
            box = (*component.bbox_world.min_m, *component.bbox_world.max_m)
            groups[component.ifc_class, tuple(np.round(np.asarray(box) / SAME_PLACE_M).astype(int))].append(
                component
            )
    dropped: dict[str, tuple[Component, Component]] = {}  # copy's GlobalId → (the copy, the one kept)
    for members in groups.values():
        if len(members) < 2:
            continue
        members.sort(key=lambda item: (-len(item.connections), item.guid))
        for copy in members[1:]:
            kept = next((item for item in members if item.guid not in dropped and _same(item, copy)), None)
            if kept is not None and kept is not copy:
                dropped[copy.guid] = (copy, kept)
    skipped = [
        SkippedElement(
            guid=copy.guid,
            ifc_class=copy.ifc_class,
            name=copy.name,
            reason=(
                "the model draws it twice: same class, place and shape as "
                f"{named_guid(kept.guid, kept.name)}, which is built (a site builds it once)"
            ),
        )
        for copy, kept in dropped.values()
    ]
    return [item for item in components if item.guid not in dropped], skipped


def _same(a: Component, b: Component) -> bool:
    """Same place (bounding boxes within :data:`SAME_PLACE_M`) and volume (within the fraction)."""
    boxes = np.abs(
        np.subtract((*a.bbox_world.min_m, *a.bbox_world.max_m), (*b.bbox_world.min_m, *b.bbox_world.max_m))
    )
    same_volume = abs(a.volume_m3 - b.volume_m3) <= SAME_VOLUME_FRACTION * max(a.volume_m3, b.volume_m3)
    return bool(np.all(boxes <= SAME_PLACE_M)) and same_volume
