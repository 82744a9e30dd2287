"""What a run decided, read back from its ``report.json``, and how two runs differ (pure).

A run's outcome is what "same seed, same outcome" promises: every component's state, construction method,
the robots that worked on it and its attempts, the order in which components became constructed, each
robot's tasks in order, and the makespan. :func:`outcome` reads it from a report (a dict), :func:`differences`
lists, one line each, where two outcomes differ (empty: the same outcome; makespans may differ by
``makespan_tolerance``, a fraction), :func:`spread` summarises many runs of one build (median and range of
the makespan and the constructed count, and the components whose outcome is not the same in every run).
"""

from __future__ import annotations

import statistics
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

MAKESPAN_TOLERANCE = 0.01  # two runs of one seed: makespans within 1 %


@dataclass(frozen=True)
class ComponentOutcome:
    state: str
    method: str | None
    robot_ids: tuple[str, ...]
    attempts: int
    constructed_s: float | None


@dataclass(frozen=True)
class RunOutcome:
    components: dict[str, ComponentOutcome]  # GUID → outcome
    order: tuple[str, ...]  # GUIDs in the order they became constructed (ties by GUID)
    tasks: dict[str, tuple[str, ...]]  # robot id → the GUIDs of its tasks, in order
    makespan_s: float | None
    constructed: int


def outcome(report: Mapping[str, Any]) -> RunOutcome:
    """The outcome of the run whose ``report.json`` is ``report``."""
    components = {
        item["guid"]: ComponentOutcome(
            state=item.get("state", "?"),
            method=item.get("method"),
            robot_ids=tuple(item.get("robot_ids") or ()),
            attempts=int(item.get("attempts") or 0),
            constructed_s=item.get("constructed_s"),
        )
        for item in report.get("components", [])
    }
    built = [(c.constructed_s, guid) for guid, c in components.items() if c.constructed_s is not None]
    tasks = {
        robot_id: tuple(task["guid"] for task in robot.get("tasks", []))
        for robot_id, robot in sorted((report.get("robots") or {}).items())
    }
    totals = report.get("totals") or {}
    return RunOutcome(
        components=components,
        order=tuple(guid for _, guid in sorted(built)),
        tasks=tasks,
        makespan_s=totals.get("makespan_s"),
        constructed=int(totals.get("constructed") or 0),
    )


def differences(a: RunOutcome, b: RunOutcome, makespan_tolerance: float = MAKESPAN_TOLERANCE) -> list[str]:
    """Where run ``b`` differs from run ``a``, one line each (empty: the same outcome)."""
    lines: list[str] = []
    for guid in sorted(a.components.keys() | b.components.keys()):
        first, second = a.components.get(guid), b.components.get(guid)
        if first is None or second is None:
            lines.append(f"{guid}: only in run {'a' if second is None else 'b'}")
            continue
        for field in ("state", "method", "robot_ids", "attempts"):
            x, y = getattr(first, field), getattr(second, field)
            if x != y:
                lines.append(f"{guid}: {field} {_show(x)} → {_show(y)}")
    if a.order != b.order:
        at = next((i for i, (x, y) in enumerate(zip(a.order, b.order, strict=False)) if x != y), None)
        at = min(len(a.order), len(b.order)) if at is None else at
        lines.append(
            f"construction order differs from position {at + 1}: "
            f"{' '.join(a.order[at : at + 3]) or '(end)'} … → {' '.join(b.order[at : at + 3]) or '(end)'} …"
        )
    for robot_id in sorted(a.tasks.keys() | b.tasks.keys()):
        x, y = a.tasks.get(robot_id, ()), b.tasks.get(robot_id, ())
        if x != y:
            lines.append(f"{robot_id}: tasks {len(x)} → {len(y)}, {_first_change(x, y)}")
    if not _close(a.makespan_s, b.makespan_s, makespan_tolerance):
        lines.append(
            f"makespan {_seconds(a.makespan_s)} → {_seconds(b.makespan_s)} (beyond {makespan_tolerance:.0%})"
        )
    return lines


@dataclass(frozen=True)
class Spread:
    runs: int
    makespan_median_s: float | None
    makespan_range_s: tuple[float, float] | None
    constructed_median: float
    constructed_range: tuple[int, int]
    varying: dict[str, list[str]]  # GUID → its outcome in each run, where not the same in every run


def spread(outcomes: Sequence[RunOutcome]) -> Spread:
    """Median and range of the makespan and the constructed count over ``outcomes`` (runs of one build),
    and each component whose state, robots or attempts are not the same in every run."""
    makespans = [item.makespan_s for item in outcomes if item.makespan_s is not None]
    counts = [item.constructed for item in outcomes]
    varying: dict[str, list[str]] = {}
    guids = sorted(set().union(*(item.components for item in outcomes))) if outcomes else []
    for guid in guids:
        seen = [_brief(item.components.get(guid)) for item in outcomes]
        if len(Counter(seen)) > 1:
            varying[guid] = seen
    return Spread(
        runs=len(outcomes),
        makespan_median_s=statistics.median(makespans) if makespans else None,
        makespan_range_s=(min(makespans), max(makespans)) if makespans else None,
        constructed_median=statistics.median(counts) if counts else 0.0,
        constructed_range=(min(counts), max(counts)) if counts else (0, 0),
        varying=varying,
    )


def _brief(item: ComponentOutcome | None) -> str:
    if item is None:
        return "absent"
    robots = "+".join(item.robot_ids) or "-"
    return f"{item.state}/{robots}/{item.attempts}"


def _close(x: float | None, y: float | None, tolerance: float) -> bool:
    if x is None or y is None:
        return x is y
    return abs(x - y) <= tolerance * max(abs(x), abs(y))


def _seconds(value: float | None) -> str:
    return "none" if value is None else f"{value:.1f} s"


def _show(value: object) -> str:
    return "+".join(value) or "-" if isinstance(value, tuple) else str(value)


def _first_change(x: tuple[str, ...], y: tuple[str, ...]) -> str:
    at = next((i for i, (p, q) in enumerate(zip(x, y, strict=False)) if p != q), min(len(x), len(y)))
    first, second = (items[at] if at < len(items) else "(none)" for items in (x, y))
    return f"first differs at task {at + 1}: {first} → {second}"
