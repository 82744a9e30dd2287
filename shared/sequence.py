"""The construction sequence file (``sequence.xml``): ordered tasks naming component GlobalIds.

Format (documented in ``docs/sequence-format.md``)::

    <construction_sequence schema_version="1" source="ifc_schedule">
      <task id="T001" guid="2O2Fr$t4X7Zf8NOew3FLOH" name="Erect Footing A1"/>
      <task id="T002" guid="0cM8Zqv9P3uQ$1aX3z6Ykq" name="Erect Column A1">
        <predecessor task="T001"/>
      </task>
    </construction_sequence>

Tasks are listed in erection order. ``<predecessor>`` elements are optional: a file that gives none for
any task is a plain ordered list (like the paper's schedule input); a file that gives some states its
precedence explicitly. ``source`` says where the sequence came from (``ifc_schedule``, ``derived``,
``user``). Reading checks structure, duplicate ids/GUIDs, unknown predecessors and cycles, and raises
:class:`SequenceError` with a message naming the offending task.
"""

from __future__ import annotations

import graphlib
import heapq
import logging
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING

from lxml import etree
from pydantic import BaseModel, ConfigDict

if TYPE_CHECKING:
    from _typeshed import SupportsRichComparison

SEQUENCE_SCHEMA_VERSION = 1
SEQUENCE_FILE_NAME = "sequence.xml"

_log = logging.getLogger(__name__)


class SequenceError(ValueError):
    """A sequence file that cannot be used: malformed, duplicate, unknown or cyclic references."""


class SequenceTask(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")

    task_id: str
    guid: str
    name: str | None = None
    predecessors: tuple[str, ...] = ()  # task ids


class ConstructionSequence(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")

    schema_version: int = SEQUENCE_SCHEMA_VERSION
    source: str
    tasks: tuple[SequenceTask, ...]

    @property
    def has_explicit_predecessors(self) -> bool:
        return any(task.predecessors for task in self.tasks)

    def guids(self) -> list[str]:
        return [task.guid for task in self.tasks]

    def predecessor_guids(self) -> dict[str, set[str]]:
        """GUID → GUIDs that must be constructed first (explicit links only)."""
        by_id = {task.task_id: task.guid for task in self.tasks}
        return {task.guid: {by_id[pred] for pred in task.predecessors} for task in self.tasks}


def check_sequence(sequence: ConstructionSequence) -> None:
    """Raise :class:`SequenceError` for duplicate ids or GUIDs, unknown predecessors or a cycle."""
    ids: set[str] = set()
    guids: set[str] = set()
    for task in sequence.tasks:
        if task.task_id in ids:
            raise SequenceError(f"task id {task.task_id!r} appears twice")
        if task.guid in guids:
            raise SequenceError(f"component {task.guid} has two tasks (second: {task.task_id!r})")
        ids.add(task.task_id)
        guids.add(task.guid)
    for task in sequence.tasks:
        unknown = [pred for pred in task.predecessors if pred not in ids]
        if unknown:
            raise SequenceError(f"task {task.task_id!r} names unknown predecessor(s) {', '.join(unknown)}")
    sorter = graphlib.TopologicalSorter({task.task_id: set(task.predecessors) for task in sequence.tasks})
    try:
        sorter.prepare()
    except graphlib.CycleError as error:
        cycle = " → ".join(error.args[1])
        raise SequenceError(f"the sequence has a precedence cycle: {cycle}") from None


def sequence_to_xml(sequence: ConstructionSequence) -> bytes:
    root = etree.Element(
        "construction_sequence", schema_version=str(sequence.schema_version), source=sequence.source
    )
    for task in sequence.tasks:
        element = etree.SubElement(root, "task", id=task.task_id, guid=task.guid)
        if task.name:
            element.set("name", task.name)
        for pred in task.predecessors:
            etree.SubElement(element, "predecessor", task=pred)
    return etree.tostring(root, pretty_print=True, xml_declaration=True, encoding="UTF-8")


def sequence_from_xml(data: bytes, *, origin: str = "sequence") -> ConstructionSequence:
    """Parse and check a sequence document; :class:`SequenceError` names what is wrong."""
    if data.lstrip()[:12] == b"ISO-10303-21":  # a STEP file: an IFC model with its own schedule, maybe
        raise SequenceError(
            f"{origin}: an IFC model, not a sequence: to build by its 4D schedule (IfcTask), give it "
            f"as --from-ifc {origin}"
        )
    try:
        root = etree.fromstring(data, parser=etree.XMLParser(resolve_entities=False, no_network=True))
    except etree.XMLSyntaxError as error:
        raise SequenceError(f"{origin}: not well-formed XML ({error})") from None
    if root.tag != "construction_sequence":
        raise SequenceError(f"{origin}: root element is <{root.tag}>, expected <construction_sequence>")
    version = int(root.get("schema_version", SEQUENCE_SCHEMA_VERSION))
    if version != SEQUENCE_SCHEMA_VERSION:
        raise SequenceError(
            f"{origin}: schema_version {version}, this bimbot reads {SEQUENCE_SCHEMA_VERSION}"
        )
    tasks: list[SequenceTask] = []
    for index, element in enumerate(root.iterfind("task"), start=1):
        guid = element.get("guid")
        if not guid:
            raise SequenceError(f"{origin}: task #{index} has no guid attribute")
        task_id = element.get("id") or f"T{index:04d}"
        preds = tuple(pred.get("task", "") for pred in element.iterfind("predecessor"))
        tasks.append(SequenceTask(task_id=task_id, guid=guid, name=element.get("name"), predecessors=preds))
    sequence = ConstructionSequence(
        schema_version=version, source=root.get("source", "user"), tasks=tuple(tasks)
    )
    try:
        check_sequence(sequence)
    except SequenceError as error:
        raise SequenceError(f"{origin}: {error}") from None
    return sequence


def read_sequence(path: Path) -> ConstructionSequence:
    path = Path(path)
    if not path.is_file():
        raise SequenceError(f"{path}: no such sequence file")
    return sequence_from_xml(path.read_bytes(), origin=str(path))


def write_sequence(sequence: ConstructionSequence, path: Path) -> Path:
    Path(path).write_bytes(sequence_to_xml(sequence))
    return Path(path)


def sequence_from_predecessors(
    ordered_guids: Iterable[str],
    predecessors: Mapping[str, set[str]],
    *,
    source: str,
    names: dict[str, str] | None = None,
) -> ConstructionSequence:
    """Build a sequence from GUIDs in order and GUID → predecessor GUIDs (task ids ``T0001``…)."""
    ordered = list(ordered_guids)
    position = {guid: index for index, guid in enumerate(ordered)}
    task_ids = {guid: f"T{index:04d}" for index, guid in enumerate(ordered, start=1)}
    tasks = tuple(
        SequenceTask(
            task_id=task_ids[guid],
            guid=guid,
            name=(names or {}).get(guid),
            predecessors=tuple(
                task_ids[pred]
                for pred in sorted(predecessors.get(guid, ()) & position.keys(), key=position.__getitem__)
            ),
        )
        for guid in ordered
    )
    sequence = ConstructionSequence(source=source, tasks=tasks)
    check_sequence(sequence)
    return sequence


def _in_order(items: set[str], position: dict[str, int]) -> list[str]:
    """The members of ``items`` that have a position, sorted by it."""
    return sorted((item for item in items if item in position), key=position.__getitem__)


def priority_topological_order(
    predecessors: Mapping[str, set[str]], key: Callable[[str], SupportsRichComparison]
) -> list[str]:
    """Kahn's algorithm: among the items whose predecessors are all placed, the smallest ``key`` goes first.

    Items caught in a cycle are appended in ``key`` order (callers report the cycle when they check).
    """
    waiting = {item: set(values) & predecessors.keys() for item, values in predecessors.items()}
    successors: dict[str, set[str]] = {item: set() for item in waiting}
    for item, values in waiting.items():
        for pred in values:
            successors[pred].add(item)
    ready = [(key(item), item) for item, values in waiting.items() if not values]
    heapq.heapify(ready)
    ordered: list[str] = []
    while ready:
        _, item = heapq.heappop(ready)
        ordered.append(item)
        for successor in successors[item]:
            waiting[successor].discard(item)
            if not waiting[successor]:
                heapq.heappush(ready, (key(successor), successor))
    if len(ordered) != len(waiting):
        placed = set(ordered)
        ordered += sorted((item for item in waiting if item not in placed), key=key)
    return ordered
