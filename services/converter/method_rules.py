"""The methods file's answers for one element: the user's word, and the rules used where the IFC says nothing.

* :func:`user_decision`: ``[by_guid]``, then ``[by_class]`` (with subclasses; the most specific class
  named wins, so ``IfcWallStandardCase`` beats ``IfcWall``), then ``[by_material]`` (a regular expression
  searched in the material names and categories, and in the kind they were read as: ``masonry`` takes the
  Revit house's "Ladrillo" walls); ``method_source`` ``user``.
* :func:`rule_decision`: the first ``[[rules]]`` entry whose conditions all hold, else ``default``;
  ``method_source`` ``rule``. A rule about the ground is answered for an element in the ground or not, as
  the caller says (its geometry is not known yet).
"""

from __future__ import annotations

import re

import ifcopenshell
import ifcopenshell.util.element

from bimbot.shared.construction_methods import ConstructionMethod, MethodDecision, MethodSource
from bimbot.shared.methods_file import MaterialKind, MethodRule, MethodsFile


def user_decision(
    element: ifcopenshell.entity_instance, texts: list[str], kind: MaterialKind, methods: MethodsFile
) -> MethodDecision | None:
    """The user's method for ``element`` (see the module docstring), or None."""
    guid = str(element.GlobalId)
    where = methods.source or "methods file"
    if guid in methods.by_guid:
        return _user(methods.by_guid[guid], f"by GlobalId in {where}")
    classes = [name for name in methods.by_class if element.is_a(name)]
    if classes:
        name = max(classes, key=lambda item: _depth(element, item))
        return _user(methods.by_class[name], f"by class {name} in {where}")
    for pattern, method in methods.by_material.items():
        for text in [*texts, kind.value]:
            if re.search(pattern, text, re.I):
                return _user(method, f"by material {pattern!r} ({text}) in {where}")
    return None


def rule_decision(
    element: ifcopenshell.entity_instance, kind: MaterialKind, methods: MethodsFile, *, in_ground: bool
) -> MethodDecision:
    """The first rule that holds for ``element`` (``in_ground``: whether its target lies in the ground), else
    the file's default."""
    for rule in methods.rules:
        if _holds(rule, element, kind, in_ground):
            return MethodDecision(method=rule.method, source=MethodSource.RULE, note=rule.note)
    return MethodDecision(method=methods.default, source=MethodSource.RULE, note="by default")


def _holds(
    rule: MethodRule, element: ifcopenshell.entity_instance, kind: MaterialKind, in_ground: bool
) -> bool:
    if rule.classes and not any(element.is_a(name) for name in rule.classes):
        return False
    if rule.predefined_types or rule.except_predefined_types:
        predefined = str(ifcopenshell.util.element.get_predefined_type(element) or "").upper()
        if rule.predefined_types and predefined not in {name.upper() for name in rule.predefined_types}:
            return False
        if predefined in {name.upper() for name in rule.except_predefined_types}:
            return False
    if rule.materials and kind not in rule.materials:
        return False
    return rule.in_ground is None or rule.in_ground == in_ground


def _depth(element: ifcopenshell.entity_instance, ifc_class: str) -> int:
    """How many classes ``ifc_class`` descends from: of the classes an element is, the deepest is nearest."""
    schema = ifcopenshell.ifcopenshell_wrapper.schema_by_name(element.is_a(True).split(".")[0])
    declaration: object = schema.declaration_by_name(ifc_class)
    depth = 0
    while isinstance(declaration, ifcopenshell.ifcopenshell_wrapper.entity):
        declaration = declaration.supertype()
        depth += 1
    return depth


def _user(method: ConstructionMethod, note: str) -> MethodDecision:
    return MethodDecision(method=method, source=MethodSource.USER, note=note)
