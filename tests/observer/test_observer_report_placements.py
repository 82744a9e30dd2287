"""Placements in the construction report (issue 11): every verified attempt per component with its robot
type, errors, drift after release, verdict and cause; the distribution of position errors per robot type;
retries by cause; the largest drift; the summary line and report.png's placement panels.

A synthetic stream on the bundled build's first four components, a fleet of r1 husky and r2, r3 carriers
(physics' site info). Each attempt goes released → picking → transporting → assembling → verifying →
verdict, one message a second, so the k-th attempt's verdict is at 6·k s:

    A  r1 husky    14 mm misplaced (no reason: released off target), drift 1 mm;  4 mm constructed, 0.5 mm
    B  r2 carrier  80 mm misplaced, reason unstable, drift 75 mm;   r3 carrier  6 mm constructed, 2 mm
    C  r1 husky     2 mm constructed, drift not measured
    D  r3 carrier  12, 20 mm misplaced, 30 mm failed (reason misplaced), drift 0

    husky    [2, 4, 14]          mean 6.67  p50  4  p95 4 + 0.9·10 = 13  max 14  1 out of tolerance
    carrier  [6, 12, 20, 30, 80]  mean 29.6  p50 20  p95 30 + 0.8·50 = 70  max 80  3 out of tol., 1 unstable
    retries (misplaced verdicts): misplaced 3 (A1, D1, D2), unstable 1 (B1); largest drift 75 mm
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, NamedTuple

import matplotlib.image
import numpy as np
import pytest
from observer_site_info import site_info
from pydantic import BaseModel

from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import ComponentState as S
from bimbot.shared.messages import ComponentStateMsg, PoseMsg, TwinMsg
from bimbot.shared.reasons import Reason, ReasonCode
from bimbot.shared.report.collector import ReportCollector
from bimbot.shared.report.placements import percentile, placement_line
from bimbot.shared.report.placements_png import TOLERANCE_MM
from bimbot.shared.report.png import DPI, FIGURE_SIZE_IN, render_report_png, report_figure

TYPES = {"r1": "husky", "r2": "carrier", "r3": "carrier"}
SLID = Reason(code=ReasonCode.UNSTABLE, message="it moved 75 mm after release", robot_id="r2")
MISSED = Reason(code=ReasonCode.MISPLACED, message="out of tolerance (10 mm, 1°)", robot_id="r3")


class Attempt(NamedTuple):
    """One placement attempt of the stream and its agent's verdict (errors and drift in mm and degrees)."""

    attempt: int
    robot: str
    verdict: S
    error_mm: float | None
    angle_deg: float
    drift_mm: float | None
    reason: Reason | None = None


ATTEMPTS: tuple[tuple[str, Attempt], ...] = (
    ("A", Attempt(1, "r1", S.MISPLACED, 14.0, 0.5, 1.0)),
    ("A", Attempt(2, "r1", S.CONSTRUCTED, 4.0, 0.2, 0.5)),
    ("B", Attempt(1, "r2", S.MISPLACED, 80.0, 3.0, 75.0, SLID)),
    ("B", Attempt(2, "r3", S.CONSTRUCTED, 6.0, 0.1, 2.0)),
    ("C", Attempt(1, "r1", S.CONSTRUCTED, 2.0, 0.0, None)),
    ("D", Attempt(1, "r3", S.MISPLACED, 12.0, 0.3, 0.0, MISSED)),
    ("D", Attempt(2, "r3", S.MISPLACED, 20.0, 0.3, 0.0, MISSED)),
    ("D", Attempt(3, "r3", S.FAILED, 30.0, 0.3, 0.0, MISSED)),
)
STEPS = (S.RELEASED, S.PICKING, S.TRANSPORTING, S.ASSEMBLING, S.VERIFYING)


def _rounded(value: Any) -> Any:
    """``value`` with every float rounded to 9 decimals (mm ↔ m conversions leave 1e-15 behind)."""
    if isinstance(value, float):
        return round(value, 9)
    if isinstance(value, dict):
        return {k: _rounded(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_rounded(v) for v in value]
    return value


def _attempt_messages(guid: str, row: Attempt, start_s: float) -> list[ComponentStateMsg]:
    """One attempt: released (from planned or misplaced) … verifying, then the verdict at ``start_s`` + 5."""
    messages, previous = [], S.PLANNED if row.attempt == 1 else S.MISPLACED
    error_mm, drift_mm = row.error_mm, row.drift_mm
    for step, state in enumerate((*STEPS, row.verdict)):
        is_verdict = state == row.verdict
        messages.append(
            ComponentStateMsg(
                guid=guid,
                state=state,
                previous=previous,
                event="verdict" if is_verdict else "test",
                attempt=row.attempt,
                robot_id=None if state == S.RELEASED else row.robot,
                sim_time_s=start_s + step,
                wall_time_s=start_s + step,
                position_error_m=error_mm / 1000.0 if is_verdict and error_mm is not None else None,
                angle_error_rad=math.radians(row.angle_deg) if is_verdict else None,
                drift_m=drift_mm / 1000.0 if is_verdict and drift_mm is not None else None,
                reason=row.reason if is_verdict else None,
            )
        )
        previous = state
    return messages


@pytest.fixture(scope="module")
def guids(frame_manifest: Manifest) -> dict[str, str]:
    return {name: component.guid for name, component in zip("ABCD", frame_manifest.components, strict=False)}


@pytest.fixture(scope="module")
def stream(guids: dict[str, str]) -> list[BaseModel]:
    messages: list[BaseModel] = [site_info(TYPES)]
    for index, (name, row) in enumerate(ATTEMPTS):
        messages += _attempt_messages(guids[name], row, start_s=6.0 * index + 1.0)
    return messages


def _collect(manifest: Manifest, messages: list[BaseModel]) -> ReportCollector:
    collector = ReportCollector(manifest)
    for message in messages:
        collector.add(message)
    return collector


@pytest.fixture(scope="module")
def report(frame_manifest: Manifest, stream: list[BaseModel]) -> dict:
    return _collect(frame_manifest, stream).report()


def _component(report: dict, guid: str) -> dict:
    return next(c for c in report["components"] if c["guid"] == guid)


def test_every_verified_attempt_is_listed_in_order_with_its_robot_type_errors_drift_verdict_and_cause(
    report: dict, guids: dict[str, str]
) -> None:
    a = _component(report, guids["A"])
    assert _rounded(a["placements"]) == [
        {
            "attempt": 1,
            "robot_id": "r1",
            "robot_type": "husky",
            "position_error_mm": 14.0,
            "angle_error_deg": 0.5,
            "drift_mm": 1.0,
            "verdict": "misplaced",
            "cause": "misplaced",
            "sim_time_s": 6.0,
        },
        {
            "attempt": 2,
            "robot_id": "r1",
            "robot_type": "husky",
            "position_error_mm": 4.0,
            "angle_error_deg": 0.2,
            "drift_mm": 0.5,
            "verdict": "constructed",
            "cause": "within_tolerance",
            "sim_time_s": 12.0,
        },
    ]
    assert a["max_drift_mm"] == pytest.approx(1.0)
    assert (a["retries"], a["position_error_mm"], a["state"]) == (1, pytest.approx(4.0), "constructed")


def test_a_placement_that_moved_after_release_is_unstable_and_a_failed_one_keeps_its_cause(
    report: dict, guids: dict[str, str]
) -> None:
    b, c, d = (_component(report, guids[name]) for name in "BCD")
    assert [(p["robot_id"], p["robot_type"], p["verdict"], p["cause"]) for p in b["placements"]] == [
        ("r2", "carrier", "misplaced", "unstable"),
        ("r3", "carrier", "constructed", "within_tolerance"),
    ]
    assert b["max_drift_mm"] == pytest.approx(75.0)
    assert c["placements"][0]["drift_mm"] is None and c["max_drift_mm"] is None
    assert [(p["attempt"], p["verdict"], p["cause"]) for p in d["placements"]] == [
        (1, "misplaced", "misplaced"),
        (2, "misplaced", "misplaced"),
        (3, "failed", "misplaced"),
    ]
    assert d["max_drift_mm"] == 0.0 and d["reason"]["code"] == "misplaced"


def test_placement_errors_are_distributed_per_robot_type_in_lane_order(report: dict) -> None:
    by_type = report["totals"]["placement_error_mm_by_type"]
    assert list(by_type) == ["husky", "carrier"]
    assert _rounded(by_type) == {
        "husky": {
            "placements": 3,
            "unstable": 0,
            "unmeasured": 0,
            "mean": round(20.0 / 3.0, 9),
            "p50": 4.0,
            "p95": 13.0,
            "max": 14.0,
            "out_of_tolerance": 1,
        },
        "carrier": {  # B's first attempt slid 75 mm after release: counted unstable, not in the errors
            "placements": 5,
            "unstable": 1,
            "unmeasured": 0,
            "mean": 17.0,
            "p50": 16.0,
            "p95": 28.5,
            "max": 30.0,
            "out_of_tolerance": 3,  # B's unstable attempt is counted once, as unstable
        },
    }


def test_retries_are_counted_by_cause_and_the_largest_drift_is_totalled(report: dict) -> None:
    totals = report["totals"]
    assert totals["retries_by_cause"] == {"misplaced": 3, "unstable": 1}
    assert totals["retries"] == 4 == sum(totals["retries_by_cause"].values())
    assert totals["max_drift_mm"] == pytest.approx(75.0)
    assert totals["max_position_error_mm"] == pytest.approx(
        6.0
    )  # the constructed ones' last verdicts, as before


def test_a_verdict_heard_twice_is_one_placement(
    frame_manifest: Manifest, stream: list[BaseModel], guids: dict[str, str]
) -> None:
    verdicts = [m for m in stream if isinstance(m, ComponentStateMsg) and m.event == "verdict"]
    report = _collect(frame_manifest, [*stream, *verdicts]).report()
    assert [len(_component(report, guids[name])["placements"]) for name in "ABCD"] == [2, 2, 1, 3]
    assert report["totals"]["placement_error_mm_by_type"]["carrier"]["placements"] == 5


def test_a_twin_replayed_gives_the_same_placements(
    frame_manifest: Manifest, stream: list[BaseModel], report: dict, guids: dict[str, str]
) -> None:
    guid = guids["B"]
    history = [m for m in stream if isinstance(m, ComponentStateMsg) and m.guid == guid]
    component = frame_manifest.component(guid)
    target = PoseMsg(
        position_m=component.target_pose_world.position_m, quat_xyzw=component.target_pose_world.quat_xyzw
    )
    twin = TwinMsg(
        guid=guid,
        key=guid,
        ifc_class=component.ifc_class,
        name=component.name,
        storey=None,
        material=None,
        mass_kg=component.mass_kg,
        target_pose=target,
        current_pose=target,
        current_pose_sim_time_s=24.0,
        state=S.CONSTRUCTED,
        attempt=2,
        robot_id="r3",
        history=history,
    )
    collector = _collect(frame_manifest, [site_info(TYPES)])
    collector.replace_from_twin(twin)
    replayed = _component(collector.report(), guid)
    assert replayed["placements"] == _component(report, guid)["placements"]


def test_a_robot_of_unknown_type_and_a_placement_without_a_pose_are_counted_unmeasured(
    frame_manifest: Manifest, guids: dict[str, str]
) -> None:
    messages = _attempt_messages(guids["A"], Attempt(1, "r9", S.MISPLACED, None, 0.0, None), start_s=1.0)
    report = _collect(frame_manifest, [site_info(TYPES), *messages]).report()
    (placement,) = _component(report, guids["A"])["placements"]
    assert (placement["robot_type"], placement["position_error_mm"], placement["cause"]) == (
        None,
        None,
        "misplaced",
    )
    assert report["totals"]["placement_error_mm_by_type"] == {
        "unknown": {
            "placements": 1,
            "unstable": 0,
            "unmeasured": 1,
            "mean": None,
            "p50": None,
            "p95": None,
            "max": None,
            "out_of_tolerance": 1,
        }
    }
    assert placement_line(report) == (
        "every placement attempt by robot type: unknown not measured (1 placement, 1 out of tolerance); "
        "retries by cause: misplaced 1, unstable 0; drift not measured"
    )


def test_an_unstable_verdict_is_not_taken_for_a_give_back(
    frame_manifest: Manifest, guids: dict[str, str]
) -> None:
    """The agent keeps its last reason on the messages after a verdict: an unfinished component's reason
    must not say a robot gave it back because it was unstable."""
    messages = _attempt_messages(
        guids["A"], Attempt(1, "r2", S.MISPLACED, 50.0, 0.0, 40.0, SLID), start_s=1.0
    )
    retried = ComponentStateMsg(
        guid=guids["A"],
        state=S.RELEASED,
        previous=S.MISPLACED,
        event="retry",
        attempt=1,
        sim_time_s=7.0,
        wall_time_s=7.0,
        reason=SLID,
    )
    reason = _component(_collect(frame_manifest, [*messages, retried]).report(), guids["A"])["reason"]
    assert reason["code"] == "interrupted" and "given back" not in reason["message"]


def test_percentiles_interpolate_between_order_statistics_as_numpy_does() -> None:
    values = sorted([3.5, 0.2, 17.0, 9.1, 9.1, 42.0, 0.0])
    for fraction in (0.0, 0.05, 0.5, 0.95, 1.0):
        assert percentile(values, fraction) == pytest.approx(np.percentile(values, fraction * 100.0))
    assert percentile([7.0], 0.95) == 7.0
    with pytest.raises(ValueError):
        percentile([], 0.5)


def test_the_summary_has_one_line_of_placement_errors_by_type_retries_by_cause_and_drift(
    report: dict,
) -> None:
    from bimbot.run.summary import RunOutcome, summary_text

    line = (
        "every placement attempt by robot type: "
        "husky mean 6.7 / p95 13.0 / max 14.0 mm (3 placements, 1 out of tolerance), "
        "carrier mean 17.0 / p95 28.5 / max 30.0 mm (5 placements, 3 out of tolerance, "
        "1 unstable: moved after release, not in these errors); "
        "retries by cause: misplaced 3, unstable 1; largest drift after placement 75.0 mm "
        "(Footing A2: it slid, tipped or fell after its release)"  # the part it moved, named
    )
    assert placement_line(report) == line
    lines = summary_text(RunOutcome(exit_code=1, constructed=3, total=28, report=report)).splitlines()
    assert lines[lines.index(line) - 1].startswith(
        "placement error of the constructed components at most 6.00 mm"
    )


def _marker_points(ax: Any, marker: str) -> int:
    return sum(len(line.get_xdata()) for line in ax.get_lines() if line.get_marker() == marker)


def test_the_chart_has_a_placement_error_panel_per_robot_type_and_a_drift_panel(
    report: dict, tmp_path: Path
) -> None:
    figure = report_figure(report)
    _, _, errors, drift = figure.axes
    assert "placement position error per robot type" in errors.get_title()
    assert [label.get_text().split("\n")[0] for label in errors.get_yticklabels()] == ["husky", "carrier"]
    assert errors.get_yticklabels()[1].get_text() == "carrier\n5 placed, p95 28.5 mm"
    assert (_marker_points(errors, "o"), _marker_points(errors, "x"), _marker_points(errors, "v")) == (
        3,
        4,
        1,
    )
    assert any(list(line.get_xdata()) == [TOLERANCE_MM] * 2 for line in errors.get_lines())  # the dashed line
    _, placement_legend = figure.legends  # the classes' legend, then the placements' row
    assert [text.get_text() for text in placement_legend.get_texts()] == [
        "within tolerance ×3",
        "misplaced (released off target) ×4",
        "unstable (moved after release) ×1",
        "tolerance 10 mm",
    ]
    assert errors.get_xscale() == "symlog"
    assert (
        _marker_points(drift, "o") + _marker_points(drift, "x") + _marker_points(drift, "v") == 7
    )  # C unmeasured
    assert "largest 75.0 mm" in drift.get_title() and "misplaced 3, unstable 1" in drift.get_title()
    path = render_report_png(report, tmp_path / "report.png")
    height, width = matplotlib.image.imread(path).shape[:2]
    assert (width, height) == (FIGURE_SIZE_IN[0] * DPI, FIGURE_SIZE_IN[1] * DPI) == (1600, 1200)


def test_a_run_without_placements_has_empty_totals_no_summary_line_and_still_a_chart(
    frame_manifest: Manifest, tmp_path: Path
) -> None:
    empty = ReportCollector(frame_manifest).report()
    totals = empty["totals"]
    assert totals["placement_error_mm_by_type"] == {} and totals["max_drift_mm"] is None
    assert totals["retries_by_cause"] == {"misplaced": 0, "unstable": 0}
    assert all(c["placements"] == [] and c["max_drift_mm"] is None for c in empty["components"])
    assert placement_line(empty) is None
    _, _, errors, drift = report_figure(empty).axes
    assert [text.get_text() for text in errors.texts] == ["no placement was verified"]
    assert [text.get_text() for text in drift.texts] == ["no drift was measured"]
    assert len(report_figure(empty).legends) == 1  # no placement legend
    assert render_report_png(empty, tmp_path / "empty.png").stat().st_size > 0
