"""The summary: robot lines with busy time beside the makespan (and what of it lies outside it); placements
caught and retried."""

from __future__ import annotations

from bimbot.run.summary import RunOutcome, summary_text


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
    assert "busy 160.0 s, 60.0 s of it after the last construction, on tasks that built nothing more" in line
    within = summary_text(RunOutcome(exit_code=1, constructed=1, total=2, report=_report(100.0)))
    assert "busy 100.0 s" in within and "after the last construction" not in within


def test_a_caught_placement_on_a_components_last_attempt_is_counted_but_not_called_retried() -> None:
    report = _report(100.0)
    report["components"][1]["placements"] = [
        {"attempt": 1, "verdict": "misplaced", "cause": "unstable"},
        {"attempt": 2, "verdict": "failed", "cause": "unstable"},
    ]
    first = summary_text(RunOutcome(exit_code=1, constructed=1, total=2, misplacements=1, report=report))
    assert (
        "2 placement(s) caught off target or unstable: 1 retried, 1 on its component's last attempt"
        in first.splitlines()[0]
    )
    report["components"][1]["placements"] = report["components"][1]["placements"][:1]
    retried = summary_text(RunOutcome(exit_code=1, constructed=1, total=2, misplacements=1, report=report))
    assert "1 placement(s) caught off target or unstable and retried" in retried.splitlines()[0]


def test_a_run_without_connections_says_so_in_its_summary() -> None:
    report = _report(100.0)
    plain = summary_text(RunOutcome(exit_code=1, constructed=1, total=2, report=report))
    assert "without connections" not in plain
    report["settings"] = {"connections": False}
    unconnected = summary_text(RunOutcome(exit_code=1, constructed=1, total=2, report=report))
    assert "without connections (--no-connections): every component had to stand by itself" in unconnected


def test_the_last_line_says_why_the_exit_code_is_not_0() -> None:
    """The new-user trial saw ``bimbot run`` exit 1 with no line saying why."""
    report = _report(100.0)
    failed = summary_text(RunOutcome(exit_code=1, constructed=1, total=2, report=report)).splitlines()
    assert failed[-1] == "exit 1: 1 component(s) not built (the table above says why)"
    report["as_built"] = {"errors": 1}
    audited = summary_text(RunOutcome(exit_code=1, constructed=2, total=2, report=report)).splitlines()
    assert audited[-1].startswith("exit 1: the as-built audit found components away from their BIM targets")
    stopped = summary_text(RunOutcome(exit_code=130, constructed=1, total=2, report=_report(100.0)))
    assert stopped.splitlines()[-1].startswith("exit 130: stopped by a signal")
    done = summary_text(RunOutcome(exit_code=0, constructed=2, total=2, report=_report(100.0)))
    assert not any(line.startswith("exit") for line in done.splitlines())
