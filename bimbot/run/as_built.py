"""The as-built audit at the end of a run: where physics has each component against its BIM target.

A component's agent verifies its placement once, when it is placed. Afterwards it may still be pushed,
knocked over or dragged by a robot, and nothing would say so. At the end of a run (however it ends, as
long as physics still answers ``physics/poses``) the run compares every component's pose in physics with
its BIM target pose, with the agents' own measure (:func:`bimbot.shared.verification.
verify`: Euclidean position error, geodesic angle error) and the agents' own tolerances
(:class:`~bimbot.services.component_agents.agent.AgentConfig`, 10 mm and 1° by default):

* a component whose twin says ``constructed`` but that physics has beyond the tolerances, or has no pose
  of, is an audit error, named with its numbers;
* a component that is not constructed is never an error, wherever it is (at its target or in the yard);
* every component physics has a pose of gets its final errors (``final_position_error_mm``,
  ``final_angle_error_deg``), the constructed ones the largest of them in the totals.

Pure: a manifest, physics' answer and the set of constructed GUIDs in; an :class:`AsBuiltAudit` out.
:func:`add_to_report` writes it into ``report.json`` and :func:`as_built_line` reads it back from there
for the summary ``bimbot run`` prints, so the terminal and the file say the same.
"""

from __future__ import annotations

import math
from collections.abc import Collection
from dataclasses import dataclass, field
from typing import Any

from bimbot.services.component_agents.agent import AgentConfig
from bimbot.shared.manifest import Component, Manifest
from bimbot.shared.messages import SitePosesMsg
from bimbot.shared.verification import (
    HasPose,
    PlacementCheck,
    Tolerances,
    is_valid_pose,
    rotate,
    verify,
)

AGENT_TOLERANCES = AgentConfig().tolerances  # what the agents of a run accept (they run with the defaults)
MAX_ERRORS_SHOWN = 5  # in the summary line; report.json has every one


@dataclass(frozen=True)
class AsBuiltAudit:
    """The audit's result. ``answered`` False: physics did not answer, nothing could be compared."""

    answered: bool
    tolerances: Tolerances
    constructed: int  # components whose twins say constructed
    checked: int  # of those, the ones physics has a pose of
    final: dict[str, PlacementCheck]  # GUID → errors against the BIM target, every component physics has
    # GUID → how far (m, world) its target's centre was moved to fit the structure as built (physics'
    # support_fit.py): its final errors are measured from its fitted target
    fitted: dict[str, tuple[float, float, float]] = field(default_factory=dict)
    # GUID → the fitted ones' errors against their BIM targets, not their fitted ones (the design's view)
    from_bim: dict[str, PlacementCheck] = field(default_factory=dict)
    errors: tuple[str, ...] = ()  # one sentence per constructed component away from its target
    wrong: tuple[str, ...] = ()  # their GUIDs, in manifest order
    sim_time_s: float | None = None  # physics' answer: when
    step: int | None = None
    epoch: int | None = None
    asked_at_unix_s: float | None = None  # when the audit asked the twins and physics (Unix time, s)

    def max_errors(self, guids: Collection[str]) -> tuple[float | None, float | None]:
        """The largest position (m) and angle (rad) errors among ``guids`` (None: none measured)."""
        checks = [self.final[guid] for guid in guids if guid in self.final]
        if not checks:
            return None, None
        return max(c.position_error_m for c in checks), max(c.angle_error_rad for c in checks)


def audit_as_built(
    manifest: Manifest,
    poses: SitePosesMsg | None,
    constructed: Collection[str],
    tolerances: Tolerances = AGENT_TOLERANCES,
    asked_at_unix_s: float | None = None,
) -> AsBuiltAudit:
    """Compare physics' ``poses`` (None: physics did not answer) with every component's BIM target;
    ``constructed`` are the GUIDs the agents' twins say are constructed."""
    built = set(constructed)
    if poses is None:
        return AsBuiltAudit(False, tolerances, len(built), 0, {}, asked_at_unix_s=asked_at_unix_s)
    final: dict[str, PlacementCheck] = {}
    fitted: dict[str, tuple[float, float, float]] = {}
    from_bim: dict[str, PlacementCheck] = {}
    errors: list[str] = []
    wrong: list[str] = []
    for component in manifest.components:
        label = f"{component.name or component.ifc_class} ({component.guid})"
        pose = poses.components.get(component.guid)
        if pose is not None and is_valid_pose(pose.pose.position_m, pose.pose.quat_xyzw):
            target = pose.fitted_target or component.target_pose_world
            check = verify(pose.pose, target, tolerances, reference_local_m=component.com_local_m)
            if pose.fitted_target is not None:
                fitted[component.guid] = centre_moved_m(component, pose.fitted_target)
                from_bim[component.guid] = verify(
                    pose.pose,
                    component.target_pose_world,
                    tolerances,
                    reference_local_m=component.com_local_m,
                )
            final[component.guid] = check
            if component.guid in built and not check.ok:
                errors.append(
                    f"{label} is constructed but physics has it {check.position_error_m * 1000:.1f} mm and "
                    f"{math.degrees(check.angle_error_rad):.2f}° from its "
                    f"{'target fitted to the structure' if pose.fitted_target else 'BIM target'} (tolerance "
                    f"{tolerances.position_m * 1000:g} mm, {math.degrees(tolerances.angle_rad):g}°)"
                )
                wrong.append(component.guid)
        elif component.guid in built:
            what = "no pose" if pose is None else "an invalid pose"
            errors.append(f"{label} is constructed but physics has {what} of it")
            wrong.append(component.guid)
    return AsBuiltAudit(
        answered=True,
        tolerances=tolerances,
        constructed=len(built),
        checked=sum(1 for guid in built if guid in final),
        final=final,
        fitted=fitted,
        from_bim=from_bim,
        errors=tuple(errors),
        wrong=tuple(wrong),
        sim_time_s=poses.sim_time_s,
        step=poses.step,
        epoch=poses.epoch,
        asked_at_unix_s=asked_at_unix_s,
    )


def centre_moved_m(component: Component, fitted: HasPose) -> tuple[float, float, float]:
    """How far ``fitted`` puts ``component``'s centre from where its BIM target does (m, world)."""
    target = component.target_pose_world
    here, there = (
        rotate(fitted.quat_xyzw, component.com_local_m),
        rotate(target.quat_xyzw, component.com_local_m),
    )
    return (
        fitted.position_m[0] + here[0] - target.position_m[0] - there[0],
        fitted.position_m[1] + here[1] - target.position_m[1] - there[1],
        fitted.position_m[2] + here[2] - target.position_m[2] - there[2],
    )


def add_to_report(report: dict[str, Any], audit: AsBuiltAudit | None, constructed: Collection[str]) -> None:
    """Write the audit into ``report`` (from :meth:`ReportCollector.report`): per component
    ``final_position_error_mm``/``final_angle_error_deg`` (None when physics did not answer or has no pose
    of it), and a failed one's reason says where it lies at the end (:func:`where_it_lies`: it may have
    been pushed or dragged since its last verdict); the totals' ``max_final_*`` over the constructed ones
    and ``report["as_built"]``. Without an audit (a report written while the run goes on) the same keys
    hold None, and ``as_built.note`` says why."""
    final = audit.final if audit is not None else {}
    for component in report["components"]:
        check = final.get(component["guid"])
        component["final_position_error_mm"] = check.position_error_m * 1000.0 if check else None
        component["final_angle_error_deg"] = math.degrees(check.angle_error_rad) if check else None
        offset = audit.fitted.get(component["guid"]) if audit is not None else None
        component["fitted_offset_mm"] = [round(1000.0 * c, 2) for c in offset] if offset else None
        bim = (audit.from_bim.get(component["guid"]) if audit is not None else None) or check
        component["final_position_error_from_bim_mm"] = bim.position_error_m * 1000.0 if bim else None
        if check is not None and component["state"] == "failed" and component.get("reason"):
            assert audit is not None  # a check comes from an audit
            where = where_it_lies(check, component.get("position_error_mm"), audit.tolerances.position_m)
            component["reason"] = {
                **component["reason"],
                "message": f"{component['reason']['message']}; {where}",
            }
    position_m, angle_rad = audit.max_errors(constructed) if audit is not None else (None, None)
    totals = report["totals"]
    totals["max_final_position_error_mm"] = position_m * 1000.0 if position_m is not None else None
    totals["max_final_angle_error_deg"] = math.degrees(angle_rad) if angle_rad is not None else None
    totals["as_built_errors"] = len(audit.errors) if audit is not None else 0
    report["as_built"] = _as_dict(audit)


def where_it_lies(check: PlacementCheck, verdict_mm: float | None, tolerance_m: float) -> str:
    """Where a failed component lies at the end, against its BIM target: ``at the end it lies 212.3 mm and
    3.10° from its BIM target``, and when that is further than its last verdict said (by more than the
    position tolerance ``tolerance_m``), that it moved since."""
    position_mm = check.position_error_m * 1000.0
    line = (
        f"at the end it lies {position_mm:.1f} mm and {math.degrees(check.angle_error_rad):.2f}° from its "
        "BIM target"
    )
    if verdict_mm is not None and position_mm - verdict_mm > tolerance_m * 1000.0:
        line += f" ({verdict_mm:.1f} mm at its last verdict: it moved since)"
    return line


def _as_dict(audit: AsBuiltAudit | None) -> dict[str, Any]:
    if audit is None:
        return {
            "audited": False,
            "answered": False,
            "errors": [],
            "wrong": [],
            "note": "written while the run went on: the audit (and every final_* error) comes at its end",
        }
    return {
        "audited": True,
        "answered": audit.answered,
        "constructed": audit.constructed,
        "checked": audit.checked,
        "fitted_to_structure": len(audit.fitted),
        "tolerance_mm": audit.tolerances.position_m * 1000.0,
        "tolerance_deg": math.degrees(audit.tolerances.angle_rad),
        "errors": list(audit.errors),
        "wrong": list(audit.wrong),
        "sim_time_s": audit.sim_time_s,
        "step": audit.step,
        "epoch": audit.epoch,
        "asked_at_unix_s": audit.asked_at_unix_s,
    }


def as_built_line(report: dict[str, Any]) -> str | None:
    """The summary's line, from ``report.json``: ``as-built: 28 checked, largest deviation 0.40 mm /
    0.02°, all within tolerance (10 mm / 1°)``, or how many are beyond it, each named; None when the run
    made no audit."""
    audit = report.get("as_built") or {}
    if not audit.get("audited"):
        return None
    if not audit.get("answered"):
        return "as-built: not audited (physics did not answer physics/poses)"
    totals = report.get("totals", {})
    line = f"as-built: {audit['checked']} checked"
    position_mm, angle_deg = (
        totals.get("max_final_position_error_mm"),
        totals.get("max_final_angle_error_deg"),
    )
    if position_mm is not None and angle_deg is not None:
        line += f", largest deviation {position_mm:.2f} mm / {angle_deg:.2f}°"
    built = [c for c in report.get("components", []) if c.get("state") == "constructed"]
    fits = [math.hypot(*c["fitted_offset_mm"]) for c in built if c.get("fitted_offset_mm")]
    from_bim = [
        c["final_position_error_from_bim_mm"] for c in built if c.get("final_position_error_from_bim_mm")
    ]
    # "within 10 mm" beside "14.7 mm from BIM" read to a trial builder as a contradiction: say first
    # which targets the tolerance holds to
    tolerance = _tolerance_text(audit) + (
        " of their targets (a fitted member's: where it fits the structure as built)" if fits else ""
    )
    errors: list[str] = audit.get("errors", [])
    if not errors:
        line += f", all within tolerance{tolerance}"
    else:
        line += f", {len(errors)} beyond tolerance{tolerance}"
    if fits:
        # a fitted member is judged at its fitted target: its BIM deviation is how far the fit moved it
        # plus its own, not held to the tolerance
        line += (
            f"; {len(fits)} fitted to the structure as built (their targets moved up to {max(fits):.1f} mm "
            f"from the BIM model), so standing up to {max(from_bim):.1f} mm from their BIM positions"
        )
        position_mm = audit.get("tolerance_mm")
        if position_mm is not None:  # a fit moves a target at most one tolerance: two from the BIM model
            line += (
                f" (at most {2 * position_mm:g} mm: a fit moves a target at most one tolerance, and the "
                "member stands within one tolerance of its fitted target)"
            )
    if not errors:
        return line
    shown = [f"  {error}" for error in errors[:MAX_ERRORS_SHOWN]]
    if len(errors) > MAX_ERRORS_SHOWN:
        shown.append(f"  … and {len(errors) - MAX_ERRORS_SHOWN} more (report.json: as_built.errors)")
    return "\n".join([line + ":", *shown])


def _tolerance_text(audit: dict[str, Any]) -> str:
    """`` (10 mm / 1°)``: the tolerances the audit held the components to ("" in an older report)."""
    position_mm, angle_deg = audit.get("tolerance_mm"), audit.get("tolerance_deg")
    if position_mm is None or angle_deg is None:
        return ""
    return f" ({position_mm:g} mm / {angle_deg:g}°)"
