"""Reading a run's outcome from its report and telling two runs apart (bimbot.run.outcome)."""

from __future__ import annotations

import copy

from bimbot.run.outcome import differences, outcome, spread


def _report(makespan_s: float = 100.0) -> dict:
    return {
        "components": [
            {
                "guid": "A",
                "state": "constructed",
                "method": "lifted",
                "robot_ids": ["r1"],
                "attempts": 1,
                "constructed_s": 10.0,
            },
            {
                "guid": "B",
                "state": "constructed",
                "method": "lifted",
                "robot_ids": ["r2"],
                "attempts": 1,
                "constructed_s": 20.0,
            },
        ],
        "robots": {"r1": {"tasks": [{"guid": "A"}]}, "r2": {"tasks": [{"guid": "B"}]}},
        "totals": {"makespan_s": makespan_s, "constructed": 2},
    }


def test_the_same_report_has_no_differences_and_makespans_within_one_percent_count_as_the_same() -> None:
    assert differences(outcome(_report()), outcome(_report(100.9))) == []
    assert differences(outcome(_report()), outcome(_report(102.0))) == [
        "makespan 100.0 s → 102.0 s (beyond 1%)"
    ]


def test_another_robot_or_order_is_named() -> None:
    other = copy.deepcopy(_report())
    other["components"][0]["robot_ids"] = ["r2"]
    other["components"][0]["constructed_s"] = 30.0
    other["robots"] = {"r1": {"tasks": []}, "r2": {"tasks": [{"guid": "B"}, {"guid": "A"}]}}
    lines = differences(outcome(_report()), outcome(other))
    assert "A: robot_ids r1 → r2" in lines
    assert any(line.startswith("construction order differs from position 1") for line in lines)
    assert any(line.startswith("r2: tasks 1 → 2") for line in lines)


def test_the_spread_over_seeds_gives_median_range_and_the_components_that_vary() -> None:
    failed = copy.deepcopy(_report(130.0))
    failed["components"][1]["state"] = "failed"
    failed["totals"]["constructed"] = 1
    figure = spread([outcome(_report(100.0)), outcome(_report(110.0)), outcome(failed)])
    assert figure.makespan_median_s == 110.0 and figure.makespan_range_s == (100.0, 130.0)
    assert figure.constructed_range == (1, 2) and figure.constructed_median == 2
    assert list(figure.varying) == ["B"]
