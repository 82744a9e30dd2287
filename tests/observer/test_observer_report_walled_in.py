"""A robot walled in, in the report and the run's summary: where it stood and since when (until when, if it
got out), and each robot's tasks apart by how they ended: built, given back."""

from __future__ import annotations

import pytest
from observer_site_info import site_info

from bimbot.run.summary import RunOutcome, summary_text
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import ComponentState as S
from bimbot.shared.messages import ComponentStateMsg, RobotState, RobotStateMsg
from bimbot.shared.reasons import Reason, ReasonCode
from bimbot.shared.report.collector import ReportCollector

WALLED_IN_XY = (1.43, -6.35)


def _state(guid: str, state: S, previous: S | None, t: float, **extra: object) -> ComponentStateMsg:
    fields: dict[str, object] = {"event": "test", **extra}
    return ComponentStateMsg(guid=guid, state=state, previous=previous, sim_time_s=t, wall_time_s=t, **fields)


def _robot(
    robot_id: str, t: float, xy: tuple[float, float], walled_in_since_s: float | None = None
) -> RobotStateMsg:
    return RobotStateMsg(
        robot_id=robot_id,
        state=RobotState.IDLE,
        pose_xy_yaw=(xy[0], xy[1], 0.0),
        sim_time_s=t,
        wall_time_s=t,
        walled_in_since_s=walled_in_since_s,
    )


def _on_task(robot_id: str, guid: str, t: float, walled_in_since_s: float | None) -> RobotStateMsg:
    return RobotStateMsg(
        robot_id=robot_id,
        state=RobotState.PICK_UP,
        task_id=f"T-{guid}",
        guid=guid,
        pose_xy_yaw=(0.0, 0.0, 0.0),
        sim_time_s=t,
        wall_time_s=t,
        walled_in_since_s=walled_in_since_s,
    )


def _trapped(robot_id: str) -> Reason:
    return Reason(
        code=ReasonCode.ROBOT_TRAPPED,
        message=f"{robot_id} at (1.43, -6.35) is walled in: no way on the planning grid leads to its depot",
        robot_id=robot_id,
    )


def _built(guid: str, robot_id: str, t: float) -> list[ComponentStateMsg | RobotStateMsg]:
    return [
        _on_task(robot_id, guid, t, None),
        _state(guid, S.PICKING, S.RELEASED, t, robot_id=robot_id, event="pick"),
        _state(guid, S.VERIFYING, S.ASSEMBLING, t + 5.0, robot_id=robot_id, event="place"),
        _state(guid, S.CONSTRUCTED, S.VERIFYING, t + 6.0, robot_id=robot_id, event="verify"),
    ]


def _given_back(
    guid: str, robot_id: str, t: float, since_s: float
) -> list[ComponentStateMsg | RobotStateMsg]:
    # as agents send it: the released state names no robot, the reason does
    return [
        _on_task(robot_id, guid, t, since_s),
        _state(guid, S.PICKING, S.RELEASED, t, robot_id=robot_id, event="pick"),
        _state(guid, S.RELEASED, S.PICKING, t + 1.0, reason=_trapped(robot_id), event="abandon"),
    ]


@pytest.fixture
def collector(frame_manifest: Manifest, frame_sequence: list[str]) -> ReportCollector:
    """r1 builds one component, is walled in at 20 s and gives back the next two, which r2 builds; r3 is
    walled in from 30 s to 50 s (then it drove out)."""
    first, second, third = frame_sequence[:3]
    collector = ReportCollector(frame_manifest, frame_sequence)
    collector.add(site_info({"r1": "carrier", "r2": "carrier", "r3": "carrier"}))
    messages = [
        *(_state(guid, S.RELEASED, S.PLANNED, 1.0, event="release") for guid in (first, second, third)),
        _robot("r1", 1.0, (-30.0, -10.0)),
        *_built(first, "r1", 2.0),
        _robot("r1", 20.0, WALLED_IN_XY, walled_in_since_s=20.0),
        *_given_back(second, "r1", 21.0, since_s=20.0),  # (no other robot could take them, say)
        *_given_back(third, "r1", 23.0, since_s=20.0),
        _robot("r1", 25.0, (1.5, -6.3), walled_in_since_s=20.0),  # it still is (and shuffled a little)
        *_built(second, "r2", 30.0),
        *_built(third, "r2", 40.0),
        _robot("r3", 30.0, (-2.98, 4.31), walled_in_since_s=30.0),
        _robot("r3", 50.0, (-30.0, -13.2)),
        _robot("r3", 51.0, (-2.98, 4.31), walled_in_since_s=30.0),  # a late copy of an old state: no news
    ]
    for message in messages:
        collector.add(message)
    return collector


def test_the_report_says_where_and_since_when_a_robot_was_walled_in_and_until_when_it_got_out(
    collector: ReportCollector,
) -> None:
    report = collector.report()
    robots = report["robots"]
    assert robots["r1"]["walled_in"] == [{"since_s": 20.0, "xy_m": list(WALLED_IN_XY), "until_s": None}]
    assert robots["r3"]["walled_in"] == [{"since_s": 30.0, "xy_m": [-2.98, 4.31], "until_s": 50.0}]
    assert robots["r2"]["walled_in"] == []
    assert report["totals"]["walled_in"] == ["r1", "r3"]


def test_the_report_counts_each_robots_tasks_built_apart_from_those_it_gave_back(
    collector: ReportCollector, frame_sequence: list[str]
) -> None:
    report = collector.report()
    robots = report["robots"]
    assert (robots["r1"]["built"], robots["r1"]["given_back"]) == (1, 2)
    assert (robots["r2"]["built"], robots["r2"]["given_back"]) == (2, 0)
    assert report["totals"]["give_backs"] == 2
    second = next(c for c in report["components"] if c["guid"] == frame_sequence[1])
    assert second["given_back_by"] == ["r1"]


def test_the_summary_names_the_robots_walled_in_and_who_gave_back_how_many(
    collector: ReportCollector,
) -> None:
    report = collector.report()
    text = summary_text(RunOutcome(exit_code=0, constructed=3, total=3, report=report))
    lines = text.splitlines()
    assert "2 give-back(s) by robots (r1 2)" in lines[0], lines[0]
    walled = next(line for line in lines if line.startswith("robots walled in"))
    assert walled == (
        "robots walled in by what was built round them (no way out to where they started; meanwhile each got "
        "no task another robot could take, and its log names what stands beside it): "
        "r1 at (1.43, -6.35) from 20.0 s of sim time to the end of the run; "
        "r3 at (-2.98, 4.31) from 30.0 s of sim time to 50.0 s"
    )
    r1 = next(line for line in lines if line.startswith("r1 (carrier)"))
    assert r1.startswith(
        "r1 (carrier): 3 task(s): 1 built, 2 given back (Footing A2: robot_trapped, at (1.43, -6.35) is "
        "walled in; Footing A3: robot_trapped, at (1.43, -6.35) is walled in; why: report.json, each "
        "component's give_backs),"
    ), r1
    assert " other (" not in r1, r1  # every task accounted for: none named
    r2 = next(line for line in lines if line.startswith("r2 (carrier)"))
    assert r2.startswith("r2 (carrier): 2 task(s): 2 built, 0 given back,"), r2


def test_a_summary_of_a_run_where_no_robot_was_walled_in_says_nothing_of_it(
    collector: ReportCollector,
) -> None:
    report = collector.report()
    for robot in report["robots"].values():
        robot["walled_in"] = []
    text = summary_text(RunOutcome(exit_code=0, constructed=3, total=3, report=report))
    assert "robots walled in" not in text  # (a give-back's reason on a robot's line may say it)
