"""The sequence the converter writes: the IFC model's own schedule when it has one, else derived.

A schedule that leaves some components out gets them appended in derived (support-graph) order, with
their supports as predecessors; a schedule whose precedence has a cycle is reported and replaced by the
derived sequence. Either way every component appears exactly once. The panels of a panelised element
take its place in the schedule (its task names the element, not its panels), in the order they rest on
one another.
"""

from __future__ import annotations

import ifcopenshell

from bimbot.shared.ifc_schedule import schedule_from_ifc, with_stand_ins
from bimbot.shared.manifest import Component, Joint
from bimbot.shared.sequence import ConstructionSequence, SequenceError, SequenceTask, check_sequence
from bimbot.shared.support_graph import derive_sequence, support_predecessors


def construction_sequence(
    model: ifcopenshell.file, components: list[Component], joints: list[Joint] | None = None
) -> tuple[ConstructionSequence, list[str]]:
    """(sequence, warnings) for ``components`` (``joints``: the pairs drawn into each other, which the
    support graph orders)."""
    support = support_predecessors(components, joints=joints or ())
    derived = derive_sequence(components, support=support)
    panels: dict[str, list[str]] = {}
    for component in components:
        if component.parent_guid:
            panels.setdefault(component.parent_guid, []).append(component.guid)
    whole = [component.guid for component in components if not component.parent_guid]
    try:
        schedule = schedule_from_ifc(model, [*whole, *panels])
        if schedule is not None and panels:
            schedule = with_stand_ins(schedule, panels, support)
    except SequenceError as error:
        return derived, [f"IFC schedule not usable ({error}); construction sequence derived from supports"]
    if schedule is None:
        return derived, []
    if not schedule.unscheduled:
        return schedule.sequence, []
    missing = set(schedule.unscheduled)
    tasks = list(schedule.sequence.tasks)
    task_of_guid = {task.guid: task.task_id for task in tasks}
    derived_ids = {task.task_id: task.guid for task in derived.tasks}
    next_index = len(tasks) + 1
    for task in derived.tasks:
        if task.guid not in missing:
            continue
        new_id = f"T{next_index:04d}"
        next_index += 1
        preds = tuple(
            task_of_guid[derived_ids[pred]] for pred in task.predecessors if derived_ids[pred] in task_of_guid
        )
        tasks.append(SequenceTask(task_id=new_id, guid=task.guid, name=task.name, predecessors=preds))
        task_of_guid[task.guid] = new_id
    sequence = ConstructionSequence(source="ifc_schedule+derived", tasks=tuple(tasks))
    check_sequence(sequence)
    warning = f"{len(missing)} component(s) have no task in the IFC schedule; appended in derived order"
    return sequence, [warning]
