"""A construction method for every element, decided before any geometry is built.

Per element, the first answer of: the user's word (the methods file's ``by_guid``, ``by_class``,
``by_material``: :mod:`.method_rules`), what the IFC says (:mod:`.method_ifc`, unless the file says
``ifc = false``), the file's rules. Rules about the ground are answered both ways (the decision keeps the
answer for an element in the ground as ``if_in_ground``), and a lifted element that is not the user's
choice carries what it becomes when it proves too heavy or too large (``if_too_heavy``: panelised for the
file's panel classes, cast in place for its cast materials, and for its ``cast_unknown_classes`` of unknown
material when it casts those first); :func:`.final_method.final_method` settles
both once the mass and size are known.
"""

from __future__ import annotations

from collections.abc import Iterable

import ifcopenshell

from bimbot.shared.construction_methods import ConstructionMethod, MethodDecision, MethodSource
from bimbot.shared.methods_file import MaterialKind, MethodsFile

from .material_kind import material_kind, material_texts
from .method_ifc import ifc_statement
from .method_rules import rule_decision, user_decision


def decide_methods(
    elements: Iterable[ifcopenshell.entity_instance], methods: MethodsFile
) -> dict[str, MethodDecision]:
    """GlobalId → decision for each of ``elements`` (the elements being converted)."""
    elements = list(elements)
    built = {element.id() for element in elements}
    return {str(element.GlobalId): decide_method(element, built, methods) for element in elements}


def decide_method(
    element: ifcopenshell.entity_instance, built: set[int], methods: MethodsFile
) -> MethodDecision:
    """The decision for one element; ``built``: the STEP ids of every element converted (possible hosts)."""
    texts = material_texts(element)
    kind = material_kind(texts)
    decision = user_decision(element, texts, kind, methods)
    if decision is None and methods.ifc:
        decision = ifc_statement(element, texts, built, methods)
    if decision is None:
        decision = rule_decision(element, kind, methods, in_ground=False)
        grounded = rule_decision(element, kind, methods, in_ground=True)
        if grounded != decision:
            grounded = grounded.model_copy(
                update={"if_too_heavy": _too_heavy(element, kind, grounded, methods)}
            )
            decision = decision.model_copy(update={"if_in_ground": grounded})
    return decision.model_copy(
        update={"material": kind.value, "if_too_heavy": _too_heavy(element, kind, decision, methods)}
    )


def _too_heavy(
    element: ifcopenshell.entity_instance, kind: MaterialKind, decision: MethodDecision, methods: MethodsFile
) -> ConstructionMethod | None:
    """What a lifted element becomes when too heavy or too large: None for the user's word."""
    if decision.method is not ConstructionMethod.LIFTED or decision.source is MethodSource.USER:
        return None
    if (
        kind is MaterialKind.UNKNOWN
        and methods.panels.cast_unknown_when_too_heavy
        and any(element.is_a(name) for name in methods.panels.cast_unknown_classes)
    ):
        return ConstructionMethod.CAST_IN_PLACE
    if any(element.is_a(name) for name in methods.panels.classes):
        return ConstructionMethod.PANELISED
    if kind in methods.panels.cast_when_too_heavy:
        return ConstructionMethod.CAST_IN_PLACE
    return None
