"""The simulated schedule as MS Project XML and Primavera P6 XML, written by IfcOpenShell's ``ifc4d``.

The schedule goes into a small IFC4 of its own (project, work schedule, calendar, tasks, sequences,
resources: :func:`bimbot.export.ifc_tasks.add_simulated_schedule`, no building), which ``ifc4d``'s
``Ifc2Msp`` / ``Ifc2P6`` turn into the planners' files. A component is a summary task (MS Project) or a WBS
node (P6) identified by its GlobalId, its method's steps the tasks under it; P6 links activities only, so
there the precedences run from a predecessor's last step to the successor's first, and a component the run
never started is one zero-long activity at the run's end (P6 activities have dates).

``Ifc2Msp`` writes durations in whole eight-hour days, which rounds a robot's minutes to zero: the written
file's ``Duration`` of each task is set again from its IfcTaskTime, to the second.
"""

from __future__ import annotations

import contextlib
import datetime as dt
import io
import logging
from collections.abc import Callable
from pathlib import Path

import ifcopenshell
import ifcopenshell.api.root
import ifcopenshell.api.unit
import ifcopenshell.util.date
from lxml import etree

from bimbot.export.ifc_tasks import add_simulated_schedule
from bimbot.export.sim_schedule import SimSchedule
from bimbot.export.work_time import WorkWeek, site_time

_log = logging.getLogger(__name__)

MSP_NS = "http://schemas.microsoft.com/project"


def schedule_model(
    schedule: SimSchedule, start: dt.datetime, week: WorkWeek | None = None, *, link_steps: bool = False
) -> ifcopenshell.file:
    """An IFC4 holding only the simulated schedule (what the planners' files are written from)."""
    model = ifcopenshell.file(schema="IFC4")
    ifcopenshell.api.root.create_entity(model, ifc_class="IfcProject", name=schedule.name)
    ifcopenshell.api.unit.assign_unit(model)
    add_simulated_schedule(
        model, schedule, lambda sim_s: site_time(start, sim_s, week), week=week, link_steps=link_steps
    )
    return model


def write_msp(schedule: SimSchedule, out: Path, start: dt.datetime, week: WorkWeek | None = None) -> int:
    """MS Project XML of ``schedule`` at ``out``; the number of tasks written."""
    from ifc4d.ifc2msp import Ifc2Msp

    model = schedule_model(schedule, start, week)
    writer = Ifc2Msp()
    writer.file = model
    writer.work_schedule = model.by_type("IfcWorkSchedule")[0]
    writer.xml = str(out)
    _quietly(writer.execute)
    _msp_durations(out, model)
    return len(model.by_type("IfcTask"))


def write_p6(schedule: SimSchedule, out: Path, start: dt.datetime, week: WorkWeek | None = None) -> int:
    """Primavera P6 XML of ``schedule`` at ``out``; the number of tasks written (WBS nodes and activities)."""
    from ifc4d.ifc2p6 import Ifc2P6

    model = schedule_model(schedule, start, week, link_steps=True)
    writer = Ifc2P6()
    writer.file = model
    writer.xml = str(out)
    finish = site_time(start, schedule.end_s, week)
    writer.holiday_start_date, writer.holiday_finish_date = start, finish  # the span holidays are listed for
    _quietly(writer.execute)
    return len(model.by_type("IfcTask"))


def _quietly(action: Callable[[], object]) -> None:
    """Run an ``ifc4d`` writer; what it prints goes to the debug log, not the user's terminal."""
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        action()
    if printed.getvalue():
        _log.debug("ifc4d: %s", printed.getvalue().strip())


def _msp_durations(path: Path, model: ifcopenshell.file) -> None:
    """Each MS Project task's Duration from its IfcTaskTime (the task's UID is its IFC step id)."""
    tree = etree.parse(str(path))
    namespaces = {"p": MSP_NS}
    for task in tree.iterfind(".//p:Tasks/p:Task", namespaces):
        uid = task.findtext("p:UID", namespaces=namespaces)
        entity = model.by_id(int(uid)) if uid and uid.isdigit() else None
        task_time = getattr(entity, "TaskTime", None)
        if task_time is None or not task_time.ScheduleDuration:
            continue
        seconds = int(ifcopenshell.util.date.ifc2datetime(task_time.ScheduleDuration).total_seconds())
        duration = task.find("p:Duration", namespaces)
        if duration is None:
            duration = etree.SubElement(task, f"{{{MSP_NS}}}Duration")
        duration.text = f"PT{seconds // 3600}H{seconds % 3600 // 60}M{seconds % 60}S"
    tree.write(str(path), encoding="utf-8", xml_declaration=True)
