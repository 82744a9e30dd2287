"""The summary's robot lines: busy time beside the makespan, with what of it lies outside the makespan."""

from __future__ import annotations

from bimbot.run import RunOutcome, summary_text


def _report(task_end_s: float) -> dict:
    components = [
        {"guid": "A", "name": "A", "state": "constructed", "released_s": 0.0, "constructed_s": 100.0},
        {"guid": "B", "name": "B", "state": "failed", "released_s": 10.0, "constructed_s": None},
    ]
    tasks = [
        {"task_id": "T1", "start_s": 0.0, "end_s": 100.0},
        {"task_id": "T2", "start_s": 100.0, "end_s": task_end_s},
    ]
    robot = {"type": "carrier", "tasks": tasks, "distance_m": 50.0, "busy_s": task_end_s}
    return {"components": components, "robots": {"r1": robot}, "totals": {"makespan_s": 100.0}}


def test_busy_time_after_the_last_construction_is_said_to_be_outside_the_makespan() -> None:
    line = next(
        line
        for line in summary_text(
            RunOutcome(exit_code=1, constructed=1, total=2, report=_report(160.0))
        ).splitlines()
        if line.startswith("r1")
    )
    assert "busy 160 s (60 s of it after the last construction, on tasks that built nothing more)" in line
    within = summary_text(RunOutcome(exit_code=1, constructed=1, total=2, report=_report(100.0)))
    assert "busy 100 s" in within and "after the last construction" not in within
