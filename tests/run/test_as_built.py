"""The as-built audit's pure core: a constructed component that physics has away from its BIM target is an
error naming it with its numbers; within the agents' tolerance, or not constructed, it is not."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from run_builders import GUIDS, manifest, poses, state, walk
from scipy.spatial.transform import Rotation

from bimbot.run.as_built import AGENT_TOLERANCES, add_to_report, as_built_line, audit_as_built
from bimbot.services.component_agents.agent import AgentConfig
from bimbot.shared.messages import ComponentState, PoseMsg
from bimbot.shared.reasons import Reason, ReasonCode
from bimbot.shared.report.collector import ReportCollector
from bimbot.shared.report.png import _as_built_title, render_report_png

SITE_MANIFEST = manifest()
BEAM, OTHER, THIRD, FOURTH = GUIDS


def _centre_error_m(guid: str, offset_m: tuple[float, float, float], yaw_deg: float) -> float:
    """How far the component's centre moves when its pose is offset and turned as ``poses`` does it (scipy,
    independently of the audit's own quaternion code)."""
    component = SITE_MANIFEST.component(guid)
    moved = poses(SITE_MANIFEST, moved={guid: (offset_m, yaw_deg)}).components[guid].pose
    target = component.target_pose_world
    centre = np.asarray(component.com_local_m)
    here = np.asarray(moved.position_m) + Rotation.from_quat(moved.quat_xyzw).apply(centre)
    there = np.asarray(target.position_m) + Rotation.from_quat(target.quat_xyzw).apply(centre)
    return float(np.linalg.norm(here - there))


def test_the_audit_uses_the_tolerances_the_agents_verify_with() -> None:
    assert AgentConfig().tolerances == AGENT_TOLERANCES


def test_a_constructed_component_displaced_by_20_mm_is_an_error_naming_it_with_its_numbers() -> None:
    answer = poses(SITE_MANIFEST, moved={BEAM: ((0.02, 0.0, 0.0), 0.0)})
    audit = audit_as_built(SITE_MANIFEST, answer, constructed={BEAM, OTHER})
    assert audit.answered and audit.checked == 2 and audit.wrong == (BEAM,)
    (error,) = audit.errors
    name = SITE_MANIFEST.component(BEAM).name
    assert f"{name} ({BEAM})" in error and "20.0 mm" in error and "tolerance 10 mm, 1°" in error
    assert audit.final[BEAM].position_error_m == pytest.approx(0.02)


def test_a_constructed_component_within_tolerance_is_no_error() -> None:
    answer = poses(SITE_MANIFEST, moved={BEAM: ((0.003, 0.004, 0.0), 0.5)})  # 5 mm, 0.5°
    audit = audit_as_built(SITE_MANIFEST, answer, constructed=set(GUIDS))
    assert audit.errors == () and audit.checked == len(GUIDS)
    position_m, angle_rad = audit.max_errors(GUIDS)
    assert position_m == pytest.approx(
        _centre_error_m(BEAM, (0.003, 0.004, 0.0), 0.5)
    ) and angle_rad == pytest.approx(0.5 * 3.141592653589793 / 180)


def test_a_component_that_is_not_constructed_is_never_an_error_wherever_it_is() -> None:
    answer = poses(SITE_MANIFEST, moved={OTHER: ((5.0, 0.0, 0.0), 90.0)}, missing=(THIRD,))
    audit = audit_as_built(SITE_MANIFEST, answer, constructed={BEAM})
    assert audit.errors == () and audit.checked == 1
    expected = _centre_error_m(OTHER, (5.0, 0.0, 0.0), 90.0)
    assert audit.final[OTHER].position_error_m == pytest.approx(expected)  # measured, not judged
    assert THIRD not in audit.final


def test_a_constructed_component_physics_has_no_pose_of_is_an_error() -> None:
    audit = audit_as_built(SITE_MANIFEST, poses(SITE_MANIFEST, missing=(OTHER,)), constructed={OTHER})
    assert audit.wrong == (OTHER,) and "physics has no pose of it" in audit.errors[0]


def test_the_report_gets_final_errors_per_component_the_largest_of_the_constructed_and_the_errors() -> None:
    report = ReportCollector(SITE_MANIFEST).report()
    answer = poses(SITE_MANIFEST, moved={BEAM: ((0.0, 0.0, 0.02), 0.0), FOURTH: ((1.0, 0.0, 0.0), 0.0)})
    audit = audit_as_built(SITE_MANIFEST, answer, constructed={BEAM, OTHER})
    add_to_report(report, audit, {BEAM, OTHER})
    by_guid = {c["guid"]: c for c in report["components"]}
    assert by_guid[BEAM]["final_position_error_mm"] == pytest.approx(20.0)
    assert by_guid[OTHER]["final_angle_error_deg"] == pytest.approx(0.0, abs=1e-6)
    assert by_guid[FOURTH]["final_position_error_mm"] == pytest.approx(1000.0)  # not constructed: not in max
    assert report["totals"]["max_final_position_error_mm"] == pytest.approx(20.0)
    assert report["totals"]["as_built_errors"] == 1 and report["as_built"]["wrong"] == [BEAM]
    json.dumps(report)  # plain JSON
    line = as_built_line(report)
    assert line is not None
    assert line.startswith(
        "as-built: 2 checked, largest deviation 20.00 mm / 0.00°, 1 beyond tolerance (10 mm / 1°):"
    )
    assert BEAM in line


def test_without_physics_every_final_error_is_null_and_the_summary_says_so() -> None:
    report = ReportCollector(SITE_MANIFEST).report()
    add_to_report(report, audit_as_built(SITE_MANIFEST, None, constructed={BEAM}), {BEAM})
    assert all(c["final_position_error_mm"] is None for c in report["components"])
    assert report["totals"]["max_final_position_error_mm"] is None
    assert as_built_line(report) == "as-built: not audited (physics did not answer physics/poses)"


def test_a_report_written_before_the_audit_has_the_keys_and_no_summary_line() -> None:
    report = ReportCollector(SITE_MANIFEST).report()
    add_to_report(report, None, set())
    assert report["as_built"]["audited"] is False and as_built_line(report) is None
    assert all(c["final_angle_error_deg"] is None for c in report["components"])


def test_the_summary_line_of_a_clean_build() -> None:
    report = ReportCollector(SITE_MANIFEST).report()
    answer = poses(SITE_MANIFEST, moved={OTHER: ((0.0004, 0.0, 0.0), 0.02)})
    add_to_report(report, audit_as_built(SITE_MANIFEST, answer, constructed=set(GUIDS)), set(GUIDS))
    expected_mm = 1000.0 * _centre_error_m(OTHER, (0.0004, 0.0, 0.0), 0.02)
    assert as_built_line(report) == (  # not "max …, 0 errors", which read as a contradiction
        f"as-built: 4 checked, largest deviation {expected_mm:.2f} mm / 0.02°, "
        "all within tolerance (10 mm / 1°)"
    )


def test_the_chart_carries_the_audit_in_its_title_and_marks_the_wrong_component(tmp_path: Path) -> None:
    report = ReportCollector(SITE_MANIFEST).report()
    answer = poses(SITE_MANIFEST, moved={BEAM: ((0.02, 0.0, 0.0), 0.0)})
    add_to_report(report, audit_as_built(SITE_MANIFEST, answer, constructed={BEAM}), {BEAM})
    report["components"][0]["reason"] = None  # as if constructed: the row shows its as-built error
    assert _as_built_title(report) == " — as-built: max 20.00 mm / 0.00°, 1 error"
    assert render_report_png(report, tmp_path / "report.png").stat().st_size > 10_000


def test_the_audit_says_when_it_asked_as_a_unix_time_not_as_a_duration() -> None:
    report = ReportCollector(SITE_MANIFEST).report()
    audit = audit_as_built(SITE_MANIFEST, poses(SITE_MANIFEST), constructed={BEAM}, asked_at_unix_s=1.7e9)
    add_to_report(report, audit, {BEAM})
    assert report["as_built"]["asked_at_unix_s"] == 1.7e9
    assert "wall_time_s" not in report["as_built"]  # it was a time stamp under a duration's name


def test_a_failed_component_moved_after_its_last_verdict_says_where_it_lies_at_the_end() -> None:
    """A component failed 14 mm off (out of attempts); a robot then dragged it 0.2 m: the run's report
    said only the 14 mm of its verdict. Its reason now ends with where physics has it at the end."""
    collector = ReportCollector(SITE_MANIFEST)
    for message in walk(BEAM, ComponentState.VERIFYING):
        collector.add(message)
    miss = Reason(code=ReasonCode.MISPLACED, message="out of tolerance (10 mm, 1°), attempt 3 of 3: 14.0 mm")
    failed = state(BEAM, ComponentState.FAILED, ComponentState.VERIFYING, "failed", sim_time_s=6.0)
    collector.add(
        failed.model_copy(update={"position_error_m": 0.014, "angle_error_rad": 0.0, "reason": miss})
    )
    report = collector.report()
    answer = poses(SITE_MANIFEST, moved={BEAM: ((0.2, 0.0, 0.0), 0.0), OTHER: ((0.003, 0.0, 0.0), 0.0)})
    add_to_report(report, audit_as_built(SITE_MANIFEST, answer, constructed=set()), set())
    by_guid = {c["guid"]: c for c in report["components"]}
    beam = by_guid[BEAM]
    assert beam["state"] == "failed" and beam["final_position_error_mm"] == pytest.approx(200.0)
    assert beam["reason"]["message"] == (
        f"{miss.message}; at the end it lies 200.0 mm and 0.00° from its BIM target (14.0 mm at its last "
        "verdict: it moved since)"
    )
    assert "at the end" not in by_guid[OTHER]["reason"]["message"]  # not failed: its reason stays as it was


def test_a_report_written_while_the_run_goes_on_says_why_it_has_no_final_errors() -> None:
    report = ReportCollector(SITE_MANIFEST).report()
    add_to_report(report, None, set())
    assert report["totals"]["max_final_position_error_mm"] is None
    assert "comes at its end" in report["as_built"]["note"]


def test_a_member_fitted_to_the_structure_is_audited_against_its_fitted_target() -> None:
    """Physics fitted the beam's target 9 mm along x (its support stood off its own): 15 mm from its BIM
    target it is 6 mm from its fitted one, no error; the report gives the fit, the summary counts it."""
    answer = poses(SITE_MANIFEST, moved={BEAM: ((0.015, 0.0, 0.0), 0.0)})
    target = SITE_MANIFEST.component(BEAM).target_pose_world
    x, y, z = target.position_m
    fitted = PoseMsg(position_m=(x + 0.009, y, z), quat_xyzw=target.quat_xyzw)
    beam = answer.components[BEAM].model_copy(update={"fitted_target": fitted})
    answer = answer.model_copy(update={"components": {**answer.components, BEAM: beam}})
    audit = audit_as_built(SITE_MANIFEST, answer, constructed={BEAM})
    assert audit.errors == () and audit.final[BEAM].position_error_m == pytest.approx(0.006, abs=1e-9)
    assert audit.fitted[BEAM] == pytest.approx((0.009, 0.0, 0.0), abs=1e-9)
    unfitted = audit_as_built(
        SITE_MANIFEST, poses(SITE_MANIFEST, moved={BEAM: ((0.015, 0.0, 0.0), 0.0)}), {BEAM}
    )
    assert unfitted.wrong == (BEAM,)
    report = {
        "components": [{"guid": BEAM, "state": "constructed"}],
        "totals": {},
    }
    add_to_report(report, audit, {BEAM})
    assert report["components"][0]["fitted_offset_mm"] == pytest.approx([9.0, 0.0, 0.0], abs=0.01)
    line = as_built_line(report)
    # the tolerance first, then what the fit did: "up to 9 mm from their BIM targets" beside "15 mm from the
    # BIM targets" beside "within 10 mm" read as three answers to one question
    assert line is not None and line.endswith(
        "all within tolerance (10 mm / 1°) of their targets (a fitted member's: where it fits the structure "
        "as built); 1 fitted to the structure as built (their "
        "targets moved up to 9.0 mm from the BIM model), so standing up to 15.0 mm from their BIM positions "
        "(at most 20 mm: a fit moves a target at most one tolerance, and the member stands within one "
        "tolerance of its fitted target)"
    )
    assert report["components"][0]["final_position_error_from_bim_mm"] == pytest.approx(15.0, abs=0.01)
