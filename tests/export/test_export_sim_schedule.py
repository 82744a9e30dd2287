"""The simulated schedule: a task per component, its method's steps and times, sim time on a calendar."""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import pytest

from bimbot.export.run_data import load_run
from bimbot.export.sim_schedule import PlanView, method_steps, sim_schedule
from bimbot.export.work_time import parse_work_week, site_time
from bimbot.shared.construction_methods import CastWork, ConstructionMethod
from bimbot.shared.errors import UserError


def test_every_component_gets_a_task_in_plan_order_with_the_lifted_steps(frame_run: Path) -> None:
    data = load_run(frame_run)
    schedule = data.schedule()
    assert [work.guid for work in schedule.components] == list(data.plan.order)
    assert data.started == dt.datetime(2027, 3, 1, 7, 0)
    first, second = schedule.components[0], schedule.components[1]
    assert (first.start_s, first.finish_s, first.robot_ids, first.state) == (0.0, 9.0, ("r1",), "constructed")
    assert [(step.name, step.start_s, step.finish_s) for step in first.steps] == [
        ("pick", 0.0, 3.0),
        ("carry", 3.0, 6.0),
        ("place", 6.0, 8.0),
        ("connect", 8.0, 9.0),
    ]
    assert second.predecessors and set(second.predecessors) == set(data.plan.predecessors[second.guid])
    assert schedule.robot_types == {"r1": "husky", "r2": "carrier"}


def test_a_failed_component_keeps_its_reason_and_the_steps_it_reached(frame_run: Path) -> None:
    last = load_run(frame_run).schedule().components[-1]
    assert last.state == "failed" and last.reason is not None and last.reason.startswith("misplaced:")
    assert [step.name for step in last.steps] == ["pick", "carry", "place", "connect"]
    assert last.steps[-1].finish_s == last.finish_s == 279.0


def test_cast_in_place_and_laid_components_get_their_own_steps(frame_run: Path) -> None:
    manifest = load_run(frame_run).manifest
    footing = manifest.components[0]
    cast = footing.model_copy(
        update={
            "method": ConstructionMethod.CAST_IN_PLACE,
            "cast": CastWork(formwork_area_m2=4.0, volume_m3=1.0, formwork_s=20.0, pour_s=10.0, cure_s=70.0),
        }
    )
    steps = method_steps(cast, [], 100.0, 150.0)  # the run timed it in 50 s: the steps keep proportions
    assert [(step.name, step.start_s, step.finish_s) for step in steps] == [
        ("formwork", 100.0, 110.0),
        ("pour", 110.0, 115.0),
        ("cure", 115.0, 150.0),
    ]
    states = [("forming", 100.0), ("pouring", 120.0), ("verifying", 130.0), ("constructed", 131.0)]
    assert [(s.name, s.start_s, s.finish_s) for s in method_steps(cast, states, 100.0, 131.0)] == [
        ("formwork", 100.0, 120.0),
        ("pour", 120.0, 130.0),
        ("cure", 131.0, 201.0),  # cure_s after it was constructed: what rests on it waits
    ]
    laid = footing.model_copy(update={"method": ConstructionMethod.LAID})
    laying = [("released", 0.0), ("laying", 5.0), ("verifying", 20.0), ("constructed", 25.0)]
    assert [(s.name, s.start_s, s.finish_s) for s in method_steps(laid, laying, 5.0, 25.0)] == [
        ("lay", 5.0, 25.0)
    ]
    assert [(s.name, s.start_s, s.finish_s) for s in method_steps(laid, [], 5.0, 25.0)] == [
        ("lay", 5.0, 25.0)
    ]
    assert method_steps(laid, [], None, None) == ()


def test_a_cast_component_s_task_ends_when_it_has_cured(frame_run: Path) -> None:
    data = load_run(frame_run)
    guid = data.plan.order[0]
    cast = CastWork(formwork_area_m2=4.0, volume_m3=1.0, formwork_s=2.0, pour_s=6.0, cure_s=600.0)
    components = [
        item.model_copy(update={"method": ConstructionMethod.CAST_IN_PLACE, "cast": cast})
        if item.guid == guid
        else item
        for item in data.manifest.components
    ]
    manifest = data.manifest.model_copy(update={"components": components})
    journal = {
        **data.journal,
        guid: [("forming", 0.0), ("pouring", 2.0), ("verifying", 8.0), ("constructed", 9.0)],
    }
    work = sim_schedule(manifest, data.report, journal, data.plan).component(guid)
    assert [step.name for step in work.steps] == ["formwork", "pour", "cure"]
    assert (work.start_s, work.finish_s) == (0.0, 609.0)


def test_a_component_the_run_never_started_has_no_times(frame_run: Path) -> None:
    data = load_run(frame_run)
    guid = data.plan.order[3]
    journal = {key: value for key, value in data.journal.items() if key != guid}
    report = {**data.report, "components": [c for c in data.report["components"] if c["guid"] != guid]}
    plan = PlanView(data.plan.order, data.plan.predecessors, data.plan.task_ids, data.plan.names)
    work = sim_schedule(data.manifest, report, journal, plan).component(guid)
    assert (work.start_s, work.finish_s, work.steps, work.timed) == (None, None, (), False)


def test_sim_time_counts_the_working_week_when_given() -> None:
    week = parse_work_week("Mon-Fri 07:00-12:00 13:00-17:00")
    friday = dt.datetime(2027, 3, 5, 16, 50)
    assert site_time(friday, 600.0) == dt.datetime(2027, 3, 5, 17, 0)  # elapsed time without a calendar
    assert site_time(friday, 1200.0, week) == dt.datetime(2027, 3, 8, 7, 10)  # Monday morning
    assert site_time(dt.datetime(2027, 3, 1, 11, 0), 2 * 3600.0, week) == dt.datetime(2027, 3, 1, 14, 0)
    assert site_time(dt.datetime(2027, 3, 6, 9, 0), 0.0, week) == dt.datetime(2027, 3, 8, 7, 0)  # a Saturday


@pytest.mark.parametrize(
    "text", ["Mon-Fri", "Xyz 07:00-17:00", "Mon-Fri 17:00-07:00", "Mon 07:00-12:00 11:00-13:00"]
)
def test_a_bad_calendar_is_one_clear_error(text: str) -> None:
    with pytest.raises(UserError, match="--calendar"):
        parse_work_week(text)
