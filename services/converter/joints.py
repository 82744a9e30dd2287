"""Joints and clashes: every pair of components the model draws into each other, told apart.

An overlap deeper than a contact (:mod:`.overlaps` measures them at the BIM targets) is a **joint** when

* the IFC relates the two (:data:`RELATIONS`: connected, realising a connection, a filling in its host's
  opening, an assembly and its part; the parts of an assembly that is no component share its relations,
  such as a curtain wall's panels in the wall it fills or meets), or
* a rule of the joint settings (:mod:`bimbot.shared.joints`) fits: one is the rule's member, the other its
  part, the overlap is no deeper than the rule's ``max_depth_m`` and, for an ``at_end`` rule, lies at one
  end or face of the member (within that depth of it, along an axis on which the member is longer than
  twice that): a member's end in what it bears on, not two members crossing through each other.

* one of the two is cast in place: its concrete is poured around the other where they meet (a beam's
  end in a pocket of a cast wall, a precast stair set on a cast landing), so the cast one is the part the
  other is set into.

A member's end drawn butting the part it frames into (no deeper than a contact) or a little short of it is a
**framed joint** when a rule gives an erection clearance (``clearance_m``) and the contact or gap lies at
the member's end within it: steel is fabricated short of a drawn butt and bolted through clearance holes,
so the part's own erection error is taken in that gap, not by pushing the member off its target.

A new component drawn into **existing work** (in place before the robots come) no deeper than
:data:`FITTED_MAX_DEPTH_M` is fitted to it on site (a notch cut, the new part scribed): a joint, the existing
part first (a Revit renovation draws its new fittings into the existing slabs and walls by a few cm). So is
a new part rising from below whose top is drawn up into the existing part over it, up to
:data:`FITTED_UNDER_MAX_DEPTH_M` (a partition drawn to the top of the existing beam it is framed up to).

A thin **deck drawn through an upright** that passes through it (a post through a roof plank) is cut round
it on site (:mod:`.notches`): a joint, the upright first.

Last, a **fitting** rule (``fitting = true``): a light board, sheet or open frame drawn into a heavier part
is made to it on site (a railing's infill cut to its parapet, a screen scribed between its piers): a joint,
the heavier part first. It comes after the others so that what the drawing says (a deck cut round the
railing passing up through it) decides first.

Any other overlap deeper than :data:`~bimbot.shared.joints.CLASH_DEPTH_M` is a **clash**: two parts that
cannot both be where the model puts them. The manifest keeps both lists; physics lets a jointed pair overlap
and connects them, and still reports a clash.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import ifcopenshell
import ifcopenshell.ifcopenshell_wrapper
import numpy as np

from bimbot.shared.construction_methods import ConstructionMethod
from bimbot.shared.joints import CLASH_DEPTH_M, JointRule, JointSettings
from bimbot.shared.manifest import Clash, Component, Joint, JointSource

from .bars import BarShapes
from .connections import element_connections
from .notches import element_plans_m2, notched_round
from .overlap_shapes import END_TOLERANCE_M, at_an_end, carried_through, embedded_along, plan_run_m
from .overlaps import Overlap, measure_overlaps

_log = logging.getLogger(__name__)

FITTED_MAX_DEPTH_M = 0.15  # a new part drawn this deep into existing work is fitted on site (notched)
# a new part rising from below into existing work over it, its top drawn up to this far above the existing
# part's underside (a deep beam: a W24 is 610 mm), is framed up to that underside on site
FITTED_UNDER_MAX_DEPTH_M = 0.65
FILLS = "IfcRelFillsElement"
RELATIONS = frozenset(
    {
        "IfcRelConnectsElements",
        "IfcRelConnectsPathElements",
        "IfcRelConnectsWithRealizingElements",
        FILLS,
        "IfcRelAggregates",
    }
)
DIRECTED_ROLES = {"filling": False, "host": True, "realizing": False, "realized_by": True}


@dataclass(frozen=True)
class Relation:
    """How the IFC relates two components: ``first`` is the part the other is set into when ``directed``."""

    first: str
    second: str
    relation: str
    directed: bool


@dataclass(frozen=True)
class JointsFound:
    joints: list[Joint]
    clashes: list[Clash]


def find_joints(
    model: ifcopenshell.file, components: Sequence[Component], out_dir: Path, settings: JointSettings
) -> JointsFound:
    """The joints and clashes among ``components`` (the built and those in place), whose collision parts
    the converter wrote under ``out_dir``."""
    classes = _ClassTree(model)
    overlaps = measure_overlaps(components, out_dir, settings.contact_m)
    joints = _framed_ends(components, out_dir, settings, classes, {(o.first, o.second) for o in overlaps})
    if not overlaps:
        return JointsFound(joints, [])
    by_guid = {component.guid: component for component in components}
    related = relations(model, components)
    bars = BarShapes(out_dir)
    element_plans = element_plans_m2(components)
    # a fitting rule is the last word: what the drawing itself says (a joint's usual drawing, a pour round
    # it, existing work, a deck cut round an upright) decides first
    drawn_rules = [rule for rule in settings.rule if not rule.fitting]
    fitting_rules = [rule for rule in settings.rule if rule.fitting]
    clashes: list[Clash] = []
    for overlap in overlaps:
        relation = related.get(frozenset((overlap.first, overlap.second)))
        if relation is not None:
            related_joint = Joint(
                guids=(relation.first, relation.second),
                depth_m=round(overlap.depth_m, 4),
                source=JointSource.RELATION,
                rule=relation.relation,
                directed=relation.directed,
            )
            joints.append(_with_bottoms(related_joint, overlap))
            continue
        first, second = by_guid[overlap.first], by_guid[overlap.second]
        joint = _by_rule(overlap, first, second, drawn_rules, classes, bars=bars)
        joint = joint or _cast_around(overlap, first, second) or _fitted_to_existing(overlap, first, second)
        joint = joint or notched_round(overlap, first, second, element_plans)
        joint = joint or _by_rule(overlap, first, second, fitting_rules, classes, bars=bars)
        if joint is not None:
            joints.append(_with_bottoms(joint, overlap))
        elif overlap.depth_m > CLASH_DEPTH_M:
            clashes.append(Clash(guids=(overlap.first, overlap.second), depth_m=round(overlap.depth_m, 4)))
    clashes.sort(key=lambda clash: (-clash.depth_m, clash.guids))
    return JointsFound(joints, clashes)


def _framed_ends(
    components: Sequence[Component],
    out_dir: Path,
    settings: JointSettings,
    classes: _ClassTree,
    overlapping: set[tuple[str, str]],
) -> list[Joint]:
    """The framed joints among ``components``: pairs drawn butting (no deeper than a contact) or apart by no
    more than the erection clearance of a rule whose member and part they are, at the member's end.
    ``overlapping`` (GUID pairs, sorted) are the deeper overlaps, judged by the other rules."""
    reach_m = settings.framed_reach_m
    framed_rules = [rule for rule in settings.rule if rule.clearance_m > 0.0]
    if reach_m <= 0.0:
        return []
    classes_named = {name for rule in framed_rules for name in (*rule.member, *rule.part)}
    steel = [c for c in components if classes.matching(c.ifc_class, tuple(classes_named)) is not None]
    by_guid = {component.guid: component for component in steel}
    joints: list[Joint] = []
    for contact in measure_overlaps(steel, out_dir, -reach_m):
        if (contact.first, contact.second) in overlapping or contact.depth_m > settings.contact_m:
            continue
        a, b = by_guid[contact.first], by_guid[contact.second]
        joint = _framed_by_rule(contact, a, b, framed_rules, classes)
        if joint is not None:
            joints.append(joint)
    _log.debug("%d framed end(s) drawn butting or within the erection clearance", len(joints))
    return joints


def _framed_by_rule(
    contact: Overlap, a: Component, b: Component, rules: Iterable[JointRule], classes: _ClassTree
) -> Joint | None:
    """The framed joint the first fitting rule makes of a butt or gap (either way round), or None."""
    for rule, member, part, member_class, part_class in _fitting(rules, a, b, classes):
        if -contact.depth_m > rule.clearance_m:
            continue
        if not at_an_end(member, contact.region_m, rule.clearance_m + END_TOLERANCE_M, length_only=True):
            continue
        return Joint(
            guids=(part.guid, member.guid),
            depth_m=round(max(0.0, contact.depth_m), 4),
            source=JointSource.FRAMED,
            rule=rule.describe_framed(member_class, part_class),
            clearance_m=rule.clearance_m,
        )
    return None


def relations(model: ifcopenshell.file, components: Sequence[Component]) -> dict[frozenset[str], Relation]:
    """Pairs of ``components`` the IFC relates (:data:`RELATIONS`), each pair once: a filling's host
    relation wins over the others, since it says which is set into which."""
    guids = {component.guid for component in components}
    found: dict[frozenset[str], Relation] = {}

    def add(relation: Relation) -> None:
        key = frozenset((relation.first, relation.second))
        if len(key) == 2 and key <= guids and (key not in found or relation.directed > found[key].directed):
            found[key] = relation

    parents: dict[str, list[str]] = {}
    for component in components:
        for link in component.connections:
            if link.relation not in RELATIONS:
                continue
            if link.relation == "IfcRelAggregates" and link.role == "aggregate_child":
                parents.setdefault(link.other_guid, []).append(component.guid)
            add(_relation(component.guid, link.other_guid, link.relation, link.role))
    for parent, children in parents.items():  # an assembly's parts share its relations (a curtain wall's)
        element = None if parent in guids else _by_guid(model, parent)
        if element is None:
            continue
        for link in element_connections(element):
            if link.relation in RELATIONS and link.relation != "IfcRelAggregates":
                by_its = f"{link.relation} (by its {element.is_a()})"
                for child in children:
                    relation = _relation(child, link.other_guid, link.relation, link.role)
                    add(Relation(relation.first, relation.second, by_its, relation.directed))
    return found


def _with_bottoms(joint: Joint, overlap: Overlap) -> Joint:
    """``joint`` with how low each of its components reaches right under the overlap (its order's height)."""
    first, second = overlap.bottoms_under_m()
    bottoms = (first, second) if joint.guids[0] == overlap.first else (second, first)
    return joint.model_copy(update={"bottoms_at_joint_m": bottoms})


def _relation(guid: str, other: str, relation: str, role: str) -> Relation:
    """The relation seen from ``guid`` with its ``role``, the part first where the role says which."""
    if role in DIRECTED_ROLES:
        first_is_self = DIRECTED_ROLES[role]
        return Relation(guid if first_is_self else other, other if first_is_self else guid, relation, True)
    first_is_self = role in ("relating", "aggregate_parent")
    return Relation(guid if first_is_self else other, other if first_is_self else guid, relation, False)


def _by_guid(model: ifcopenshell.file, guid: str) -> ifcopenshell.entity_instance | None:
    try:
        return model.by_guid(guid)
    except RuntimeError:
        return None


def _cast_around(overlap: Overlap, a: Component, b: Component) -> Joint | None:
    """A joint where one of the two is cast in place (its concrete poured around the other), or None."""
    cast = [c for c in (a, b) if c.method is ConstructionMethod.CAST_IN_PLACE]
    if not cast:
        return None
    member = b if cast[0] is a else a
    rule = f"{member.ifc_class} in cast-in-place {cast[0].ifc_class}"
    return _part_first(overlap, cast[0], member, JointSource.CAST, rule)


def _fitted_to_existing(overlap: Overlap, a: Component, b: Component) -> Joint | None:
    """A joint where a new component is drawn into existing work (in place before the robots come) no
    deeper than :data:`FITTED_MAX_DEPTH_M`, or rises from below with its top drawn up into it no deeper
    than :data:`FITTED_UNDER_MAX_DEPTH_M` (:func:`framed_up_under`), the existing part first, or None."""
    existing = [c for c in (a, b) if c.method is ConstructionMethod.IN_PLACE]
    if len(existing) != 1:
        return None
    member = b if existing[0] is a else a
    if overlap.depth_m <= FITTED_MAX_DEPTH_M:
        rule = f"{member.ifc_class} fitted to existing {existing[0].ifc_class}"
    elif framed_up_under(member, existing[0]):
        rule = f"{member.ifc_class} framed up under existing {existing[0].ifc_class}"
    else:
        return None
    return _part_first(overlap, existing[0], member, JointSource.FITTED, rule)


def framed_up_under(member: Component, existing: Component) -> bool:
    """Whether ``member`` rises from below ``existing`` with its top drawn up into it, no more than
    :data:`FITTED_UNDER_MAX_DEPTH_M` above its underside and not past its top: a partition a renovation
    draws to the top of the existing beam over it (the Janesville restaurant: 432-533 mm into its timber
    and W24 beams) is framed up to the beam's underside and scribed to it on site."""
    member_low, member_high = member.bbox_world.min_m[2], member.bbox_world.max_m[2]
    existing_low, existing_high = existing.bbox_world.min_m[2], existing.bbox_world.max_m[2]
    drawn_up_m = member_high - existing_low
    return (
        member_low < existing_low - FITTED_UNDER_MAX_DEPTH_M
        and 0.0 < drawn_up_m <= FITTED_UNDER_MAX_DEPTH_M
        and member_high <= existing_high + END_TOLERANCE_M
    )


def _part_first(
    overlap: Overlap, part: Component, member: Component, source: JointSource, rule: str
) -> Joint:
    """The directed joint of ``overlap``: ``part`` first, ``member`` set into it."""
    return Joint(
        guids=(part.guid, member.guid),
        depth_m=round(overlap.depth_m, 4),
        source=source,
        rule=rule,
        directed=True,
    )


def _by_rule(
    overlap: Overlap,
    a: Component,
    b: Component,
    rules: Iterable[JointRule],
    classes: _ClassTree,
    *,
    bars: BarShapes,
) -> Joint | None:
    """The joint the first fitting rule makes of ``overlap`` (either way round), or None."""
    for rule, member, part, member_class, part_class in _fitting(rules, a, b, classes):
        if overlap.depth_m > rule.max_depth_m:
            continue
        if rule.slender and not bars.is_bar(member):
            continue
        if rule.at_end and not at_an_end(member, overlap.region_m, rule.max_depth_m + END_TOLERANCE_M):
            continue
        if rule.embedded and not embedded_along(member, part, overlap.region_m):
            continue
        # existing work is not built round: a new part drawn through it is judged as fitted to it
        if rule.through and (
            ConstructionMethod.IN_PLACE in (member.method, part.method)
            or not carried_through(member, part, overlap.region_m)
        ):
            continue
        if rule.min_run_m > 0.0 and plan_run_m(overlap.region_m) < rule.min_run_m:
            continue
        if not rule.takes_masses(member.mass_kg, part.mass_kg) or not rule.takes_shape(*_shape(member)):
            continue
        # either may be the member of a rule that does not look for an end: no direction then
        either_way = not rule.at_end and classes.matching(part.ifc_class, rule.member) is not None
        either_way = either_way and classes.matching(member.ifc_class, rule.part) is not None
        either_way = either_way and rule.takes_masses(part.mass_kg, member.mass_kg)
        return Joint(
            guids=(part.guid, member.guid),
            depth_m=round(overlap.depth_m, 4),
            source=JointSource.RULE,
            rule=rule.describe(member_class, part_class),
            directed=not either_way,
            part_first=rule.part_first and not either_way,
        )
    return None


def _fitting(
    rules: Iterable[JointRule], a: Component, b: Component, classes: _ClassTree
) -> Iterator[tuple[JointRule, Component, Component, str, str]]:
    """Each rule, in order, with each way round ``a`` and ``b`` fit it: (rule, member, part, the member's
    and the part's class as the rule names them)."""
    for rule in rules:
        for member, part in ((a, b), (b, a)):
            member_class = classes.matching(member.ifc_class, rule.member)
            part_class = classes.matching(part.ifc_class, rule.part)
            if member_class is not None and part_class is not None:
                yield rule, member, part, member_class, part_class


def _shape(component: Component) -> tuple[float, float]:
    """``component``'s own box's least side (m) and the share of that box its volume fills."""
    size = np.asarray(component.bbox_local.max_m) - np.asarray(component.bbox_local.min_m)
    box_m3 = float(np.prod(size))
    return float(np.min(size)), (component.volume_m3 / box_m3 if box_m3 > 0.0 else 1.0)


class _ClassTree:
    """Which of a rule's IFC classes a component's class is (itself or a subclass), by the model's schema."""

    def __init__(self, model: ifcopenshell.file) -> None:
        self._schema = ifcopenshell.ifcopenshell_wrapper.schema_by_name(model.schema_identifier)
        self._ancestors: dict[str, frozenset[str]] = {}

    def ancestors(self, ifc_class: str) -> frozenset[str]:
        """``ifc_class`` and its supertypes, lower-case."""
        found = self._ancestors.get(ifc_class)
        if found is None:
            names = {ifc_class.lower()}
            try:
                declaration = self._schema.declaration_by_name(ifc_class)
            except (RuntimeError, KeyError):
                declaration = None
            entity = None
            if isinstance(declaration, ifcopenshell.ifcopenshell_wrapper.entity):
                entity = declaration
            while entity is not None:
                names.add(entity.name().lower())
                entity = entity.supertype()
            found = self._ancestors[ifc_class] = frozenset(names)
        return found

    def matching(self, ifc_class: str, candidates: Sequence[str]) -> str | None:
        """The first of ``candidates`` that ``ifc_class`` is (with subclasses), or None."""
        ancestors = self.ancestors(ifc_class)
        return next((name for name in candidates if name.lower() in ancestors), None)
