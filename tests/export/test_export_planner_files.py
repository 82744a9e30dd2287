"""Schedules out to MS Project and P6 through ifc4d, read back by ifc4d, and in as a run's --sequence."""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import ifcopenshell
import ifcopenshell.api.attribute
import ifcopenshell.api.sequence
import pytest
from ifc4d.ifc2msp import Ifc2Msp
from ifc4d.msp2ifc import MSP2Ifc
from ifc4d.p62ifc import P62Ifc
from lxml import etree

from bimbot.export.planner_files import MSP_NS, schedule_model, write_msp, write_p6
from bimbot.export.run_data import RunData, load_run
from bimbot.services.planner.sources import PlanError, PlanSource, SourceKind, load_plan
from bimbot.shared.planner_schedules import ScheduleFormat, schedule_format

START = dt.datetime(2027, 3, 1, 7, 0)


@pytest.fixture(scope="module")
def run_data(frame_run: Path) -> RunData:
    return load_run(frame_run)


def _read_back(reader: MSP2Ifc | P62Ifc, path: Path) -> ifcopenshell.file:
    model = ifcopenshell.file(schema="IFC4")
    ifcopenshell.api.root.create_entity(model, ifc_class="IfcProject")
    reader.xml = str(path)
    reader.file = model
    reader.execute()
    return model


def test_ms_project_xml_reads_back_through_ifc4d_with_every_task(run_data: RunData, tmp_path: Path) -> None:
    path = tmp_path / "frame.xml"
    written = write_msp(run_data.schedule(), path, START)
    assert written == 28 * 5 and schedule_format(path) is ScheduleFormat.MSP
    back = _read_back(MSP2Ifc(), path)
    assert len(back.by_type("IfcTask")) == written
    edges = sum(len(preds) for preds in run_data.plan.predecessors.values())
    assert len(back.by_type("IfcRelSequence")) == edges + 28 * 3  # the plan's, and each component's steps
    durations = etree.parse(str(path)).findall(f".//{{{MSP_NS}}}Task/{{{MSP_NS}}}Duration")
    assert {duration.text for duration in durations} >= {"PT0H0M9S", "PT0H0M3S"}  # seconds, not days


def test_p6_xml_reads_back_through_ifc4d_with_activities_linked(run_data: RunData, tmp_path: Path) -> None:
    path = tmp_path / "frame-p6.xml"
    written = write_p6(run_data.schedule(), path, START)
    assert schedule_format(path) is ScheduleFormat.P6_XML
    back = _read_back(P62Ifc(), path)
    assert len(back.by_type("IfcTask")) == written
    for rel in back.by_type("IfcRelSequence"):  # P6 links activities (steps), never WBS nodes
        assert rel.RelatingProcess.TaskTime is not None and rel.RelatedProcess.TaskTime is not None


@pytest.mark.parametrize("writer", [write_msp, write_p6], ids=["msp", "p6"])
def test_a_written_schedule_drives_the_planner_as_sequence(run_data: RunData, writer, tmp_path: Path) -> None:
    path = tmp_path / "schedule.xml"
    writer(run_data.schedule(), path, START)
    plan = load_plan(run_data.manifest, run_data.build_dir, PlanSource(SourceKind.SEQUENCE, path))
    assert plan.order == run_data.plan.order
    assert dict(plan.predecessors) == dict(run_data.plan.predecessors)
    assert plan.warnings == ()


def test_tasks_without_globalids_match_by_name_and_the_rest_are_named(
    run_data: RunData, tmp_path: Path
) -> None:
    model = schedule_model(run_data.schedule(), START)
    for task in model.by_type("IfcTask"):  # a planner's own numbering, no GlobalIds
        ifcopenshell.api.attribute.edit_attributes(
            model, product=task, attributes={"Identification": str(task.id())}
        )
    (schedule,) = model.by_type("IfcWorkSchedule")
    ifcopenshell.api.sequence.add_task(model, work_schedule=schedule, name="Site set-up", identification="0")
    path = tmp_path / "by-name.xml"
    writer = Ifc2Msp()
    writer.file, writer.work_schedule, writer.xml = model, schedule, str(path)
    writer.execute()
    plan = load_plan(run_data.manifest, run_data.build_dir, PlanSource(SourceKind.SEQUENCE, path))
    assert plan.order == run_data.plan.order
    assert len(plan.warnings) == 1 and "1 task(s) matched no component" in plan.warnings[0]
    assert "'Site set-up'" in plan.warnings[0]


def test_a_schedule_matching_no_component_is_one_clear_error(run_data: RunData, tmp_path: Path) -> None:
    model = schedule_model(run_data.schedule(), START)
    for task in model.by_type("IfcTask"):
        ifcopenshell.api.attribute.edit_attributes(
            model, product=task, attributes={"Identification": str(task.id()), "Name": f"Task {task.id()}"}
        )
    path = tmp_path / "nothing.xml"
    writer = Ifc2Msp()
    writer.file, writer.work_schedule, writer.xml = model, model.by_type("IfcWorkSchedule")[0], str(path)
    writer.execute()
    with pytest.raises(PlanError, match="no task of the MS Project XML file matched a component"):
        load_plan(run_data.manifest, run_data.build_dir, PlanSource(SourceKind.SEQUENCE, path))


def test_a_broken_p6_file_is_one_clear_error(run_data: RunData, tmp_path: Path) -> None:
    path = tmp_path / "broken-p6.xml"
    path.write_text(
        '<APIBusinessObjects xmlns="http://xmlns.oracle.com/Primavera/P6/V8.3/API/BusinessObjects"/>'
    )
    with pytest.raises(PlanError, match="not a readable Primavera P6 XML file"):
        load_plan(run_data.manifest, run_data.build_dir, PlanSource(SourceKind.SEQUENCE, path))


def test_a_component_the_run_never_started_is_a_linked_p6_activity(run_data: RunData, tmp_path: Path) -> None:
    from bimbot.export.sim_schedule import sim_schedule

    guid = run_data.plan.order[-2]  # waited for by the last one
    journal = {key: value for key, value in run_data.journal.items() if key != guid}
    report = {
        **run_data.report,
        "components": [c for c in run_data.report["components"] if c["guid"] != guid],
    }
    schedule = sim_schedule(run_data.manifest, report, journal, run_data.plan)
    assert not schedule.component(guid).timed
    msp, p6 = tmp_path / "msp.xml", tmp_path / "p6.xml"
    write_msp(schedule, msp, START)
    write_p6(schedule, p6, START)
    from_msp, from_p6 = _read_back(MSP2Ifc(), msp), _read_back(P62Ifc(), p6)
    assert len(from_p6.by_type("IfcRelSequence")) == len(from_msp.by_type("IfcRelSequence"))
    (erect,) = [
        task for task in from_p6.by_type("IfcTask") if task.Name == f"erect {schedule.component(guid).name}"
    ]
    assert erect.TaskTime.ScheduleStart == erect.TaskTime.ScheduleFinish  # zero long, at the run's end


def test_a_p6_xer_is_told_by_its_header_and_read_by_ifc4d(run_data: RunData, tmp_path: Path) -> None:
    path = tmp_path / "programme.xer"
    path.write_text("ERMHDR\t19.12\t2027-03-01\tProject\tadmin\n%T\tPROJECT\n%E\n", encoding="utf-8")
    assert schedule_format(path) is ScheduleFormat.P6_XER
    with pytest.raises(PlanError, match="not a readable Primavera P6 XER file"):  # no project, no tasks
        load_plan(run_data.manifest, run_data.build_dir, PlanSource(SourceKind.SEQUENCE, path))
