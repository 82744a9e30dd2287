"""``bimbot export``: every format from one run, one component for other simulators, bad input in one line."""

from __future__ import annotations

from pathlib import Path

import ifcopenshell
import pybullet as p
import pytest
from pxr import Usd

from bimbot.cli import main
from bimbot.shared.manifest import read_manifest


def test_one_command_writes_the_ifc_the_schedules_and_the_stage(
    frame_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    argv = ["export", str(frame_run), "--ifc", str(out / "frame.ifc"), "--msp", str(out / "msp.xml")]
    argv += ["--p6", str(out / "p6.xml"), "--usd", str(out / "frame.usda"), "--validate"]
    argv += ["--start", "2027-03-02T07:00", "--calendar", "Mon-Fri 07:00-17:00"]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "ifcopenshell.validate: 0 error(s)" in printed and "msp: " in printed and "p6: " in printed
    model = ifcopenshell.open(str(out / "frame.ifc"))
    (calendar,) = [item for item in model.by_type("IfcWorkCalendar") if item.Name == "Site working week"]
    assert calendar.WorkingTimes[0].RecurrencePattern.WeekdayComponent == (1, 2, 3, 4, 5)
    first = read_manifest(frame_run.parent.parent).components[0].guid  # the first of the run
    (task,) = [task for task in model.by_type("IfcTask") if task.Identification == first]
    assert task.TaskTime.ScheduleStart == "2027-03-02T07:00:00"
    assert (out / "msp.xml").stat().st_size > 0 and (out / "p6.xml").stat().st_size > 0
    assert Usd.Stage.Open(str(out / "frame.usda")).GetPrimAtPath("/World/Components")


def test_one_component_as_urdf_loads_in_pybullet_and_as_its_sdf_model_folder(
    frame_run: Path, tmp_path: Path
) -> None:
    build = frame_run.parent.parent
    component = read_manifest(build).components[0]
    urdf, sdf = tmp_path / "footing.urdf", tmp_path / "footing-sdf"
    argv = ["export", str(build), "--component", component.guid, "--urdf", str(urdf), "--sdf", str(sdf)]
    assert main(argv) == 0
    client = p.connect(p.DIRECT)
    try:
        body = p.loadURDF(str(urdf), physicsClientId=client)
        assert p.getDynamicsInfo(body, -1, physicsClientId=client)[0] == pytest.approx(
            component.mass_kg, rel=1e-5
        )
    finally:
        p.disconnect(client)
    assert (sdf / "model.sdf").is_file() and (sdf / "model.config").is_file()


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        ([], "name at least one output"),
        (["--ifc", "x.ifc", "--calendar", "weekdays"], "--calendar"),
        (["--ifc", "x.ifc", "--start", "soon"], "--start"),
        (["--usd", "x.obj"], "must end in .usda"),
        (["--urdf", "x.urdf"], "--component GUID"),
    ],
)
def test_bad_options_are_one_line_and_exit_2(
    frame_run: Path, extra: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["export", str(frame_run), *extra]) == 2
    error = capsys.readouterr().err.strip()
    assert error.startswith("bimbot export: error:") and message in error and len(error.splitlines()) == 1


def test_a_folder_that_is_no_run_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["export", str(tmp_path), "--ifc", str(tmp_path / "x.ifc")]) == 2
    assert "neither a build" in capsys.readouterr().err


def test_bimbot_run_from_ifc_reaches_the_planner_and_the_export_reads_the_same_plan(
    frame_run: Path, tmp_path: Path
) -> None:
    from bimbot.command_line import parse_arguments
    from bimbot.export.run_data import run_plan
    from bimbot.run.options import run_options
    from bimbot.run.settings import run_settings
    from bimbot.services.planner.sources import PlanSource, SourceKind, load_plan

    build = frame_run.parent.parent
    plain = run_options(parse_arguments(["run", str(build), "--from-ifc"]))
    named = run_options(parse_arguments(["run", str(build), "--from-ifc", "model.ifc", "--strict"]))
    assert plain.planner_source == ("--from-ifc",)
    assert named.planner_source == ("--from-ifc", "model.ifc", "--strict")
    settings = run_settings(plain)
    assert settings["sequence"] == "the IFC schedule of the build model"
    assert run_settings(named)["sequence"] == "the IFC schedule of model.ifc"
    manifest = read_manifest(build)
    plan = run_plan(manifest, build, {"settings": settings})
    ifc_plan = load_plan(manifest, build, PlanSource(SourceKind.IFC))
    assert plan.order == ifc_plan.order and dict(plan.predecessors) == dict(ifc_plan.predecessors)
