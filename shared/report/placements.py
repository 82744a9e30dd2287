"""Placements in the construction report: one record per verified attempt, the distribution of placement
errors per robot type, retries by cause, and how far components moved after they were released.

Why: a robot places a component from where it believes it stands, with its robot type's precision, and
physics then releases it into dynamics, where it may slide, tip or fall. The largest error of the
constructed components does not say which robot type misses, how often, nor whether a miss was an
imprecise release (``misplaced``) or a component that moved after release (``unstable``). These pure
functions turn the agents' verdicts into those figures; no bus, no files.

* A *verdict* is a component state change out of ``verifying`` (to ``constructed``, ``misplaced`` or
  ``failed``): its agent's measurement of one placement attempt (:class:`Placement`).
* Its *cause*: ``within_tolerance`` when constructed; else ``unstable`` when the verdict's reason says so,
  else ``misplaced`` (a miss whose reason is missing or names something else was released off target).
* Distribution per robot type (the type of the robot that placed it, from physics' site info; ``unknown``
  without one): over every attempt, ``placements`` (attempts), ``unmeasured`` (attempts without a
  position error: no pose on the bus), ``mean``/``p50``/``p95``/``max`` of the position errors in mm
  (percentiles interpolated linearly between order statistics, as numpy's default), and
  ``out_of_tolerance``: the attempts the agent judged out of tolerance as placed (its verdict, not a
  second threshold here; a miss by angle alone counts), not those that moved after release (``unstable``,
  counted apart: one attempt is one of the two, never both).
* Retries by cause: the ``misplaced`` verdicts (each one a retry), by cause. A ``failed`` verdict is not
  retried: its cause is in its component's reason (``totals.by_reason``).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from bimbot.shared.messages import ComponentState, ComponentStateMsg
from bimbot.shared.reasons import ReasonCode

from .fleet import UNKNOWN_TYPE

WITHIN_TOLERANCE = "within_tolerance"
MISPLACED = ReasonCode.MISPLACED.value
UNSTABLE = ReasonCode.UNSTABLE.value
RETRY_CAUSES = (MISPLACED, UNSTABLE)
VERDICT_STATES = (ComponentState.CONSTRUCTED, ComponentState.MISPLACED, ComponentState.FAILED)
PLACEMENT_REASON_CODES = (ReasonCode.MISPLACED, ReasonCode.UNSTABLE)  # a verdict's, not a give-back's


@dataclass(frozen=True)
class Placement:
    """One verified placement attempt as its agent measured it (SI units; ``None``: not measured)."""

    attempt: int
    robot_id: str | None
    verdict: ComponentState
    cause: str
    position_error_m: float | None
    angle_error_rad: float | None
    drift_m: float | None
    sim_time_s: float


def is_verdict(msg: ComponentStateMsg) -> bool:
    """A state change out of ``verifying``: the agent's verdict on one placement."""
    return msg.previous == ComponentState.VERIFYING and msg.state in VERDICT_STATES


def placement_of(msg: ComponentStateMsg) -> Placement | None:
    """The placement a verdict measured (None for any other state message)."""
    if not is_verdict(msg):
        return None
    if msg.state == ComponentState.CONSTRUCTED:
        cause = WITHIN_TOLERANCE
    elif msg.reason is not None and msg.reason.code == ReasonCode.UNSTABLE:
        cause = UNSTABLE
    else:
        cause = MISPLACED
    return Placement(
        attempt=msg.attempt,
        robot_id=msg.robot_id,
        verdict=msg.state,
        cause=cause,
        position_error_m=msg.position_error_m,
        angle_error_rad=msg.angle_error_rad,
        drift_m=msg.drift_m,
        sim_time_s=msg.sim_time_s,
    )


def _scaled(value: float | None, factor: float) -> float | None:
    return value * factor if value is not None else None


def placement_entry(placement: Placement, robot_type: str | None) -> dict[str, Any]:
    """A placement as ``report.json`` lists it (mm and degrees)."""
    return {
        "attempt": placement.attempt,
        "robot_id": placement.robot_id,
        "robot_type": robot_type,
        "position_error_mm": _scaled(placement.position_error_m, 1000.0),
        "angle_error_deg": _scaled(placement.angle_error_rad, 180.0 / math.pi),
        "drift_mm": _scaled(placement.drift_m, 1000.0),
        "verdict": placement.verdict.value,
        "cause": placement.cause,
        "sim_time_s": placement.sim_time_s,
    }


def max_or_none(values: Iterable[float | None]) -> float | None:
    known = [value for value in values if value is not None]
    return max(known) if known else None


def percentile(sorted_values: Sequence[float], fraction: float) -> float:
    """The ``fraction`` quantile (0–1) of ascending ``sorted_values``, interpolated linearly between the
    order statistics (numpy's default method)."""
    if not sorted_values:
        raise ValueError("no values")
    rank = fraction * (len(sorted_values) - 1)
    low = math.floor(rank)
    high = min(low + 1, len(sorted_values) - 1)
    return sorted_values[low] + (rank - low) * (sorted_values[high] - sorted_values[low])


def error_distribution(placements: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """The distribution of position errors of ``placements`` (entries of :func:`placement_entry`). An
    unstable placement is counted (``unstable``) but its error is not in the distribution: it was measured
    after the component moved (a member that fell 3 m made a robot's mean error 546 mm on the Revit hub),
    so it says how the structure held, not how the robot placed."""
    placed = [p for p in placements if p["cause"] != UNSTABLE]
    errors = sorted(p["position_error_mm"] for p in placed if p["position_error_mm"] is not None)
    return {
        "placements": len(placements),
        "unstable": len(placements) - len(placed),
        "unmeasured": len(placed) - len(errors),
        "mean": sum(errors) / len(errors) if errors else None,
        "p50": percentile(errors, 0.50) if errors else None,
        "p95": percentile(errors, 0.95) if errors else None,
        "max": errors[-1] if errors else None,
        "out_of_tolerance": sum(1 for p in placed if p["cause"] != WITHIN_TOLERANCE),
    }


def type_of(placement: Mapping[str, Any]) -> str:
    return placement.get("robot_type") or UNKNOWN_TYPE


def placement_totals(
    components: Iterable[Mapping[str, Any]], type_order: Sequence[str] = ()
) -> dict[str, Any]:
    """``placement_error_mm_by_type`` (robot types in ``type_order`` first, the Gantt's lane order, then
    by name, ``unknown`` last), ``retries_by_cause`` and ``max_drift_mm`` over every component's
    ``placements``, with ``max_drift_component``: the name (else GUID) of the component it moved."""
    components = list(components)
    placements = [p for component in components for p in component.get("placements", [])]
    drifts = [
        (p["drift_mm"], str(component.get("name") or component.get("guid") or ""))
        for component in components
        for p in component.get("placements", [])
        if p.get("drift_mm") is not None
    ]
    by_type: dict[str, list[Mapping[str, Any]]] = {}
    for placement in placements:
        by_type.setdefault(type_of(placement), []).append(placement)
    rank = {name: index for index, name in enumerate(type_order)}
    names = sorted(by_type, key=lambda name: (name == UNKNOWN_TYPE, rank.get(name, len(rank)), name))
    retries = dict.fromkeys(RETRY_CAUSES, 0)
    for placement in placements:
        if placement["verdict"] == ComponentState.MISPLACED.value:
            retries[placement["cause"]] += 1
    return {
        "placement_error_mm_by_type": {name: error_distribution(by_type[name]) for name in names},
        "retries_by_cause": retries,
        "max_drift_mm": max(drifts)[0] if drifts else None,
        "max_drift_component": max(drifts)[1] if drifts else None,
    }


def placement_line(report: Mapping[str, Any]) -> str | None:
    """One summary line: ``every placement attempt by robot type: husky mean 6.7 / p95 13.0 / max 14.0 mm (3
    placements, 1 out of tolerance), …; retries by cause: misplaced 3, unstable 1; largest drift after
    placement 75.0 mm``; None when no placement was verified."""
    totals = report.get("totals", {})
    by_type = totals.get("placement_error_mm_by_type") or {}
    if not by_type:
        return None
    parts = []
    for name, entry in by_type.items():
        count = f"{entry['placements']} placement{'' if entry['placements'] == 1 else 's'}"
        if entry["out_of_tolerance"]:
            count += f", {entry['out_of_tolerance']} out of tolerance"
        if entry.get("unstable"):
            count += f", {entry['unstable']} unstable: moved after release, not in these errors"
        if entry["mean"] is None:
            parts.append(f"{name} not measured ({count})")
        else:
            figures = f"mean {entry['mean']:.1f} / p95 {entry['p95']:.1f} / max {entry['max']:.1f} mm"
            parts.append(f"{name} {figures} ({count})")
    retries = totals.get("retries_by_cause") or {}
    line = "every placement attempt by robot type: " + ", ".join(parts)
    line += "; retries by cause: " + ", ".join(f"{cause} {count}" for cause, count in retries.items())
    drift = totals.get("max_drift_mm")
    if drift is None:
        return line + "; drift not measured"
    line += f"; largest drift after placement {drift:.1f} mm"
    moved = totals.get("max_drift_component")
    return line + (f" ({moved}: it slid, tipped or fell after its release)" if moved and drift > 5.0 else "")


def caught_on_last_attempt(report: dict[str, Any]) -> int:
    """Placements caught off target or unstable on their component's last attempt (verdict ``failed``):
    not retried, so not among the retries, but drawn among the placement panels' markers."""
    return sum(
        placement.get("verdict") == "failed"
        for component in report.get("components", [])
        for placement in component.get("placements", [])
    )
