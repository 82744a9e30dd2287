"""The host of each ``with_host`` component: the element it is built into (pure, over the manifest entries).

Candidates are the elements the IFC relations name (:func:`.method_ifc.relation_hosts`: the aggregate or
nest it belongs to, the connection it realises, the element whose opening it fills, the elements it is
connected to) and every component whose bounding box meets the guest's (within ``CONTACT_M``). The best
candidate is, in this order of preference: one the guest is embedded in (``EMBEDDED_SHARE`` of the guest's
box inside the candidate's: an anchor bolt in its footing, a cleat within a beam's depth); one of the
material a guest of its kind is fixed to (steel for plates, fasteners and accessories, so a base plate
goes with the column it is welded to, not the footing it bears on; concrete for reinforcement); one that
is not itself a guest; one the relations name; the largest overlap. A guest whose best host is a guest
goes with that one's host. A guest without a host stays a lifted component (the caller warns).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import ifcopenshell
import numpy as np

from bimbot.shared.construction_methods import ConstructionMethod
from bimbot.shared.manifest import Component
from bimbot.shared.methods_file import MaterialKind

from .material_kind import kind_of
from .method_ifc import relation_hosts

CONTACT_M = 0.005  # boxes this close touch (a plate drawn on a column's end, a bolt through a plate)
EMBEDDED_SHARE = 0.5  # of the guest's box inside the host's: embedded


@dataclass(frozen=True)
class Hosting:
    host_guid: str
    relation: str  # the IFC relationship that named the host, or "embedded" / "contact"


def find_hosts(
    model: ifcopenshell.file, components: Sequence[Component]
) -> tuple[dict[str, Hosting], dict[str, str]]:
    """(guest GlobalId → its hosting, guest GlobalId → why none was found) for the ``with_host``
    components among ``components``."""
    by_guid = {component.guid: component for component in components}
    guests = [component for component in components if component.method is ConstructionMethod.WITH_HOST]
    if not guests:
        return {}, {}
    built = {step for step in (_step_id(model, guid) for guid in by_guid) if step is not None}
    boxes = np.array([[c.bbox_world.min_m, c.bbox_world.max_m] for c in components], dtype=float)
    guest_guids = {guest.guid for guest in guests}
    first: dict[str, Hosting] = {}
    missing: dict[str, str] = {}
    for guest in guests:
        element = model.by_guid(guest.guid)
        named = {
            other.GlobalId: relation
            for other, relation in relation_hosts(element, built)
            if other.GlobalId in by_guid
        }
        box = np.array([guest.bbox_world.min_m, guest.bbox_world.max_m], dtype=float)
        touching = _touching(box, boxes)
        candidates = {components[i].guid for i in touching} | set(named)
        candidates.discard(guest.guid)
        if not candidates:
            missing[guest.guid] = "no IFC relation names a converted element and it touches none"
            continue
        prefer = _preferred_kind(element)
        scores = {
            guid: _score(box, by_guid[guid], prefer, not_guest=guid not in guest_guids, named=guid in named)
            for guid in candidates
        }
        best = max(sorted(candidates), key=scores.__getitem__)
        embedded = scores[best][0] > 0
        first[guest.guid] = Hosting(best, named.get(best) or ("embedded" if embedded else "contact"))
    return _through_guests(first, guest_guids, missing), missing


def _through_guests(
    first: dict[str, Hosting], guests: set[str], missing: dict[str, str]
) -> dict[str, Hosting]:
    """Each guest's host followed through hosts that are guests themselves, to one that is not."""
    final: dict[str, Hosting] = {}
    for guest, hosting in first.items():
        seen = {guest}
        host = hosting.host_guid
        while host in guests and host in first and host not in seen:
            seen.add(host)
            host = first[host].host_guid
        if host in guests:
            missing[guest] = f"its host {hosting.host_guid} is built into nothing that is built"
            continue
        final[guest] = Hosting(host, hosting.relation)
    return final


def _score(
    box: np.ndarray, other: Component, prefer: MaterialKind, *, not_guest: bool, named: bool
) -> tuple[float, ...]:
    """The rank of ``other`` as the host of a guest whose box is ``box`` (higher is better; the order is
    the module docstring's)."""
    share = _share_inside(box, np.array([other.bbox_world.min_m, other.bbox_world.max_m]))
    return (
        float(share >= EMBEDDED_SHARE),
        float(kind_of(other.material or "") is prefer),
        float(not_guest),
        float(named),
        share,
    )


def _preferred_kind(element: ifcopenshell.entity_instance) -> MaterialKind:
    return MaterialKind.CONCRETE if element.is_a("IfcReinforcingElement") else MaterialKind.STEEL


def _touching(box: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """Indices of ``boxes`` (n, 2, 3) that meet ``box`` (2, 3) within ``CONTACT_M``."""
    meets = (boxes[:, 0] <= box[1] + CONTACT_M) & (boxes[:, 1] >= box[0] - CONTACT_M)
    return np.flatnonzero(meets.all(axis=1))


def _share_inside(box: np.ndarray, other: np.ndarray) -> float:
    """The share of ``box``'s volume inside ``other`` (flat boxes: of its area or length)."""
    size = box[1] - box[0]
    overlap = np.minimum(box[1], other[1]) - np.maximum(box[0], other[0])
    flat = size < 1e-6
    per_axis = np.where(flat, overlap >= 0, np.clip(overlap, 0.0, None) / np.where(flat, 1.0, size))
    return float(np.prod(per_axis))


def _step_id(model: ifcopenshell.file, guid: str) -> int | None:
    try:
        return int(model.by_guid(guid).id())
    except RuntimeError:  # not a GlobalId of this model (a panel's own id)
        return None
