"""report.png draws the lifts again, zoomed in, where a long work in place squeezes them into a sliver
(shared/report/lifts_inset.py): the Revit house's 54 lifts took two hours beside 86 h of formwork."""

from __future__ import annotations

from functools import partial
from typing import Any

from matplotlib.figure import Figure

from bimbot.shared.report.lifts_inset import add_lifts_inset, lifting_robots
from bimbot.shared.report.png import draw_lane_tasks
from bimbot.shared.report.time_breaks import TimeBreaks

HOUR_S = 3600.0


def _report(lift_hours: list[tuple[float, float]]) -> dict[str, Any]:
    """Two carriers lifting studs in ``lift_hours`` (start, end; alternately), a crane idle, a concrete
    pump forming and pouring a slab from 10 h to 100 h."""
    components = [{"guid": "slab", "name": "Slab", "ifc_class": "IfcSlab", "method": "cast_in_place"}]
    tasks: dict[str, list[dict[str, Any]]] = {"r1": [], "r2": [], "r3": []}
    for index, (start_h, end_h) in enumerate(lift_hours):
        guid = f"stud{index}"
        components.append(
            {"guid": guid, "name": f"Stud {index}", "ifc_class": "IfcMember", "method": "lifted"}
        )
        robot = ("r1", "r2")[index % 2]
        tasks[robot].append({"guid": guid, "start_s": start_h * HOUR_S, "end_s": end_h * HOUR_S})
    tasks["r4"] = [{"guid": "slab", "start_s": 10 * HOUR_S, "end_s": 100 * HOUR_S}]
    types = {"r1": "carrier", "r2": "carrier", "r3": "tower_crane", "r4": "concrete_pump"}
    robots = {robot_id: {"type": types[robot_id], "tasks": tasks[robot_id]} for robot_id in types}
    return {"components": components, "robots": robots}


def _inset(report: dict[str, Any]) -> Any:
    ax = Figure().add_subplot()
    robot_ids = ["r1", "r2", "r3", "r4"]
    return ax, add_lifts_inset(
        ax, report, robot_ids, TimeBreaks(100 * HOUR_S), partial(draw_lane_tasks, colors={})
    )


def test_lifts_squeezed_beside_a_long_pour_are_drawn_again_zoomed_in_beside_them() -> None:
    report = _report([(50.0, 50.2), (50.1, 50.4), (50.4, 50.9), (51.0, 51.5)])
    assert lifting_robots(report, ["r1", "r2", "r3", "r4"]) == ["r1", "r2"]
    ax, found = _inset(report)
    assert found is not None
    inset, labels = found
    assert inset in ax.child_axes
    assert inset.get_xlim()[0] < 50.0 * HOUR_S < 51.5 * HOUR_S < inset.get_xlim()[1]
    assert [tick.get_text() for tick in inset.get_yticklabels()] == ["r1", "r2"]
    assert {label.get_text() for label in labels} == {"Stud 0", "Stud 1", "Stud 2", "Stud 3"}
    assert "50.0–51.5 h" in inset.get_title()


def test_lifts_spread_over_the_build_read_as_they_are() -> None:
    _, found = _inset(_report([(12.0, 12.5), (40.0, 41.0), (90.0, 91.0)]))
    assert found is None
