"""Utilisation is the share of the makespan (first release → last construction) the robots worked: a task
that goes on after the last component was built counts only up to there (a run once reported 116 %)."""

from __future__ import annotations

from typing import Any

import pytest

from bimbot.shared.report.fleet import by_type, percent
from bimbot.shared.report.totals import busy_within_s, makespan_window, totals_of


def _component(released_s: float | None, constructed_s: float | None, state: str) -> dict[str, Any]:
    return {
        "state": state,
        "released_s": released_s,
        "constructed_s": constructed_s,
        "position_error_mm": None,
        "angle_error_deg": None,
        "retries": 0,
        "give_backs": [],
    }


def _robot(*tasks: tuple[float, float], robot_type: str = "carrier") -> dict[str, Any]:
    intervals = [{"start_s": start, "end_s": end} for start, end in tasks]
    return {
        "type": robot_type,
        "busy_s": sum(end - start for start, end in tasks),
        "distance_m": 0.0,
        "tasks": intervals,
    }


COMPONENTS = [_component(10.0, 60.0, "constructed"), _component(10.0, 110.0, "constructed")]
COMPONENTS += [_component(20.0, None, "failed")]


def test_busy_time_after_the_last_construction_does_not_count() -> None:
    robot = _robot((10.0, 60.0), (60.0, 110.0), (110.0, 400.0))  # the last task failed long after
    assert makespan_window(COMPONENTS) == (10.0, 110.0)
    assert busy_within_s(robot, (10.0, 110.0)) == pytest.approx(100.0)
    totals = totals_of(COMPONENTS, {"r1": robot})
    assert totals["busy_s"] == pytest.approx(390.0), "busy time itself is all of it"
    assert totals["utilisation"] == pytest.approx(1.0)
    assert by_type({"r1": robot}, makespan_window(COMPONENTS))["carrier"]["utilisation"] == pytest.approx(1.0)


def test_utilisation_never_exceeds_one_and_is_none_before_anything_is_built() -> None:
    robots = {"r1": _robot((0.0, 500.0)), "r2": _robot((30.0, 70.0), robot_type="husky")}
    totals = totals_of(COMPONENTS, robots)
    assert totals["utilisation"] == pytest.approx((100.0 + 40.0) / (2 * 100.0))
    kinds = by_type(robots, makespan_window(COMPONENTS))
    assert kinds["carrier"]["utilisation"] == pytest.approx(1.0)
    assert kinds["husky"]["utilisation"] == pytest.approx(0.4)
    nothing_built = [_component(10.0, None, "failed")]
    assert totals_of(nothing_built, robots)["utilisation"] is None
    assert by_type(robots, makespan_window(nothing_built))["husky"]["utilisation"] is None


def test_a_long_cure_in_the_makespan_gives_the_utilisation_while_some_robot_was_at_work_too() -> None:
    """A crane busy 2 h of a 100 h makespan, 90 h of it a cure with nothing at work: 2 % of the makespan,
    and 20 % of the 10 h some robot was at work (overlapping tasks count once)."""
    from bimbot.shared.report.fleet import utilisation_line, working_within_s

    hour = 3600.0
    robots = {
        "r1": _robot((0.0, 2 * hour), robot_type="tower_crane"),
        "r2": _robot((1 * hour, 6 * hour), (96 * hour, 100 * hour), robot_type="concrete_pump"),
    }
    window = (0.0, 100 * hour)
    assert working_within_s(robots.values(), window) == pytest.approx(10 * hour)
    types = by_type(robots, window)
    assert types["tower_crane"]["utilisation"] == pytest.approx(0.02)
    assert types["tower_crane"]["utilisation_at_work"] == pytest.approx(0.2)
    assert types["concrete_pump"]["utilisation_at_work"] == pytest.approx(0.9)
    line = utilisation_line({"totals": {"by_type": types, "makespan_s": 100 * hour, "working_s": 10 * hour}})
    assert line is not None
    assert "tower_crane 2 % (1 robot)" in line
    assert (
        "while some robot was at work (10.0 h (36,000 s) of it): tower_crane 20 %, concrete_pump 90 %" in line
    )
    busy = by_type({"r1": _robot((0.0, 90 * hour))}, window)  # at work most of the makespan: no second part
    assert "while some robot" not in (
        utilisation_line({"totals": {"by_type": busy, "makespan_s": 100 * hour, "working_s": 90 * hour}})
        or ""
    )


def test_a_share_that_rounds_to_nothing_is_said_under_one_percent() -> None:
    """The house's Husky built 23 components in 0.4 % of an 8.8-day makespan: "husky 0 %" read as idle."""
    assert [percent(share) for share in (0.0, 0.0041, 0.005, 0.45)] == ["0 %", "<1 %", "<1 %", "45 %"]
