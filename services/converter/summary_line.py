"""The words of ``bimbot convert``'s summary line: where each IFC element went, and the counts beside it.

Why: a user reads the line against the progress line above it ("919 IFC elements to convert"), and a
count that does not add up reads as lost elements. A panelised wall is one element and nine components;
a bolt built into its footing is an element and no component. So the line says how the elements it
converted became the components it counts (:func:`elements_summary`), counts only the clashes that touch
a placement, as the warning under it does (:func:`clash_summary`), and the methods and skips as before.
Pure functions over the manifest.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence

from bimbot.shared.construction_methods import ConstructionMethod
from bimbot.shared.manifest import JointSource, Manifest, SkippedElement


def elements_summary(manifest: Manifest) -> str:
    """`` from 919 IFC element(s) (701 as one component each, 18 cut into 236 panels in all, 180 built with
    their hosts)``: how the elements converted (the count the progress line gave) became the components to
    build, the parts that apply in that order (and those it read but could not convert); empty when each
    element is one component. Every skip is said after it, with its reason."""
    whole = sum(1 for c in manifest.components if c.parent_guid is None)
    parts = [c for c in manifest.components if c.parent_guid is not None]
    guests = sum(len(c.guests) for c in [*manifest.components, *manifest.in_place])
    in_place = len({c.parent_guid or c.guid for c in manifest.in_place})
    words = [f"{whole:,} as one component each"]
    for method, said in (
        (ConstructionMethod.PANELISED, "cut into {parts:,} panels in all"),
        (ConstructionMethod.CAST_IN_PLACE, "poured in {parts:,} bays"),
        (ConstructionMethod.LAID, "laid in {parts:,} stretches"),
    ):
        split = {element.guid for element in manifest.panelised if element.method is method}
        if split:
            count = sum(1 for c in parts if c.parent_guid in split)
            words.append(f"{len(split):,} " + said.format(parts=count))
    if guests:
        words.append(f"{guests:,} built with their hosts")
    if in_place:
        words.append(f"{in_place:,} in place before the robots come")
    from .selection import selected_out

    not_converted = sum(1 for item in manifest.skipped if not selected_out(item.reason))
    if not_converted:
        words.append(f"{not_converted:,} not converted (skipped, below)")
    if len(words) == 1:
        return ""
    elements = whole + len(manifest.panelised) + guests + in_place + not_converted
    return f" from {elements:,} IFC element(s) ({', '.join(words)})"


def clash_summary(manifest: Manifest) -> str:
    """``8 clash(es) (27 more between two parts in place)``: the clashes a placement meets, as the warning
    under the summary counts them; the pairs of parts in place (no robot places them) said apart."""
    existing = {component.guid for component in manifest.in_place}
    both_in_place = sum(1 for clash in manifest.clashes if set(clash.guids) <= existing)
    built = len(manifest.clashes) - both_in_place
    more = f" ({both_in_place:,} more between two parts in place)" if both_in_place else ""
    return f"{built:,} clash(es){more}"


def framed_summary(manifest: Manifest) -> str:
    """`` (12 of them framed ends)`` when some joints are framed ends drawn butting their part."""
    framed = sum(1 for joint in manifest.joints if joint.source is JointSource.FRAMED)
    return f" ({framed:,} of them framed ends)" if framed else ""


def methods_summary(manifest: Manifest) -> str:
    """``; to be built: 12 lifted, 3 panelised, 2 cast_in_place (and 4 with their hosts)``: the components
    by method, most first; empty for none (not "built:": a trial user read it as built already)."""
    counts = Counter(component.method.value for component in manifest.components)
    if not counts:
        return ""
    ranked = sorted(counts.items(), key=lambda pair: (-pair[1], pair[0]))
    guests = sum(len(component.guests) for component in [*manifest.components, *manifest.in_place])
    with_hosts = f" (and {guests:,} with their hosts)" if guests else ""
    return "; to be built: " + ", ".join(f"{count:,} {method}" for method, count in ranked) + with_hosts


def skipped_summary(skipped: Sequence[SkippedElement], most: int = 4) -> str:
    """`` (35 not a building element (IfcFurnishingElement), 10 feature element (IfcOpeningElement))``:
    the elements left out, counted by the head of their reason, most frequent first; empty for none."""
    from .selection import reason_head

    if not skipped:
        return ""
    counts = Counter(reason_head(item.reason) for item in skipped)
    ranked = sorted(counts.items(), key=lambda pair: (-pair[1], pair[0]))
    parts = [f"{count:,} {head}" for head, count in ranked[:most]]
    if len(ranked) > most:
        parts.append(f"{sum(count for _, count in ranked[most:]):,} for other reasons")
    return f" ({', '.join(parts)})"
