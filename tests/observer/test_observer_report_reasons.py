"""Reasons in the construction report: every component that is not constructed has a ``reason`` (code,
message, guid, robot_id) — its agent's for failed and blocked, else the planner's, else how the run
ended (interrupted, stalled) with its state — and report.png marks them."""

from __future__ import annotations

import logging
import warnings
from pathlib import Path

import matplotlib.image
import numpy as np
import pytest

from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import ComponentState as S
from bimbot.shared.messages import ComponentStateMsg, ProgressMsg
from bimbot.shared.reasons import Reason, ReasonCode, blocked_by
from bimbot.shared.report.collector import ReportCollector, RunEnding
from bimbot.shared.report.png import render_report_png, write_report_files

TOO_HEAVY = Reason(code=ReasonCode.TOO_HEAVY, message="5,760 kg exceed the robot's 1,000 kg payload")
GIVEN_BACK = Reason(code=ReasonCode.NO_APPROACH_POSE, message="no free cell within 1.4 m", robot_id="r1")
STALLED = RunEnding(
    "stalled", ReasonCode.STALLED, "nothing on the site changed for 600 s of sim time", ("r1: idle",)
)


def _state(guid: str, state: S, previous: S | None, t: float, **extra: object) -> ComponentStateMsg:
    fields: dict[str, object] = {"event": "test", **extra}
    return ComponentStateMsg(guid=guid, state=state, previous=previous, sim_time_s=t, wall_time_s=t, **fields)


@pytest.fixture
def collector(frame_manifest: Manifest, frame_sequence: list[str]) -> ReportCollector:
    """First component constructed, second failed too heavy, third blocked (the reason only in the
    planner's progress), fourth given back once and picked again; the rest never released."""
    first, heavy, blocked, picking = frame_sequence[:4]
    collector = ReportCollector(frame_manifest, frame_sequence)
    for message in (
        _state(first, S.RELEASED, S.PLANNED, 1.0),
        _state(first, S.CONSTRUCTED, S.VERIFYING, 9.0),
        _state(heavy, S.RELEASED, S.PLANNED, 1.0),
        _state(heavy, S.FAILED, S.RELEASED, 2.0, reason=TOO_HEAVY),
        _state(blocked, S.BLOCKED, S.PLANNED, 2.0),
        _state(picking, S.RELEASED, S.PLANNED, 10.0),
        _state(picking, S.PICKING, S.RELEASED, 11.0, robot_id="r1"),
        _state(picking, S.RELEASED, S.PICKING, 20.0, reason=GIVEN_BACK, event="abandon"),
        _state(picking, S.PICKING, S.RELEASED, 21.0, robot_id="r1"),
        ProgressMsg(
            total=len(frame_manifest.components),
            counts={},
            percent_constructed=0.0,
            sim_time_s=22.0,
            estimated_finish_sim_time_s=None,
            failed=[heavy],
            blocked=[blocked],
            reasons={heavy: TOO_HEAVY, blocked: blocked_by(heavy, TOO_HEAVY)},
        ),
    ):
        collector.add(message)
    return collector


def _by_guid(report: dict) -> dict[str, dict]:
    return {c["guid"]: c for c in report["components"]}


def test_every_component_not_constructed_has_a_reason_and_constructed_ones_none(
    collector: ReportCollector, frame_sequence: list[str]
) -> None:
    report = collector.report(STALLED)
    components = _by_guid(report)
    first, heavy, blocked, picking, never = frame_sequence[:5]
    assert components[first]["reason"] is None
    assert all(c["reason"] is not None for c in report["components"] if c["state"] != "constructed")
    assert components[heavy]["reason"] == {
        "code": "too_heavy",
        "message": TOO_HEAVY.message,
        "guid": None,
        "robot_id": None,
    }
    assert (
        components[blocked]["reason"]["code"] == "blocked_by"
        and components[blocked]["reason"]["guid"] == heavy
    )
    stalled = components[picking]["reason"]
    assert stalled["code"] == "stalled" and stalled["robot_id"] == "r1"
    assert stalled["message"].startswith(STALLED.message)
    assert "it was picking (robot r1)" in stalled["message"] and "no_approach_pose" in stalled["message"]
    assert components[never]["reason"]["code"] == "stalled"
    assert "it was planned" in components[never]["reason"]["message"]
    assert report["ending"] == {
        "how": "stalled",
        "code": "stalled",
        "message": STALLED.message,
        "details": ["r1: idle"],
    }
    totals = report["totals"]
    assert totals["not_constructed"] == len(frame_sequence) - 1
    assert totals["by_reason"] == {"blocked_by": 1, "stalled": len(frame_sequence) - 3, "too_heavy": 1}


def test_a_report_written_before_the_end_says_interrupted(
    collector: ReportCollector, frame_sequence: list[str]
) -> None:
    report = collector.report()
    reason = _by_guid(report)[frame_sequence[4]]["reason"]
    assert reason["code"] == "interrupted" and "before the run ended" in reason["message"]
    assert report["ending"]["how"] == "running"


def test_the_chart_marks_the_components_not_built(collector: ReportCollector, tmp_path: Path) -> None:
    report = collector.report(STALLED)
    marked = render_report_png(report, tmp_path / "marked.png")
    for component in report["components"]:
        component["reason"] = None
    report["totals"]["by_reason"] = {}
    plain = render_report_png(report, tmp_path / "plain.png")
    red = [_red_pixels(matplotlib.image.imread(path)) for path in (marked, plain)]
    assert red[0] > red[1] + 500, red  # hatching, codes and red labels


def _red_pixels(image: np.ndarray) -> int:
    rgb = image[..., :3]
    return int(((rgb[..., 0] > 0.8) & (rgb[..., 1] < 0.3) & (rgb[..., 2] < 0.3)).sum())


def test_every_give_back_is_in_the_report_with_its_reason(
    collector: ReportCollector, frame_sequence: list[str]
) -> None:
    report = collector.report(STALLED)
    by_guid = {component["guid"]: component for component in report["components"]}
    assert by_guid[frame_sequence[3]]["give_backs"] == [GIVEN_BACK.line()]
    assert by_guid[frame_sequence[0]]["give_backs"] == []
    assert report["totals"]["give_backs"] == 1


def test_names_the_plot_font_cannot_draw_are_one_log_line_not_a_warning_per_glyph(
    collector: ReportCollector, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """A Chinese Revit model's names ("混凝土 - 矩形 - 柱") printed a warning per glyph and draw."""
    report = collector.report(STALLED)
    for component in report["components"]:
        component["name"] = "混凝土 - 矩形 - 柱:200 x 200mm"
    with warnings.catch_warnings(record=True) as caught, caplog.at_level(logging.INFO):
        warnings.simplefilter("always")
        write_report_files(report, tmp_path)
    assert not [w for w in caught if "missing from font" in str(w.message)]
    assert (tmp_path / "report.png").is_file()
    lines = [r.getMessage() for r in caplog.records if "has no glyph" in r.getMessage()]
    assert len(lines) == 1 and "fonts-noto-cjk" in lines[0], lines
