"""The report's totals and small value helpers: pure functions over the report's component and robot
entries (:mod:`.collector`), apart so the collector stays about its timelines."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from bimbot.shared.messages import ComponentState
from bimbot.shared.reasons import Reason


def dump_reason(reason: Reason | None) -> dict[str, Any] | None:
    return reason.model_dump(mode="json") if reason is not None else None


def count_reasons(components: list[dict[str, Any]]) -> dict[str, int]:
    counts: dict[str, int] = {}
    for component in components:
        if component["reason"] is not None:
            code = component["reason"]["code"]
            counts[code] = counts.get(code, 0) + 1
    return dict(sorted(counts.items()))


def scaled(value: float | None, factor: float) -> float | None:
    return value * factor if value is not None else None


def difference(later: float | None, earlier: float | None) -> float | None:
    return later - earlier if later is not None and earlier is not None else None


def busy_within_s(robot: Mapping[str, Any], window: tuple[float, float] | None) -> float:
    """A robot's busy time inside ``window`` (sim s, first release → last construction): utilisation is
    the share of the makespan a robot worked, so a task that went on after the last component was built
    (one that failed, a give-back) counts only up to there; it once gave 116 %."""
    if window is None:
        return 0.0
    start_s, end_s = window
    return sum(max(0.0, min(end_s, t["end_s"]) - max(start_s, t["start_s"])) for t in robot["tasks"])


def makespan_window(components: list[dict[str, Any]]) -> tuple[float, float] | None:
    """(first release, last construction) in sim seconds, or None before anything was constructed."""
    released = [c["released_s"] for c in components if c["released_s"] is not None]
    constructed = [c["constructed_s"] for c in components if c["constructed_s"] is not None]
    return (min(released), max(constructed)) if released and constructed else None


def totals_of(components: list[dict[str, Any]], robots: dict[str, dict[str, Any]]) -> dict[str, Any]:
    by_state: dict[str, int] = {}
    for component in components:
        by_state[component["state"]] = by_state.get(component["state"], 0) + 1
    released = [c["released_s"] for c in components if c["released_s"] is not None]
    constructed = [c["constructed_s"] for c in components if c["constructed_s"] is not None]
    makespan = max(constructed) - min(released) if released and constructed else None
    busy = sum(robot["busy_s"] for robot in robots.values())
    built = [c for c in components if c["state"] == ComponentState.CONSTRUCTED.value]
    position_errors = [c["position_error_mm"] for c in built if c["position_error_mm"] is not None]
    angle_errors = [c["angle_error_deg"] for c in built if c["angle_error_deg"] is not None]
    window = makespan_window(components)
    in_window = sum(busy_within_s(robot, window) for robot in robots.values())
    utilisation = in_window / (len(robots) * makespan) if robots and makespan else None
    return {
        "components": len(components),
        "by_state": dict(sorted(by_state.items())),
        "constructed": by_state.get(ComponentState.CONSTRUCTED.value, 0),
        "failed": by_state.get(ComponentState.FAILED.value, 0),
        "retries": sum(c["retries"] for c in components),
        "give_backs": sum(len(c["give_backs"]) for c in components),
        "first_release_s": min(released) if released else None,
        "last_constructed_s": max(constructed) if constructed else None,
        "makespan_s": makespan,
        "robots": len(robots),
        "busy_s": busy,
        "distance_m": sum(robot["distance_m"] for robot in robots.values()),
        "utilisation": utilisation,
        "max_position_error_mm": max(position_errors) if position_errors else None,
        "max_angle_error_deg": max(angle_errors) if angle_errors else None,
    }
