"""The simulated schedule written into an IFC4 model with ``ifcopenshell.api`` (sequence, resource, control).

One IfcWorkSchedule (in an IfcWorkPlan) holds one IfcTask per component, identified by the component's
GlobalId, with one sub-task per step of its method (``<GlobalId>.<step>``) chained finish-to-start. Panels
of one element sit under a task of their element. Each task has an IfcTaskTime (ScheduleStart, -Finish,
-Duration) from the project start plus sim time (:func:`bimbot.export.work_time.site_time`). The
planner's precedences are IfcRelSequence (finish-to-start) between component tasks. Each component is the
output of its task (IfcRelAssignsToProduct: the task constructs it, which is what 4D tools animate); each
robot of the run (the machines that pour or lay too) is an IfcConstructionEquipmentResource of the fleet's
crew (IfcCrewResource), assigned to the tasks it worked on (IfcRelAssignsToProcess). A working week, when
given, is the IfcWorkCalendar that controls the tasks.

Sequences are related before any task has a time, so ``assign_sequence`` has nothing to cascade and the
sim times stay as simulated (``edit_task_time`` would snap them to 09:00/17:00 of a working day).
"""

from __future__ import annotations

import datetime as dt
import itertools
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import ifcopenshell
import ifcopenshell.api.attribute
import ifcopenshell.api.control
import ifcopenshell.api.resource
import ifcopenshell.api.sequence

from bimbot.export.sim_schedule import ComponentWork, SimSchedule, Step
from bimbot.export.work_time import WorkWeek
from bimbot.shared.construction_methods import ConstructionMethod

Clock = Callable[[float], dt.datetime]  # sim seconds → the site's date and time
EVERY_DAY = WorkWeek(frozenset(range(7)), ((dt.time(0, 0), dt.time(23, 59, 59)),))


@dataclass
class WrittenSchedule:
    """What :func:`add_simulated_schedule` made: the schedule and its tasks and resources."""

    work_schedule: ifcopenshell.entity_instance
    calendar: ifcopenshell.entity_instance
    tasks: dict[str, ifcopenshell.entity_instance] = field(default_factory=dict)  # GUID → component task
    all_tasks: list[ifcopenshell.entity_instance] = field(default_factory=list)
    resources: dict[str, ifcopenshell.entity_instance] = field(default_factory=dict)  # robot id → equipment
    element_tasks: dict[str, ifcopenshell.entity_instance] = field(default_factory=dict)  # panelised

    @property
    def timed_tasks(self) -> int:
        return sum(1 for task in self.all_tasks if task.TaskTime is not None)


def add_simulated_schedule(
    model: ifcopenshell.file,
    schedule: SimSchedule,
    clock: Clock,
    *,
    week: WorkWeek | None = None,
    products: Mapping[str, ifcopenshell.entity_instance] | None = None,
    element_names: Mapping[str, str] | None = None,
    link_steps: bool = False,
) -> WrittenSchedule:
    """Write ``schedule`` into ``model`` (IFC4); ``products`` (GUID → product, components and panelised
    elements) become the tasks' outputs. ``element_names``: a panelised element's GUID → its name.
    ``link_steps``: precedences from a predecessor's last step to the successor's first, and a component
    without steps gets one (``erect``; zero long at the run's end when the run never started it), for
    tools such as P6 whose activities have dates and links, and whose WBS nodes have neither."""
    products = products or {}
    plan = ifcopenshell.api.sequence.add_work_plan(model, name="bimbot")
    work_schedule = ifcopenshell.api.sequence.add_work_schedule(
        model,
        name=f"Simulated construction of {schedule.name}",
        predefined_type="PLANNED",
        start_time=ifc_datetime(clock(0.0)),
        work_plan=plan,
    )
    calendar = _calendar(model, week or EVERY_DAY, "Site working week" if week else "Continuous")
    written = WrittenSchedule(work_schedule, calendar)
    _add_resources(model, schedule, written)
    for work in schedule.components:
        parent = _element_task(model, work, written, element_names or {}, products)
        task = _task(model, written, work.task_name, work.guid, parent)
        ifcopenshell.api.attribute.edit_attributes(
            model,
            product=task,
            attributes={"Description": f"{work.method.value}; {work.ifc_class}", "Status": work.state},
        )
        written.tasks[work.guid] = task
        steps = [
            _task(model, written, f"{step.name} {work.name}", f"{work.guid}.{step.name}", task)
            for step in _steps(work, one_at_least=link_steps, end_s=schedule.end_s)
        ]
        for before, after in itertools.pairwise(steps):
            ifcopenshell.api.sequence.assign_sequence(model, relating_process=before, related_process=after)
        if work.guid in products:
            ifcopenshell.api.sequence.assign_product(
                model, relating_product=products[work.guid], related_object=task
            )
        _assign_resources(model, work, task, written)
    for work in schedule.components:
        for predecessor in work.predecessors:
            if predecessor in written.tasks:
                before, after = written.tasks[predecessor], written.tasks[work.guid]
                if link_steps:
                    before = (_subtasks(before) or [before])[-1]
                    after = (_subtasks(after) or [after])[0]
                ifcopenshell.api.sequence.assign_sequence(
                    model, relating_process=before, related_process=after
                )
    ifcopenshell.api.control.assign_control(
        model, relating_control=calendar, related_objects=list(_top_tasks(written))
    )
    for work in schedule.components:
        _time(model, written.tasks[work.guid], work.start_s, finish_s=work.finish_s, clock=clock, week=week)
        for step, step_task in zip(
            _steps(work, one_at_least=link_steps, end_s=schedule.end_s),
            _subtasks(written.tasks[work.guid]),
            strict=False,
        ):
            _time(model, step_task, step.start_s, finish_s=step.finish_s, clock=clock, week=week)
    for guid, element_task in written.element_tasks.items():
        panels = [work for work in schedule.components if work.parent_guid == guid and work.timed]
        if panels:
            start = min(work.start_s for work in panels if work.start_s is not None)
            finish = max(work.finish_s for work in panels if work.finish_s is not None)
            _time(model, element_task, start, finish_s=finish, clock=clock, week=week)
    return written


def _steps(work: ComponentWork, *, one_at_least: bool, end_s: float) -> tuple[Step, ...]:
    """The component's steps; with ``one_at_least``, a single ``erect`` over its span when it has none
    (a component the run never started: zero long at the run's end ``end_s``, not built by then)."""
    if work.steps or not one_at_least:
        return work.steps
    if work.start_s is None or work.finish_s is None:
        return (Step("erect", end_s, end_s),)
    return (Step("erect", work.start_s, work.finish_s),)


def _task(
    model: ifcopenshell.file,
    written: WrittenSchedule,
    name: str,
    identification: str,
    parent: ifcopenshell.entity_instance | None,
) -> ifcopenshell.entity_instance:
    task = ifcopenshell.api.sequence.add_task(
        model,
        work_schedule=None if parent is not None else written.work_schedule,
        parent_task=parent,
        name=name,
        identification=identification,
        predefined_type="CONSTRUCTION",
    )
    # add_task numbers a sub-task after its parent (<parent>.1); the GlobalId-based one says what it is
    ifcopenshell.api.attribute.edit_attributes(
        model, product=task, attributes={"Identification": identification}
    )
    written.all_tasks.append(task)
    return task


def _subtasks(task: ifcopenshell.entity_instance) -> list[ifcopenshell.entity_instance]:
    return [item for rel in task.IsNestedBy or [] for item in rel.RelatedObjects if item.is_a("IfcTask")]


def _top_tasks(written: WrittenSchedule) -> list[ifcopenshell.entity_instance]:
    return [item for rel in written.work_schedule.Controls or [] for item in rel.RelatedObjects]


def _element_task(
    model: ifcopenshell.file,
    work: ComponentWork,
    written: WrittenSchedule,
    element_names: Mapping[str, str],
    products: Mapping[str, ifcopenshell.entity_instance],
) -> ifcopenshell.entity_instance | None:
    """A panel's parent task: its element's (made on its first panel), the element as its output."""
    if work.parent_guid is None:
        return None
    task = written.element_tasks.get(work.parent_guid)
    if task is None:
        name = element_names.get(work.parent_guid, work.parent_guid)
        title = {
            ConstructionMethod.CAST_IN_PLACE: f"Cast {name} (in bays)",
            ConstructionMethod.LAID: f"Lay {name} (in stretches)",
        }.get(work.method, f"Erect {name} (precast panels)")
        task = _task(model, written, title, work.parent_guid, None)
        written.element_tasks[work.parent_guid] = task
        if work.parent_guid in products:
            ifcopenshell.api.sequence.assign_product(
                model, relating_product=products[work.parent_guid], related_object=task
            )
    return task


def _calendar(model: ifcopenshell.file, week: WorkWeek, name: str) -> ifcopenshell.entity_instance:
    calendar = ifcopenshell.api.sequence.add_work_calendar(model, name=name)
    work_time = ifcopenshell.api.sequence.add_work_time(
        model, work_calendar=calendar, time_type="WorkingTimes"
    )
    ifcopenshell.api.attribute.edit_attributes(model, product=work_time, attributes={"Name": week.text})
    pattern = ifcopenshell.api.sequence.assign_recurrence_pattern(
        model, parent=work_time, recurrence_type="WEEKLY"
    )
    ifcopenshell.api.sequence.edit_recurrence_pattern(
        model,
        recurrence_pattern=pattern,
        attributes={"WeekdayComponent": [day + 1 for day in sorted(week.days)]},
    )
    for start, end in week.periods:
        ifcopenshell.api.sequence.add_time_period(
            model, recurrence_pattern=pattern, start_time=start, end_time=end
        )
    return calendar


def _add_resources(model: ifcopenshell.file, schedule: SimSchedule, written: WrittenSchedule) -> None:
    """The run's robots (pumps and block layers too) as construction equipment of one crew, the fleet."""
    fleet = ifcopenshell.api.resource.add_resource(
        model, ifc_class="IfcCrewResource", name="Robot fleet", predefined_type="SITE"
    )
    for robot_id, robot_type in schedule.robot_types.items():
        robot = ifcopenshell.api.resource.add_resource(
            model,
            parent_resource=fleet,
            ifc_class="IfcConstructionEquipmentResource",
            name=f"{robot_id} ({robot_type})",
            predefined_type="ERECTING",
        )
        ifcopenshell.api.attribute.edit_attributes(
            model, product=robot, attributes={"Identification": robot_id, "Description": robot_type}
        )
        written.resources[robot_id] = robot


def _assign_resources(
    model: ifcopenshell.file,
    work: ComponentWork,
    task: ifcopenshell.entity_instance,
    written: WrittenSchedule,
) -> None:
    for robot_id in work.robot_ids:
        if robot_id in written.resources:
            ifcopenshell.api.sequence.assign_process(
                model, relating_process=task, related_object=written.resources[robot_id]
            )


def _time(
    model: ifcopenshell.file,
    task: ifcopenshell.entity_instance,
    start_s: float | None,
    *,
    finish_s: float | None,
    clock: Clock,
    week: WorkWeek | None,
) -> None:
    """IfcTaskTime with the site's start and finish of ``[start_s, finish_s]`` (none when not timed)."""
    if start_s is None or finish_s is None:
        return
    task_time = ifcopenshell.api.sequence.add_task_time(model, task=task)
    ifcopenshell.api.attribute.edit_attributes(
        model,
        product=task_time,
        attributes={
            "ScheduleStart": ifc_datetime(clock(start_s)),
            "ScheduleFinish": ifc_datetime(clock(finish_s)),
            "ScheduleDuration": ifc_duration(finish_s - start_s),
            "DurationType": "WORKTIME" if week is not None else "ELAPSEDTIME",
        },
    )


def ifc_datetime(moment: dt.datetime) -> str:
    """IfcDateTime to the second (``2027-03-01T07:00:31``)."""
    return moment.replace(microsecond=0).isoformat()


def ifc_duration(seconds: float) -> str:
    """IfcDuration (ISO 8601) to the millisecond: ``PT1H2M3.4S``."""
    millis = round(max(seconds, 0.0) * 1000)
    hours, rest = divmod(millis, 3_600_000)
    minutes, rest = divmod(rest, 60_000)
    return f"PT{hours}H{minutes}M{rest / 1000:g}S"
