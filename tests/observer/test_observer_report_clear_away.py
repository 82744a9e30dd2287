"""A failed body carried out of the robots' way, in the report and the run's summary: it stays failed with its
own reason, and its entry says who cleared it, when and how long it took; one left in the way says why,
in its entry and in its reason."""

from __future__ import annotations

from observer_site_info import site_info

from bimbot.run.summary import RunOutcome, summary_text
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import ComponentState as S
from bimbot.shared.messages import ComponentStateMsg, PoseMsg, TaskKind, TaskMsg, TaskStatus
from bimbot.shared.reasons import Reason, ReasonCode
from bimbot.shared.report.collector import ReportCollector

FELL = Reason(code=ReasonCode.UNSTABLE, message="it moved 4.211 m after it was released")
TOO_HEAVY = Reason(code=ReasonCode.TOO_HEAVY, message="no robot on site can carry its 900 kg away")


def _failed(guid: str, t: float) -> ComponentStateMsg:
    return ComponentStateMsg(
        guid=guid, state=S.FAILED, previous=S.VERIFYING, event="failed_placement", reason=FELL, sim_time_s=t,
        wall_time_s=t,
    )  # fmt: skip


def _clear(
    guid: str, status: TaskStatus, t: float, robot_id: str | None, reason: Reason | None = None
) -> TaskMsg:
    return TaskMsg(
        task_id=f"T-{guid}-c", guid=guid, component_key=guid, status=status, robot_id=robot_id,
        target_pose=PoseMsg(position_m=(0.0, 0.0, 0.0), quat_xyzw=(0.0, 0.0, 0.0, 1.0)), sim_time_s=t,
        wall_time_s=t, reason=reason, kind=TaskKind.CLEAR, put_down_xy_m=(14.0, 5.0),
    )  # fmt: skip


def test_the_report_and_summary_say_who_cleared_a_failed_body_away_and_why_another_was_not(
    frame_manifest: Manifest, frame_sequence: list[str]
) -> None:
    cleared, left = frame_sequence[:2]
    collector = ReportCollector(frame_manifest, frame_sequence)
    collector.add(site_info({"r1": "carrier"}))
    for message in (
        _failed(cleared, 100.0),
        _failed(left, 110.0),
        _clear(cleared, TaskStatus.ASSIGNED, 101.0, "r1"),
        _clear(left, TaskStatus.FAILED, 111.0, None, TOO_HEAVY),
        _clear(cleared, TaskStatus.DONE, 161.0, "r1"),
    ):
        collector.add(message)
    report = collector.report()
    entries = {c["guid"]: c for c in report["components"]}
    done = entries[cleared]
    assert done["state"] == "failed" and done["reason"]["code"] == "unstable", "still failed, its own reason"
    assert done["cleared_away"] | {"reason": None} == {
        "task_id": f"T-{cleared}-c",
        "cleared": True,
        "robot_id": "r1",
        "assigned_s": 101.0,
        "cleared_s": 161.0,
        "took_s": 60.0,
        "put_down_xy_m": [14.0, 5.0],
        "reason": None,
    }
    not_done = entries[left]
    assert not_done["cleared_away"]["cleared"] is False
    assert not_done["reason"]["code"] == "unstable"
    assert "was not cleared away: no robot on site can carry its 900 kg away" in not_done["reason"]["message"]
    assert entries[frame_sequence[2]]["cleared_away"] is None
    assert (report["totals"]["cleared_away"], report["totals"]["not_cleared_away"]) == (1, 1)
    text = summary_text(RunOutcome(exit_code=1, constructed=0, total=len(entries), report=report))
    line = next(line for line in text.splitlines() if line.startswith("failed bodies cleared"))
    assert "by r1 at 161.0 s (took 60.0 s)" in line
    assert "NOT cleared: no robot on site can carry its 900 kg away" in line
