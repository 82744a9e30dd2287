"""Schedules from the planners' tools as construction sequences: MS Project XML, Primavera P6 XML and XER.

Each file is read by IfcOpenShell's ``ifc4d`` (``MSP2Ifc``, ``P62Ifc``, ``P6XER2Ifc``) into an IFC work
schedule of tasks without products; :func:`match_tasks` then finds each task's component:

* by GlobalId: a component's GlobalId in the task's Identification (activity Id, WBS code, outline number),
  its name, or one of its custom fields (P6 UDFs, MS Project extended attributes);
* else by name: the task's name equal to the component's name or to ``Erect <name>`` (case and spacing
  ignored); components that share a name take the tasks that carry it in order.

A task matched to a component owns the tasks under it (a component's summary task and its steps). A task
whose ancestors are unmatched and that matches nothing is reported by name: :attr:`MatchedSchedule.
unmatched`. Precedences are the files' relationships between tasks of two different components; the order is
by start date, then the order of the file. Tasks are never matched to components twice.
"""

from __future__ import annotations

import contextlib
import io
import logging
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path

import ifcopenshell
import ifcopenshell.util.element
import ifcopenshell.util.sequence
from lxml import etree

from bimbot.shared.sequence import (
    ConstructionSequence,
    SequenceError,
    priority_topological_order,
    sequence_from_predecessors,
)

_log = logging.getLogger(__name__)

GUID_PATTERN = re.compile(r"[0-9A-Za-z_$]{22}")
CUSTOM_FIELD_PSETS = ("P6_UDF", "MSP_ExtendedAttribute", "Pset_MSP_Task", "P6_ActivityCodes")


class ScheduleFormat(StrEnum):
    BIMBOT = "bimbot sequence XML"
    MSP = "MS Project XML"
    P6_XML = "Primavera P6 XML"
    P6_XER = "Primavera P6 XER"


@dataclass(frozen=True)
class MatchedSchedule:
    sequence: ConstructionSequence
    by_guid: int  # components matched by GlobalId
    by_name: int  # components matched by name
    unmatched: tuple[str, ...]  # names of tasks that matched no component

    def notes(self, origin: str) -> list[str]:
        """One line for the plan's warnings when some tasks matched nothing."""
        if not self.unmatched:
            return []
        shown = ", ".join(repr(name) for name in self.unmatched[:5])
        more = f" and {len(self.unmatched) - 5} more" if len(self.unmatched) > 5 else ""
        return [
            f"{origin}: {len(self.unmatched)} task(s) matched no component by GlobalId or name: {shown}{more}"
        ]


def schedule_format(path: Path) -> ScheduleFormat:
    """Which format the file at ``path`` is, from its content (XER by its header line)."""
    with Path(path).open("rb") as stream:
        head = stream.read(4096)
    if head.lstrip(b"\xef\xbb\xbf").startswith(b"ERMHDR"):
        return ScheduleFormat.P6_XER
    try:
        root = etree.parse(
            str(path), parser=etree.XMLParser(resolve_entities=False, no_network=True)
        ).getroot()
    except etree.XMLSyntaxError:
        return ScheduleFormat.BIMBOT  # the sequence reader names what is wrong with it
    local = etree.QName(root).localname
    if local == "Project" and "schemas.microsoft.com/project" in (etree.QName(root).namespace or ""):
        return ScheduleFormat.MSP
    if local == "APIBusinessObjects":
        return ScheduleFormat.P6_XML
    return ScheduleFormat.BIMBOT


def planner_schedule_model(path: Path, kind: ScheduleFormat) -> ifcopenshell.file:
    """The file at ``path`` read by ``ifc4d`` into an IFC4 work schedule (:class:`SequenceError` if not)."""
    import ifcopenshell.api.root

    model = ifcopenshell.file(schema="IFC4")
    ifcopenshell.api.root.create_entity(model, ifc_class="IfcProject", name=Path(path).stem)
    printed = io.StringIO()
    try:
        with contextlib.redirect_stdout(printed):  # ifc4d prints progress
            _read_into(model, Path(path), kind)
    except Exception as error:  # a malformed file fails anywhere in ifc4d's parser
        raise SequenceError(
            f"{path}: not a readable {kind.value} file ({type(error).__name__}: {error})"
        ) from None
    return model


def _read_into(model: ifcopenshell.file, path: Path, kind: ScheduleFormat) -> None:
    if kind is ScheduleFormat.MSP:
        from ifc4d.msp2ifc import MSP2Ifc

        reader: object = MSP2Ifc()
        reader.xml = str(path)  # type: ignore[attr-defined]
    elif kind is ScheduleFormat.P6_XML:
        from ifc4d.p62ifc import P62Ifc

        reader = P62Ifc()
        reader.xml = str(path)  # type: ignore[attr-defined]
    else:
        from ifc4d.p6xer2ifc import P6XER2Ifc

        reader = P6XER2Ifc()
        reader.xer = str(path)  # type: ignore[attr-defined]
    reader.file = model  # type: ignore[attr-defined]
    reader.execute()  # type: ignore[attr-defined]


def read_planner_schedule(
    path: Path,
    kind: ScheduleFormat,
    components: Mapping[str, str],
    plan_names: Mapping[str, str] | None = None,
) -> MatchedSchedule:
    """The construction sequence of a planner's file; ``components``: GUID → name (manifest order)."""
    model = planner_schedule_model(path, kind)
    return match_tasks(model, components, plan_names, source=kind.name.lower())


def match_tasks(
    model: ifcopenshell.file,
    components: Mapping[str, str],
    plan_names: Mapping[str, str] | None = None,
    *,
    source: str = "planner",
) -> MatchedSchedule:
    """Match the model's tasks to ``components`` (GUID → name) and build the sequence (module docstring)."""
    tasks = _tasks_in_order(model)
    position = {task.id(): index for index, task in enumerate(tasks)}
    names = _name_index(components, plan_names or {})
    owner: dict[int, str] = {}  # task id → component GUID (itself or an ancestor matched)
    taken: dict[str, ifcopenshell.entity_instance] = {}
    by_guid = by_name = 0
    unmatched: list[str] = []
    for task in tasks:
        parent = ifcopenshell.util.sequence.get_parent_task(task)
        if parent is not None and parent.id() in owner:
            owner[task.id()] = owner[parent.id()]
            continue
        guid = _guid_of(task, components, taken)
        if guid is not None:
            by_guid += 1
        else:
            guid = next((item for item in names.get(_normal(task.Name), []) if item not in taken), None)
            by_name += guid is not None
        if guid is not None:
            owner[task.id()], taken[guid] = guid, task
        elif not ifcopenshell.util.sequence.get_nested_tasks(task):
            unmatched.append(task.Name or task.Identification or f"#{task.id()}")
    predecessors: dict[str, set[str]] = {guid: set() for guid in taken}
    for relation in model.by_type("IfcRelSequence"):
        before = owner.get(relation.RelatingProcess.id())
        after = owner.get(relation.RelatedProcess.id())
        if before is not None and after is not None and before != after:
            predecessors[after].add(before)

    def key(guid: str) -> tuple[str, int]:
        task = taken[guid]
        return (_start(task), position[task.id()])

    ordered = priority_topological_order(predecessors, key)
    sequence = sequence_from_predecessors(
        ordered,
        predecessors,
        source=source,
        names={guid: task.Name for guid, task in taken.items() if task.Name},
    )
    return MatchedSchedule(sequence, by_guid, by_name, tuple(unmatched))


def _tasks_in_order(model: ifcopenshell.file) -> list[ifcopenshell.entity_instance]:
    """Every task, parents before their children, in the schedules' order."""
    ordered: list[ifcopenshell.entity_instance] = []

    def visit(task: ifcopenshell.entity_instance) -> None:
        ordered.append(task)
        for child in ifcopenshell.util.sequence.get_nested_tasks(task):
            visit(child)

    for schedule in model.by_type("IfcWorkSchedule"):
        for root in ifcopenshell.util.sequence.get_root_tasks(schedule):
            visit(root)
    seen = {task.id() for task in ordered}
    for task in model.by_type("IfcTask"):  # tasks of no schedule
        if task.id() not in seen and ifcopenshell.util.sequence.get_parent_task(task) is None:
            visit(task)
    return ordered


def _guid_of(
    task: ifcopenshell.entity_instance, components: Mapping[str, str], taken: Mapping[str, object]
) -> str | None:
    texts = [task.Identification or "", task.Name or ""]
    for pset_name in CUSTOM_FIELD_PSETS:
        values = ifcopenshell.util.element.get_pset(task, pset_name) or {}
        texts += [str(value) for name, value in values.items() if name != "id"]
    for text in texts:
        for candidate in GUID_PATTERN.findall(text):
            if candidate in components and candidate not in taken:
                return candidate
    return None


def _normal(name: str | None) -> str:
    return " ".join((name or "").split()).casefold()


def _name_index(components: Mapping[str, str], plan_names: Mapping[str, str]) -> dict[str, list[str]]:
    """Normalised name → GUIDs that answer to it (component name, ``Erect <name>``, the plan's task name)."""
    index: dict[str, list[str]] = {}
    for guid, name in components.items():
        for text in (name, f"Erect {name}", plan_names.get(guid, "")):
            if text and guid not in index.setdefault(_normal(text), []):
                index[_normal(text)].append(guid)
    return index


def _start(task: ifcopenshell.entity_instance) -> str:
    """The earliest ScheduleStart of the task or its sub-tasks ('~' when none: after the dated ones)."""
    starts = [
        item.TaskTime.ScheduleStart
        for item in [task, *ifcopenshell.util.sequence.get_all_nested_tasks(task)]
        if getattr(item, "TaskTime", None) is not None and item.TaskTime.ScheduleStart
    ]
    return min(starts) if starts else "~"


def summary(matched: MatchedSchedule, components: Sequence[str]) -> str:
    """``28 of 30 components matched (26 by GlobalId, 2 by name), 1 task unmatched``."""
    return (
        f"{len(matched.sequence.tasks)} of {len(components)} components matched "
        f"({matched.by_guid} by GlobalId, {matched.by_name} by name), "
        f"{len(matched.unmatched)} task(s) unmatched"
    )
