"""The 4D IFC: the source model with the simulated schedule, resources, as-built results and panels, valid,
and converting it back gives the run's order."""

from __future__ import annotations

import datetime as dt
import shutil
from pathlib import Path

import ifcopenshell
import ifcopenshell.util.element
import ifcopenshell.util.sequence
import pytest
from converter.ifc_builders import add_beam, new_model, translation
from export_runs import write_run
from sample_builds import converted_sample

from bimbot.export.ifc_as_built import AS_BUILT_PSET
from bimbot.export.ifc_export import IfcExport, export_ifc, validate_ifc
from bimbot.export.run_data import RunData, load_run
from bimbot.export.sim_schedule import PlanView, sim_schedule
from bimbot.services.converter.convert import convert_model
from bimbot.shared.construction_methods import ConstructionMethod, PanelisedElement
from bimbot.shared.manifest import read_manifest
from bimbot.shared.sequence import read_sequence

START = dt.datetime(2027, 3, 1, 7, 0)


def simulated_tasks(model: ifcopenshell.file) -> list[ifcopenshell.entity_instance]:
    """The tasks of the export's work schedule (the bundled frame has a schedule of its own too)."""
    (schedule,) = [item for item in model.by_type("IfcWorkSchedule") if item.Name.startswith("Simulated")]
    return list(ifcopenshell.util.sequence.get_work_schedule_tasks(schedule))


@pytest.fixture(scope="module")
def exported(frame_run: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[RunData, IfcExport]:
    data = load_run(frame_run)
    out = tmp_path_factory.mktemp("ifc") / "frame-4d.ifc"
    return data, export_ifc(data.manifest, data.build_dir, data.schedule(), out, START)


def test_the_export_validates_with_a_timed_task_per_component_and_step(
    exported: tuple[RunData, IfcExport],
) -> None:
    data, result = exported
    assert validate_ifc(result.path) == []
    model = ifcopenshell.open(str(result.path))
    assert model.schema == "IFC4"
    tasks = {task.Identification: task for task in simulated_tasks(model)}
    timed = [task for task in tasks.values() if task.TaskTime is not None]
    assert result.component_tasks == 28 and len(timed) == result.timed_tasks == 28 * 5
    first = data.schedule().components[0]
    task = tasks[first.guid]
    assert (task.TaskTime.ScheduleStart, task.TaskTime.ScheduleFinish) == (
        "2027-03-01T07:00:00",
        "2027-03-01T07:00:09",
    )
    steps = ifcopenshell.util.sequence.get_nested_tasks(task)
    assert [step.Identification for step in steps] == [
        f"{first.guid}.{name}" for name in ("pick", "carry", "place", "connect")
    ]
    assert steps[1].TaskTime.ScheduleStart == "2027-03-01T07:00:03"


def test_each_component_is_its_task_s_output_and_robots_are_equipment_of_its_tasks(
    exported: tuple[RunData, IfcExport],
) -> None:
    data, result = exported
    model = ifcopenshell.open(str(result.path))
    tasks = {task.Identification: task for task in simulated_tasks(model)}
    robots = {
        resource.Identification: resource for resource in model.by_type("IfcConstructionEquipmentResource")
    }
    assert set(robots) == {"r1", "r2"} and {r.Description for r in robots.values()} == {"husky", "carrier"}
    assert len(model.by_type("IfcCrewResource")) == 1  # the fleet the robots belong to
    for work in data.schedule().components:
        outputs = ifcopenshell.util.sequence.get_task_outputs(tasks[work.guid])
        assert [product.GlobalId for product in outputs] == [work.guid]
        resources = ifcopenshell.util.sequence.get_task_resources(tasks[work.guid])
        assert [resource.Identification for resource in resources] == list(work.robot_ids)


def test_the_planner_s_precedences_are_sequences_between_component_tasks(
    exported: tuple[RunData, IfcExport],
) -> None:
    data, result = exported
    model = ifcopenshell.open(str(result.path))
    components = {work.guid for work in data.schedule().components}
    links = {
        (rel.RelatingProcess.Identification, rel.RelatedProcess.Identification)
        for rel in model.by_type("IfcRelSequence")
        if rel.RelatingProcess.Identification in components
    }
    expected = {(before, guid) for guid, preds in data.plan.predecessors.items() for before in preds}
    assert links == expected and expected


def test_as_built_results_are_a_property_set_of_each_component(exported: tuple[RunData, IfcExport]) -> None:
    data, result = exported
    model = ifcopenshell.open(str(result.path))
    schedule = data.schedule()
    built, failed = schedule.components[0], schedule.components[-1]
    first = ifcopenshell.util.element.get_pset(model.by_guid(built.guid), AS_BUILT_PSET)
    assert first["State"] == "constructed" and first["Robots"] == "r1" and first["Method"] == "lifted"
    assert first["Attempts"] == 1 and "Reason" not in first
    last = ifcopenshell.util.element.get_pset(model.by_guid(failed.guid), AS_BUILT_PSET)
    assert last["State"] == "failed" and last["Reason"].startswith("misplaced: placed 52 mm off")


def test_converting_the_export_back_sequences_the_components_in_the_run_s_order(
    exported: tuple[RunData, IfcExport], tmp_path: Path
) -> None:
    data, result = exported
    manifest = convert_model(ifcopenshell.open(str(result.path)), result.path, tmp_path / "again")
    sequence = read_sequence(tmp_path / "again" / manifest.sequence_file)
    run_order = [
        work.guid for work in sorted(data.schedule().components, key=lambda work: work.start_s or 0.0)
    ]
    assert sequence.source == "ifc_schedule" and sequence.guids() == run_order
    again = {
        task.guid: {sequence.tasks[int(p[1:]) - 1].guid for p in task.predecessors} for task in sequence.tasks
    }
    assert again == {guid: set(preds) for guid, preds in data.plan.predecessors.items()}


def test_panels_become_parts_of_their_element_each_with_its_task(frame_run: Path, tmp_path: Path) -> None:
    data = load_run(frame_run)
    beam = next(component for component in data.manifest.components if component.ifc_class == "IfcBeam")
    halves = [
        beam.model_copy(
            update={
                "guid": guid,
                "name": f"{beam.name} panel {index}",
                "method": ConstructionMethod.PANELISED,
                "parent_guid": beam.guid,
            }
        )
        for index, guid in enumerate(("0PanelAAAAAAAAAAAAAAA1", "0PanelAAAAAAAAAAAAAAA2"), start=1)
    ]
    components = [item for item in data.manifest.components if item.guid != beam.guid] + halves
    element = PanelisedElement(
        guid=beam.guid,
        ifc_class="IfcBeam",
        name=beam.name,
        mass_kg=beam.mass_kg,
        panel_guids=(halves[0].guid, halves[1].guid),
        why="a test",
    )
    manifest = data.manifest.model_copy(update={"components": components, "panelised": [element]})
    journal = {
        **data.journal,
        halves[0].guid: [("picking", 500.0), ("constructed", 510.0)],
        halves[1].guid: [("picking", 520.0), ("constructed", 530.0)],
    }
    order = (*(guid for guid in data.plan.order if guid != beam.guid), halves[0].guid, halves[1].guid)
    schedule = sim_schedule(manifest, data.report, journal, PlanView(order, {}, {}, {}))
    result = export_ifc(manifest, data.build_dir, schedule, tmp_path / "panels.ifc", START)
    assert validate_ifc(result.path) == []
    model = ifcopenshell.open(str(result.path))
    parts = model.by_type("IfcBuildingElementPart")
    assert sorted(part.GlobalId for part in parts) == sorted(element.panel_guids)
    assert all(ifcopenshell.util.element.get_aggregate(part).GlobalId == beam.guid for part in parts)
    assert all(part.Representation is not None for part in parts)
    tasks = {task.Identification: task for task in simulated_tasks(model)}
    element_task = tasks[beam.guid]
    assert [t.Identification for t in ifcopenshell.util.sequence.get_nested_tasks(element_task)] == list(
        element.panel_guids
    )
    assert [p.GlobalId for p in ifcopenshell.util.sequence.get_task_outputs(element_task)] == [beam.guid]
    assert element_task.TaskTime.ScheduleStart == "2027-03-01T07:08:20"  # the first panel's pick, 500 s in


def test_an_ifc2x3_model_is_exported_as_valid_ifc4(tmp_path: Path) -> None:
    small = new_model("IFC2X3")
    add_beam(small, "Beam A", matrix_m=translation(0.0, 0.0, 0.0))
    add_beam(small, "Beam B", matrix_m=translation(0.0, 2.0, 0.0))
    source = tmp_path / "two-beams-2x3.ifc"
    small.file.write(str(source))
    build = tmp_path / "build"
    manifest = convert_model(ifcopenshell.open(str(source)), source, build)
    write_run(build, manifest, read_sequence(build / manifest.sequence_file).guids())
    data = load_run(build)
    result = export_ifc(data.manifest, build, data.schedule(), tmp_path / "two-beams-4d.ifc", START)
    assert result.migrated_from == "IFC2X3" and result.component_tasks == 2
    assert validate_ifc(result.path) == []
    model = ifcopenshell.open(str(result.path))
    assert model.schema == "IFC4" and {b.Name for b in model.by_type("IfcBeam")} == {"Beam A", "Beam B"}


def test_the_revit_house_exports_as_valid_ifc4(
    samples_dir: Path, tmp_path: Path, tmp_path_factory: pytest.TempPathFactory
) -> None:
    converted, manifest = converted_sample("revit2021_sample_project.ifc", tmp_path_factory)
    build = tmp_path / "house"
    shutil.copytree(converted, build, symlinks=True)  # the shared conversion stays as it is
    write_run(build, manifest, read_sequence(build / manifest.sequence_file).guids())
    data = load_run(build)
    result = export_ifc(read_manifest(build), build, data.schedule(), tmp_path / "house-4d.ifc", START)
    assert result.migrated_from == "IFC2X3" and result.timed_tasks >= len(manifest.components)
    assert validate_ifc(result.path) == []
    shutil.rmtree(build)


def test_the_fast_ifc2x3_upgrade_gives_what_the_migrator_gives() -> None:
    import collections
    import contextlib
    import io

    import ifcopenshell.util.schema

    from bimbot.export.ifc_upgrade import upgrade_to_ifc4

    small = new_model("IFC2X3")
    for index in range(3):
        add_beam(small, f"Beam {index}", matrix_m=translation(0.0, 2.0 * index, 0.0))
    fast, _ = upgrade_to_ifc4(small.file)
    slow = ifcopenshell.file(schema="IFC4")
    migrator = ifcopenshell.util.schema.Migrator()
    with contextlib.redirect_stdout(io.StringIO()):
        for element in small.file:
            migrator.migrate(element, slow)

    def content(model: ifcopenshell.file) -> collections.Counter[str]:
        return collections.Counter(
            repr(e.get_info(recursive=True, include_identifier=False)) for e in model.by_type("IfcRoot")
        )

    assert collections.Counter(e.is_a() for e in fast) == collections.Counter(e.is_a() for e in slow)
    assert content(fast) == content(slow)
