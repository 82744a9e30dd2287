"""An IFC2X3 model brought to IFC4, where the 4D schedule (IfcTaskTime and its relationships) lives.

``ifcopenshell.util.schema.Migrator`` maps each entity attribute by attribute through the schemas'
declarations, about 70 µs an entity. Most entities of a model (points, loops, faces, placements,
directions) are of classes whose attributes are the same in both schemas; those are copied here with one
``create_entity`` call each, and only the rest go through the Migrator (which shares this copy's map of
migrated ids, so each entity is migrated once whichever way). The result is the Migrator's.
"""

from __future__ import annotations

import contextlib
import io
import logging
from collections.abc import Iterator
from typing import Any

import ifcopenshell
import ifcopenshell.ifcopenshell_wrapper as wrapper
import ifcopenshell.util.schema

_log = logging.getLogger(__name__)


class _Upgrade:
    def __init__(self, source: ifcopenshell.file, target: ifcopenshell.file) -> None:
        self.source, self.target = source, target
        self.migrator = _Migrator(self)
        self.done: dict[int, int] = self.migrator.migrated_ids  # source id → target id, shared
        self.copies: dict[int, ifcopenshell.entity_instance] = {}  # source id → target entity, no lookups
        self.same: dict[str, bool] = {}
        self.old_schema = wrapper.schema_by_name(source.schema_identifier)
        self.new_schema = wrapper.schema_by_name(target.schema_identifier)

    def same_layout(self, ifc_class: str) -> bool:
        """The class exists in both schemas with the same attributes, none derived in IFC4."""
        known = self.same.get(ifc_class)
        if known is None:
            try:
                old = self.old_schema.declaration_by_name(ifc_class).as_entity()
                new = self.new_schema.declaration_by_name(ifc_class).as_entity()
            except RuntimeError:  # not a class of IFC4
                old = new = None
            known = (
                old is not None
                and new is not None
                and [a.name() for a in old.all_attributes()] == [a.name() for a in new.all_attributes()]
                and not any(new.derived())
            )
            self.same[ifc_class] = known
        return known

    def entity(self, element: ifcopenshell.entity_instance) -> ifcopenshell.entity_instance:
        if element.id() == 0:  # a typed value (IfcLabel('x'))
            return self.target.create_entity(element.is_a(), element.wrappedValue)
        number = element.id()
        copy = self.copies.get(number)
        if copy is not None:
            return copy
        if number in self.done:  # migrated by the Migrator
            copy = self.copies[number] = self.target.by_id(self.done[number])
            return copy
        ifc_class = element.is_a()
        if self.same_layout(ifc_class):
            values = [self.value(element[index]) for index in range(len(element))]
            copied = self.target.create_entity(ifc_class)
            try:
                for index, value in enumerate(values):
                    copied[index] = value
            except (RuntimeError, TypeError, ValueError):  # a value IFC4 types otherwise: the Migrator's way
                self.target.remove(copied)
            else:
                self.done[number] = copied.id()
                self.copies[number] = copied
                return copied
        return ifcopenshell.util.schema.Migrator.migrate(self.migrator, element, self.target)

    def value(self, value: Any) -> Any:
        if isinstance(value, ifcopenshell.entity_instance):
            return self.entity(value)
        if isinstance(value, tuple | list):
            return [self.value(item) for item in value]
        return value


class _Migrator(ifcopenshell.util.schema.Migrator):
    """The Migrator, whose recursion into an entity's attributes takes the fast copy where it can."""

    def __init__(self, upgrade: _Upgrade) -> None:
        super().__init__()
        self.upgrade = upgrade

    def migrate(
        self, element: ifcopenshell.entity_instance, new_file: ifcopenshell.file
    ) -> ifcopenshell.entity_instance:
        return self.upgrade.entity(element)


def upgrade_to_ifc4(source: ifcopenshell.file) -> tuple[ifcopenshell.file, int]:
    """``source`` (IFC2X3) as a new IFC4 file; (the file, attribute values IFC4 has no place for)."""
    target = ifcopenshell.file(schema="IFC4")
    upgrade = _Upgrade(source, target)
    notes = io.StringIO()
    with contextlib.redirect_stdout(notes):  # the Migrator prints each attribute it drops
        for element in _in_file_order(source):
            upgrade.entity(element)
    return target, notes.getvalue().count("Unable to find equivalent attribute")


def _in_file_order(model: ifcopenshell.file) -> Iterator[ifcopenshell.entity_instance]:
    yield from model
