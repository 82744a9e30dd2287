"""The summary as a new user reads it: the wall time split as the run's ending counts it, one duration
format (the robots' busy times in one unit), an as-built line that does not read as a contradiction, and
every task a robot did not build named."""

from __future__ import annotations

from run_builders import watch_of
from test_run_loop_dead_service import _Dead, _Monitor

from bimbot.run.robot_summary import moved_text, tasks_text
from bimbot.run.summary import RunOutcome, method_line, one_at_a_time_line, summary_text


def _report() -> dict:
    components = [
        {
            "guid": "A",
            "name": "Beam A",
            "state": "constructed",
            "released_s": 0.0,
            "constructed_s": 2000.0,
            "placements": [
                {"attempt": 1, "robot_id": "r1", "verdict": "misplaced", "cause": "unstable"},
                {"attempt": 2, "robot_id": "r1", "verdict": "constructed", "cause": "within_tolerance"},
            ],
        },
        {"guid": "B", "name": "Column B", "state": "assembling", "released_s": 10.0, "constructed_s": None},
        {
            "guid": "C",
            "name": "Footing C",
            "state": "constructed",
            "released_s": 1000.0,
            "constructed_s": 1396.0,
            "placements": [{"attempt": 1, "robot_id": "r2", "verdict": "constructed"}],
        },
    ]
    r2_tasks = [{"task_id": "T3", "guid": "C", "kind": "build", "start_s": 1000.0, "end_s": 1396.0}]
    r1_tasks = [
        {"task_id": "T1", "guid": "A", "kind": "build", "start_s": 0.0, "end_s": 900.0, "open": False},
        {"task_id": "T1", "guid": "A", "kind": "build", "start_s": 901.0, "end_s": 2000.0, "open": False},
        {"task_id": "T2", "guid": "B", "kind": "build", "start_s": 2001.0, "end_s": 2197.0, "open": True},
    ]
    robots = {
        "r1": {"type": "husky", "tasks": r1_tasks, "distance_m": 426.0, "busy_s": 2197.0, "built": 1},
        "r2": {"type": "carrier", "tasks": r2_tasks, "distance_m": 200.0, "busy_s": 396.0, "built": 1},
    }
    return {"components": components, "robots": robots, "totals": {"makespan_s": 2000.0}}


def _lines(**extra: object) -> list[str]:
    outcome = RunOutcome(exit_code=1, constructed=2, total=3, sim_time_s=2197.0, report=_report())
    for name, value in extra.items():
        setattr(outcome, name, value)
    return summary_text(outcome).splitlines()


def test_the_wall_time_is_split_into_start_up_and_the_building_the_runs_ending_counts() -> None:
    lines = _lines(wall_time_s=345.0, startup_wall_s=85.0, build_wall_s=251.0)
    assert "wall" not in lines[0]  # the one figure "345 s wall" beside an ENDED line's 251 s is gone
    assert lines[1].startswith("wall time 345.0 s: 85.0 s start-up, 251.0 s building (the planner's")
    # a new user saw the planner prepare for 37 s after "3.2 s start-up": the building says it has that
    assert "the planner's preparation and the build" in lines[1]
    assert lines[1].endswith("9.0 s closing (the as-built audit, the report, stopping the services)")
    ended = watch_of(_Dead("planner", 0, []), [], _Monitor())._ended(251.0)
    assert ended is not None and "after 251 s wall of building" in ended.ending.message
    assert _lines(wall_time_s=3.0)[1] == "wall time 3.0 s"  # a run that never got to its build


def test_the_summary_says_every_duration_one_way_and_the_robots_busy_times_in_one_unit() -> None:
    lines = _lines()
    assert lines[0].startswith(
        "constructed 2/3 components in 36.6 min (2,197 s) of sim time, makespan 33.3 min"
    )
    r1 = next(line for line in lines if line.startswith("r1 (husky)"))
    r2 = next(line for line in lines if line.startswith("r2 (carrier)"))
    assert r1.endswith(
        "busy 36.6 min (2,197 s), 3.3 min (198 s) of it after the last construction, on tasks that built "
        "nothing more"
    )
    assert r2.endswith("busy 6.6 min (396 s)")  # beside r1's minutes, not "396.0 s"


def test_a_run_stopped_before_its_end_says_its_makespan_so_far() -> None:
    """A trial user read a stopped run's 'makespan 78.9 h' as a finished build's."""
    from bimbot.shared.reasons import ReasonCode
    from bimbot.shared.report.collector import RunEnding

    stopped = RunEnding("interrupted", ReasonCode.INTERRUPTED, "SIGINT")

    def headline(ending: RunEnding) -> str:
        return next(line for line in _lines(ending=ending) if line.startswith("constructed "))

    assert ", makespan so far 33.3 min" in headline(stopped)
    for how in ("done", "stalled"):
        assert ", makespan 33.3 min" in headline(RunEnding(how, None, ""))


def test_the_tasks_a_robot_did_not_build_or_give_back_are_named_with_what_they_came_to() -> None:
    r1 = next(line for line in _lines() if line.startswith("r1 (husky)"))
    assert r1.startswith(
        "r1 (husky): 3 task(s): 1 built, 0 given back, 2 ended another way (T1 Beam A: placed unstable, "
        "retried, then built by r1; T2 Column B: still at it when the run ended)"
    ), r1  # a retried placement says who built the part in the end: a trial user read it as left unbuilt
    r2 = next(line for line in _lines() if line.startswith("r2 (carrier)"))
    assert "ended another way" not in r2


def test_the_method_line_adds_up_to_the_components_and_counts_guests_and_existing_work_apart() -> None:
    """937 components with 2 bolts built into their hosts: the line's components add up to 937, and the
    bolts are said apart, not as a ninth method beside them."""

    by_method = {
        "cast_in_place": {"components": 226, "constructed": 226},
        "in_place": {"components": 3, "constructed": 3},
        "lifted": {"components": 711, "constructed": 711},
        "with_host": {"components": 2, "constructed": 2},
    }
    line = method_line({"by_method": by_method})
    assert line == (
        "by method (constructed/components): cast_in_place 226/226, lifted 711/711; "
        "besides them: with_host 2/2 (built into their hosts), in_place 3/3 (existing work)"
    )
    assert method_line({"by_method": {"lifted": {"components": 5, "constructed": 5}}}) is None


def test_a_robot_s_tasks_add_up_its_hand_offs_among_them() -> None:
    """A new user's trial: "70 task(s): 40 built, 5 given back (26 hand-off(s))" is 71. A hand-off given
    back was counted as given back and as a hand-off; then as a hand-off only, beside its give-back named
    ("0 given back (L-Angle …: no_progress …)" on the Revit hub). It counts as given back, once."""
    robot = {
        "built": 1,
        "given_back": 1,
        "tasks": [
            {"guid": "A", "task_id": "T1", "kind": "build"},
            {"guid": "B", "task_id": "T2-h1", "kind": "hand_off"},
            {"guid": "B", "task_id": "T2-h2", "kind": "hand_off"},
        ],
    }
    components = {
        "A": {"guid": "A", "placements": [{"robot_id": "r2", "verdict": "constructed"}]},
        "B": {"guid": "B", "given_back_by": ["r2"], "placements": []},
    }
    assert tasks_text("r2", robot, components) == "3 task(s): 1 built, 1 given back, 1 hand-off(s) to a crane"


def test_a_robot_s_give_backs_are_named_with_their_reasons_codes() -> None:
    """A new user's trial found "2 given back" and the reasons only in report.json; the next read the code
    alone, "no_approach_pose", as something other than "r2 would wall itself in setting …"."""
    robot = {
        "built": 0,
        "given_back": 2,
        "tasks": [
            {"guid": "W", "task_id": "T1", "kind": "build"},
            {"guid": "S", "task_id": "T2", "kind": "build"},
        ],
    }
    components = {
        "W": {
            "guid": "W",
            "name": "Wall W1 panel 2/2",
            "given_back_by": ["r2"],
            "give_backs": ["no_approach_pose: r2 would wall itself in setting Wall W1 panel 2/2 (W): …"],
        },
        "S": {
            "guid": "S",
            "name": "Stud S4",
            "given_back_by": ["r1", "r2"],
            "give_backs": ["out_of_reach: …", "robot_trapped: r2 at (-2.87, 4.38) is walled in: …"],
        },
    }
    assert tasks_text("r2", robot, components) == (
        "2 task(s): 0 built, 2 given back (Wall W1 panel 2/2: no_approach_pose, would wall itself in setting "
        "it; Stud S4: robot_trapped, at (-2.87, 4.38) is walled in; why: report.json, each component's "
        "give_backs)"
    )
    assert "given back (Stud S4: out_of_reach, …;" in tasks_text("r1", {**robot, "given_back": 1}, components)


def test_a_machine_that_stands_fixed_says_its_relocations_not_zero_metres_driven() -> None:
    """A new user read ``r6 (piling_rig): 216 task(s): 216 built, …, 0 m driven`` under ``driven 216/216``:
    a machine's moves are its relocations between set-ups."""
    assert moved_text({"distance_m": 412.4, "relocations": 0}) == ", 412 m driven"
    assert moved_text({"distance_m": 3233.2, "relocations": 0}) == ", 3,233 m driven"  # as seconds are said
    assert moved_text({"distance_m": 0.0, "relocations": 11}) == ", 11 relocation(s) between set-ups"
    assert moved_text({"distance_m": 0.0, "relocations": 0}) == ""  # a crane: it never moves


def _chain_report(spans: list[tuple[float, float]], sequence: str) -> dict:
    components = [
        {"guid": f"C{i}", "state": "constructed", "released_s": start, "constructed_s": end}
        for i, (start, end) in enumerate(spans)
    ]
    return {"components": components, "robots": {"r1": {}, "r2": {}}, "settings": {"sequence": sequence}}


def test_a_build_of_one_component_at_a_time_on_a_given_sequence_says_why_the_robots_waited() -> None:
    """A 361-part frame with seven robots on the sample's 4D schedule (one chain) took 14.7 h with six
    robots idle and nothing said why; --derive took 2.3 h. The summary names the chain and the way out;
    it says nothing when two components were at work at once or when the run derived its sequence."""
    chained = [(0.0, 100.0), (100.0, 250.0), (250.0, 300.0), (300.0, 420.0)]
    line = one_at_a_time_line(_chain_report(chained, "the build's sequence.xml"))
    assert line is not None and "each of the 4" in line and "--derive" in line
    assert "the build's sequence.xml" in line
    overlapping = [(0.0, 100.0), (50.0, 250.0), (250.0, 300.0), (300.0, 420.0)]
    assert one_at_a_time_line(_chain_report(overlapping, "the build's sequence.xml")) is None
    assert one_at_a_time_line(_chain_report(chained, "derived from the structure (--derive)")) is None
    alone = _chain_report(chained, "the build's sequence.xml") | {"robots": {"r1": {}}}
    assert one_at_a_time_line(alone) is None
