"""Read an IFC model's own 4D schedule as a construction sequence of components.

Uses IfcTask (nested with IfcRelNests), IfcRelAssignsToProduct (a task's output products),
IfcRelAssignsToProcess (its inputs, accepted as well), IfcRelSequence (predecessor → successor) and
IfcTaskTime (ScheduleStart, for ordering). A task's components are the products assigned to it or to any
task nested under it; an IfcRelSequence between two tasks makes every component of the successor wait for
every component of the predecessor. Tasks are listed by start time, then in precedence order, then by
Identification. A model with several work schedules (a master schedule and the simulated one ``bimbot
export`` adds, say) is read from one: the last one in the file that is not a baseline. Only components
(GUIDs the caller passes) are kept; the caller decides what to do with components the schedule does not
mention (see :func:`schedule_from_ifc`'s ``unscheduled``).
"""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass

import ifcopenshell
import ifcopenshell.util.sequence

from .sequence import ConstructionSequence, priority_topological_order, sequence_from_predecessors


@dataclass(frozen=True)
class IfcSchedule:
    sequence: ConstructionSequence
    unscheduled: tuple[str, ...]  # component GUIDs that no task mentions


def schedule_from_ifc(model: ifcopenshell.file, component_guids: Collection[str]) -> IfcSchedule | None:
    """The model's task schedule restricted to ``component_guids``; None when no task names a component."""
    wanted = set(component_guids)
    tasks = sorted(_schedule_tasks(model), key=lambda task: task.id())
    outputs = {task.id(): _task_components(task, wanted) for task in tasks}
    if not any(outputs.values()):
        return None
    # First (leaf-most) task per component: the task that owns it directly wins over a summary task.
    owner: dict[str, ifcopenshell.entity_instance] = {}
    for task in sorted(tasks, key=lambda item: (len(_nested(item)), item.id())):
        for guid in outputs[task.id()]:
            owner.setdefault(guid, task)
    predecessors: dict[str, set[str]] = {guid: set() for guid in owner}
    for relation in model.by_type("IfcRelSequence"):
        before, after = relation.RelatingProcess, relation.RelatedProcess
        if before is None or after is None or not before.is_a("IfcTask") or not after.is_a("IfcTask"):
            continue
        for guid in outputs.get(after.id(), set()):
            if guid in predecessors:
                predecessors[guid].update(outputs.get(before.id(), set()) - {guid})
    ordered = _ordered_guids(owner, predecessors)
    names = {guid: task.Name for guid, task in owner.items() if task.Name}
    sequence = sequence_from_predecessors(ordered, predecessors, source="ifc_schedule", names=names)
    unscheduled = tuple(sorted(wanted - set(owner)))
    return IfcSchedule(sequence, unscheduled)


def _schedule_tasks(model: ifcopenshell.file) -> list[ifcopenshell.entity_instance]:
    """Every task of the model, or of its last non-baseline work schedule when it has several."""
    schedules = [
        schedule
        for schedule in model.by_type("IfcWorkSchedule")
        if ifcopenshell.util.sequence.get_root_tasks(schedule)
    ]
    if len(schedules) < 2:
        return list(model.by_type("IfcTask"))
    current = [item for item in schedules if getattr(item, "PredefinedType", None) != "BASELINE"] or schedules
    chosen = max(current, key=lambda item: item.id())
    return list(set(ifcopenshell.util.sequence.get_work_schedule_tasks(chosen)))


def with_stand_ins(
    schedule: IfcSchedule, stand_ins: Mapping[str, Sequence[str]], support: Mapping[str, set[str]]
) -> IfcSchedule:
    """``schedule`` (computed for the elements of ``stand_ins`` among the components) with each such element
    replaced by the components that stand in for it, e.g. the panels a wall was split into: each takes the
    element's place and predecessors (an element predecessor is all its stand-ins), and follows those of
    its siblings it rests on (``support``: GUID → the GUIDs it rests on). An element the schedule leaves
    out leaves its stand-ins out."""
    tasks = schedule.sequence.tasks
    guid_of = {task.task_id: task.guid for task in tasks}
    members = {task.guid: list(stand_ins.get(task.guid, [task.guid])) for task in tasks}
    predecessors: dict[str, set[str]] = {}
    names: dict[str, str] = {}
    ordered: list[str] = []
    for task in tasks:
        before = {guid for pred in task.predecessors for guid in members[guid_of[pred]]}
        siblings = set(members[task.guid])
        for guid in members[task.guid]:
            predecessors[guid] = before | (set(support.get(guid, ())) & siblings - {guid})
            if task.name:
                names[guid] = task.name
            ordered.append(guid)
    position = {guid: index for index, guid in enumerate(ordered)}
    order = priority_topological_order(predecessors, position.__getitem__)
    sequence = sequence_from_predecessors(order, predecessors, source=schedule.sequence.source, names=names)
    unscheduled = [guid for element in schedule.unscheduled for guid in stand_ins.get(element, [element])]
    return IfcSchedule(sequence, tuple(unscheduled))


def _nested(task: ifcopenshell.entity_instance) -> list[ifcopenshell.entity_instance]:
    return list(ifcopenshell.util.sequence.get_all_nested_tasks(task))


def _task_components(task: ifcopenshell.entity_instance, wanted: set[str]) -> set[str]:
    guids: set[str] = set()
    for item in [task, *_nested(task)]:
        products = list(ifcopenshell.util.sequence.get_task_outputs(item))
        products += list(ifcopenshell.util.sequence.get_task_inputs(item))
        guids.update(product.GlobalId for product in products if product.GlobalId in wanted)
    return guids


def _start_key(task: ifcopenshell.entity_instance) -> str:
    task_time = getattr(task, "TaskTime", None)
    start = getattr(task_time, "ScheduleStart", None) if task_time is not None else None
    return str(start) if start else "~"  # tasks without a start sort after dated ones


def _ordered_guids(
    owner: dict[str, ifcopenshell.entity_instance], predecessors: dict[str, set[str]]
) -> list[str]:
    """Precedence order; ties broken by start time, then task Identification/Name, then step id."""

    def key(guid: str) -> tuple[str, str, int]:
        task = owner[guid]
        # IFC2X3 tasks have a TaskId instead of an Identification
        identification = getattr(task, "Identification", None) or getattr(task, "TaskId", None)
        return (_start_key(task), str(identification or task.Name or ""), task.id())

    return priority_topological_order(predecessors, key)
