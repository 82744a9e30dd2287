"""What ifcopenshell could not read in a model, and which elements it leaves incomplete.

Why: ifcopenshell opens a damaged file without an exception. A line it cannot parse (a line cut in half, a
misspelt entity) is dropped, every reference to it reads as unset, and the element whose geometry used it
converts with a wrong shape: a Revit beam's profile curve cut in half made its mass 570 kg instead of 308 kg,
silently. The parser says so only in its log (:func:`ifcopenshell.get_log`): an unknown entity, a syntax
error, "Instance reference #A used by instance #B … not found", each with the byte offset in the file.

:func:`read_parse_log` turns that log into :class:`ParseDamage` (lines, not offsets: what a user opens the
file at), and :func:`damaged_elements` finds the elements that reach a lost reference through their
geometry, placement, type, material or properties: those are left out of the build with a reason naming
the line, the rest converts. Real exports have dangling references too (the Revit structural hub's window
style refers to four instances it lacks): they matter only when an element being built reaches them.
"""

from __future__ import annotations

import bisect
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import ifcopenshell

_LEVEL = re.compile(r"^\[(?P<level>error|warning)\](?: \[[A-Z]+\d*\])? \[[^\]]*\] (?P<message>.*)$")
_OFFSET = re.compile(r" at offset (?P<offset>\d+)$")
_LOST = re.compile(r"^Instance reference #(?P<missing>\d+) used by instance #(?P<referrer>\d+) ")
# Relationships through which what one object lacks reaches the objects it relates (its type, material or
# properties). Containment and aggregation do not: a storey that lost a property leaves its walls whole.
_SHARED_BY = ("IfcRelDefinesByType", "IfcRelDefinesByProperties", "IfcRelAssociatesMaterial")
MAX_VISITED = 200_000  # instances walked per lost reference at most (a model's whole graph, in practice)


@dataclass(frozen=True)
class LostReference:
    referrer_id: int  # the instance that refers to what the file lacks
    missing_id: int
    line: int | None  # where the referrer is written (1-based)


@dataclass(frozen=True)
class ParseDamage:
    """What the parser could not read: whole lines (``(line, what)``) and references left unset."""

    unreadable: tuple[tuple[int | None, str], ...] = ()
    lost: tuple[LostReference, ...] = ()
    source: Path | None = None  # the file (read again for where a lost instance was written, when needed)

    def __bool__(self) -> bool:
        return bool(self.unreadable or self.lost)


def read_parse_log(log: str, path: Path) -> ParseDamage:
    """The damage ifcopenshell's log (text format) reports for the file at ``path``."""
    entries = [
        match for line in log.splitlines() if (match := _LEVEL.match(line)) and match["level"] == "error"
    ]
    if not entries:
        return ParseDamage()
    newlines = _newline_offsets(path)
    unreadable: list[tuple[int | None, str]] = []
    lost: list[LostReference] = []
    for entry in entries:
        message = entry["message"]
        where = _OFFSET.search(message)
        line = _line_at(newlines, int(where["offset"])) if where else None
        text = message[: where.start()] if where else message
        reference = _LOST.match(text)
        if reference:
            lost.append(LostReference(int(reference["referrer"]), int(reference["missing"]), line))
        else:
            unreadable.append((line, text))
    return ParseDamage(tuple(unreadable), tuple(lost), path)


def damaged_elements(
    model: ifcopenshell.file, damage: ParseDamage, elements: Sequence[ifcopenshell.entity_instance]
) -> dict[int, str]:
    """Element id → why it is incomplete, for each of ``elements`` that reaches a lost reference."""
    wanted = {element.id() for element in elements}
    reasons: dict[int, str] = {}
    written_at: dict[int, int | None] | None = None  # read from the file once an element is reached
    for reference in damage.lost:
        reached = list(_reached_elements(model, reference.referrer_id, wanted))
        if not reached:
            continue
        if written_at is None:
            written_at = _lines_of_ids(damage.source, {lost.missing_id for lost in damage.lost})
        missing_line = _damaged_line(damage, written_at.get(reference.missing_id))
        lacks = (
            f"#{reference.missing_id}, which could not be read (line {missing_line})"
            if missing_line is not None
            else f"#{reference.missing_id}, which the file lacks"
        )
        where = f" (line {reference.line})" if reference.line is not None else ""
        for element_id in reached:
            reasons.setdefault(
                element_id,
                f"damaged in the file: #{reference.referrer_id}{where}, part of its geometry, placement, "
                f"type or properties, refers to {lacks}; repair the file to build it",
            )
    return reasons


def _damaged_line(damage: ParseDamage, written_at: int | None) -> int | None:
    """The unreadable line that cost an instance written at ``written_at``: the nearest one at or before it
    (a line cut in half swallows the next; a lost ``;`` the lines after it)."""
    if written_at is None:
        return None
    before = [line for line, _ in damage.unreadable if line is not None and line <= written_at]
    return max(before, default=written_at)


def describe_unreadable(damage: ParseDamage) -> list[str]:
    """One warning per line the parser could not read."""
    name = damage.source.name if damage.source is not None else "the file"
    return [
        f"{name} line {line}: could not be read ({what.rstrip()}); what refers to it is incomplete"
        if line is not None
        else f"{name}: {what.rstrip()}"
        for line, what in damage.unreadable
    ]


def _reached_elements(model: ifcopenshell.file, start_id: int, wanted: set[int]) -> Iterable[int]:
    """The ``wanted`` elements that reach instance ``start_id``: up through whatever refers to it, and from
    a type, material or property relationship on to the objects it relates."""
    try:
        start = model.by_id(start_id)
    except RuntimeError:
        return
    seen = {start_id}
    stack = [start]
    while stack and len(seen) < MAX_VISITED:
        instance = stack.pop()
        if instance.id() in wanted:
            yield instance.id()
            continue
        if instance.is_a("IfcProduct") and instance.id() != start_id:
            continue  # another product (a storey, a host): what it lacks is not its neighbours' geometry
        upward = list(model.get_inverse(instance))
        if _is_shared_by(instance):
            upward += _related_objects(instance)
        for other in upward:
            if other.id() not in seen:
                seen.add(other.id())
                stack.append(other)


def _is_shared_by(instance: ifcopenshell.entity_instance) -> bool:
    return any(instance.is_a(name) for name in _SHARED_BY)


def _related_objects(relationship: ifcopenshell.entity_instance) -> list[ifcopenshell.entity_instance]:
    related = getattr(relationship, "RelatedObjects", None)
    return [item for item in (related or ()) if item is not None]


def _newline_offsets(path: Path) -> list[int]:
    data = path.read_bytes()
    offsets, at = [], data.find(b"\n")
    while at >= 0:
        offsets.append(at)
        at = data.find(b"\n", at + 1)
    return offsets


def _line_at(newlines: list[int], offset: int) -> int:
    return bisect.bisect_left(newlines, offset) + 1


def _lines_of_ids(path: Path | None, ids: set[int]) -> dict[int, int | None]:
    """The line where each of ``ids`` is written as ``#id=`` (None: nowhere: the file lacks it)."""
    found: dict[int, int | None] = dict.fromkeys(ids)
    if not ids or path is None:
        return found
    pattern = re.compile(rb"^\s*#(\d+)\s*=", re.MULTILINE)
    with path.open("rb") as stream:
        for number, line in enumerate(stream, start=1):
            match = pattern.match(line)
            if match and int(match.group(1)) in found:
                found[int(match.group(1))] = number
    return found
