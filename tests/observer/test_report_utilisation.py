"""Utilisation is the share of the makespan (first release → last construction) the robots worked: a task
that goes on after the last component was built counts only up to there (a run once reported 116 %)."""

from __future__ import annotations

from typing import Any

import pytest

from bimbot.shared.report.fleet import by_type
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
