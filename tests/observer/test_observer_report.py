"""The construction report from the synthetic run (see conftest): times, retries, busy time, distance, totals,
and its Gantt chart written at its fixed size."""

from __future__ import annotations

import json
import math
from pathlib import Path

import matplotlib.image
import pytest
from matplotlib.figure import Figure
from pydantic import BaseModel

from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import ComponentState as S
from bimbot.shared.messages import ComponentStateMsg, RobotPoseMsg, RobotState, RobotStateMsg, SensorsMsg
from bimbot.shared.report.collector import ReportCollector
from bimbot.shared.report.png import DPI, FIGURE_SIZE_IN, render_report_png, report_figure


def _report(manifest: Manifest, sequence: list[str], messages: list[tuple[str, BaseModel]]) -> dict:
    collector = ReportCollector(manifest, sequence)
    for _, message in messages:
        collector.add(message)
    return collector.report()


@pytest.fixture(scope="module")
def report(
    frame_manifest: Manifest, frame_sequence: list[str], run_messages: list[tuple[str, BaseModel]]
) -> dict:
    return _report(frame_manifest, frame_sequence, run_messages)


def _component(report: dict, guid: str) -> dict:
    return next(c for c in report["components"] if c["guid"] == guid)


def test_component_times_are_release_first_pick_last_place_and_constructed(
    report: dict, frame_sequence: list[str]
) -> None:
    first, retried, third = (_component(report, guid) for guid in frame_sequence[:3])
    assert (first["released_s"], first["picked_s"], first["placed_s"], first["constructed_s"]) == (
        1.0,
        2.0,
        10.0,
        pytest.approx(10.2),
    )
    assert first["retries"] == 0 and first["robot_ids"] == ["r1"] and first["sequence_index"] == 0
    # misplaced at 12 and retried: the first release and pick, the last placement
    assert (retried["released_s"], retried["picked_s"], retried["placed_s"]) == (1.0, 3.0, 20.0)
    assert retried["constructed_s"] == pytest.approx(20.2)
    assert retried["retries"] == 1 and retried["misplaced_s"] == [12.0] and retried["attempts"] == 2
    assert retried["cycle_time_s"] == pytest.approx(19.2)
    assert (third["released_s"], third["picked_s"], third["placed_s"]) == (11.0, 12.0, 18.0)
    assert third["state"] == "constructed" and third["ifc_class"] == "IfcFooting"


def test_components_the_run_did_not_reach_stay_planned_without_times(
    report: dict, frame_sequence: list[str]
) -> None:
    rest = [_component(report, guid) for guid in frame_sequence[3:]]
    assert len(rest) == 25
    assert all(
        c["state"] == "planned" and c["released_s"] is None and c["constructed_s"] is None for c in rest
    )


def test_busy_time_runs_from_leaving_idle_to_returning_to_idle(
    report: dict, frame_sequence: list[str]
) -> None:
    r1, r2 = report["robots"]["r1"], report["robots"]["r2"]
    assert r1["busy_s"] == pytest.approx((10.5 - 2.0) + (18.5 - 12.0))
    assert r2["busy_s"] == pytest.approx(20.5 - 3.0)
    assert [(t["guid"], t["start_s"], t["end_s"]) for t in r1["tasks"]] == [
        (frame_sequence[0], 2.0, 10.5),
        (frame_sequence[2], 12.0, 18.5),
    ]
    assert r1["state"] == "idle"


def test_distance_comes_from_ground_truth_poses(report: dict) -> None:
    assert report["robots"]["r1"]["distance_m"] == pytest.approx(12.0)  # 6 m east and back
    assert report["robots"]["r2"]["distance_m"] == pytest.approx(4.0)
    assert report["robots"]["r1"]["distance_source"] == "ground_truth"


def test_distance_falls_back_to_odometry_without_ground_truth(
    frame_manifest: Manifest, frame_sequence: list[str], run_messages: list[tuple[str, BaseModel]]
) -> None:
    without_truth = [(k, m) for k, m in run_messages if not isinstance(m, RobotPoseMsg)]
    robots = _report(frame_manifest, frame_sequence, without_truth)["robots"]
    assert robots["r1"]["distance_source"] == "odom"
    assert robots["r1"]["distance_m"] == pytest.approx(12.0 * 1.1)  # odometry drifts 10 % in the stream
    only_states = [(k, m) for k, m in without_truth if not isinstance(m, SensorsMsg)]
    assert (
        _report(frame_manifest, frame_sequence, only_states)["robots"]["r1"]["distance_source"]
        == "state_poses"
    )


def test_a_task_still_open_at_the_end_is_closed_at_the_last_sim_time(frame_manifest: Manifest) -> None:
    collector = ReportCollector(frame_manifest)
    for state, t in ((RobotState.IDLE, 0.0), (RobotState.PICK_UP, 4.0), (RobotState.ASSEMBLE, 9.0)):
        collector.add(
            RobotStateMsg(robot_id="r9", state=state, pose_xy_yaw=(0, 0, 0), sim_time_s=t, wall_time_s=0)
        )
    (task,) = collector.report()["robots"]["r9"]["tasks"]
    assert (task["start_s"], task["end_s"], task["open"]) == (4.0, 9.0, True)


def test_totals_sum_up_the_run(report: dict) -> None:
    totals = report["totals"]
    assert totals["components"] == 28
    assert totals["by_state"] == {"constructed": 3, "planned": 25}
    assert (totals["constructed"], totals["failed"], totals["blocked"], totals["retries"]) == (3, 0, 0, 1)
    assert totals["makespan_s"] == pytest.approx(20.2 - 1.0)
    assert totals["busy_s"] == pytest.approx(15.0 + 17.5)
    assert totals["distance_m"] == pytest.approx(16.0)
    # r2 works on until 20.5 s, past the last construction (20.2 s): the makespan holds 17.2 s of its 17.5
    assert totals["utilisation"] == pytest.approx((15.0 + 17.2) / (2 * 19.2))
    assert totals["done"] is True and report["sim_time_s"] == pytest.approx(21.0)


def test_the_report_is_plain_json(report: dict) -> None:
    assert json.loads(json.dumps(report)) == report


def test_the_gantt_chart_is_written_at_its_size(report: dict, tmp_path: Path) -> None:
    path = render_report_png(report, tmp_path / "report.png")
    assert path.stat().st_size > 10_000
    height, width = matplotlib.image.imread(path).shape[:2]
    assert (width, height) == (FIGURE_SIZE_IN[0] * DPI, FIGURE_SIZE_IN[1] * DPI)


def test_saving_the_chart_draws_it_once(
    report: dict, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The chart is laid out when it is made: saving it draws it once, not a second time for a layout engine
    (each draw of the bundled frame's chart takes seconds)."""
    figure = report_figure(report)
    draws: list[object] = []
    draw = Figure.draw

    def counted(self: Figure, renderer: object) -> None:
        draws.append(renderer)
        draw(self, renderer)

    monkeypatch.setattr(Figure, "draw", counted)
    figure.savefig(tmp_path / "report.png", dpi=DPI)
    assert len(draws) == 1


def test_a_run_without_messages_still_gets_a_chart(frame_manifest: Manifest, tmp_path: Path) -> None:
    empty = ReportCollector(frame_manifest).report()
    assert empty["totals"]["makespan_s"] is None and empty["robots"] == {}
    assert render_report_png(empty, tmp_path / "empty.png").stat().st_size > 0


def test_a_verdict_stamped_before_its_placement_does_not_go_back_in_time(frame_manifest: Manifest) -> None:
    collector = ReportCollector(frame_manifest)
    guid = frame_manifest.components[0].guid
    for previous, state, t in (
        (S.ASSEMBLING, S.VERIFYING, 55.58),  # stamped by the robot's clock
        (S.VERIFYING, S.CONSTRUCTED, 55.57),  # stamped by the agent's clock, a step behind
    ):
        collector.add(
            ComponentStateMsg(
                guid=guid, state=state, previous=previous, event="e", sim_time_s=t, wall_time_s=0.0
            )
        )
    (entry,) = [c for c in collector.report()["components"] if c["guid"] == guid]
    assert entry["placed_s"] == entry["constructed_s"] == 55.58


def test_placement_errors_are_those_of_the_last_verdict_in_mm_and_degrees(frame_manifest: Manifest) -> None:
    collector = ReportCollector(frame_manifest)
    first, second = (c.guid for c in frame_manifest.components[:2])
    for guid, previous, state, error_m, error_rad in (
        (first, S.VERIFYING, S.MISPLACED, 0.05, 0.0),  # caught, then retried
        (first, S.VERIFYING, S.CONSTRUCTED, 0.002, 0.001),
        (second, S.VERIFYING, S.CONSTRUCTED, 0.004, 0.0005),
    ):
        collector.add(
            ComponentStateMsg(
                guid=guid,
                state=state,
                previous=previous,
                event="verify",
                sim_time_s=1.0,
                wall_time_s=0.0,
                position_error_m=error_m,
                angle_error_rad=error_rad,
            )
        )
    report = collector.report()
    entry = next(c for c in report["components"] if c["guid"] == first)
    assert entry["position_error_mm"] == pytest.approx(2.0)
    assert entry["angle_error_deg"] == pytest.approx(0.0572958, rel=1e-4)
    assert report["totals"]["max_position_error_mm"] == pytest.approx(4.0)
    assert report["totals"]["max_angle_error_deg"] == pytest.approx(0.0572958, rel=1e-4)


def test_the_closest_two_robots_came_is_measured_on_ground_truth_at_equal_sim_times(
    frame_manifest: Manifest,
    frame_sequence: list[str],
    run_messages: list[tuple[str, BaseModel]],
    robot_paths: dict[str, list[tuple[float, float]]],
) -> None:

    shifted = [  # r2 one metre north of its path: the closest approach is then at its first step
        (k, m.model_copy(update={"pose_xy_yaw": (m.pose_xy_yaw[0], m.pose_xy_yaw[1] + 1.0, 0.0)}))
        if isinstance(m, RobotPoseMsg) and m.robot_id == "r2"
        else (k, m)
        for k, m in run_messages
    ]
    together = zip(robot_paths["r1"], robot_paths["r2"], strict=False)
    expected = min(math.hypot(x1 - x2, y1 - (y2 + 1.0)) for (x1, y1), (x2, y2) in together)
    totals = _report(frame_manifest, frame_sequence, shifted)["totals"]
    assert totals["min_robot_separation_m"] == pytest.approx(expected) and expected == pytest.approx(1.0)
    alone = [(k, m) for k, m in run_messages if not (isinstance(m, RobotPoseMsg) and m.robot_id == "r2")]
    assert _report(frame_manifest, frame_sequence, alone)["totals"]["min_robot_separation_m"] is None
