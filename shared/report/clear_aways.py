"""The report's clear-aways: failed bodies the planner had carried out of the robots' way (pure).

Why: a component that failed for good and lies where robots must drive gets one clear-away task (kind
``clear``, :mod:`bimbot.services.planner.clear_away`): a robot carries it to its yard slot. The component
stays failed, so its entry says besides its state whether it was cleared, by whom, when and how long it
took, or why not; a body left in the way says so in its reason too. Taken from the planner's task
messages of kind ``clear`` (assigned, then done or failed).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from bimbot.shared.messages import TaskKind, TaskMsg, TaskStatus
from bimbot.shared.reasons import Reason

from .totals import difference, dump_reason


@dataclass
class ClearSeen:
    """One component's clear-away as its task messages told it."""

    task_id: str
    robot_id: str | None = None
    assigned_s: float | None = None
    ended_s: float | None = None
    cleared: bool | None = None  # None: still open
    reason: Reason | None = None  # not cleared: why
    put_down_xy_m: tuple[float, float] | None = None


def take_clear(seen: dict[str, ClearSeen], message: TaskMsg) -> None:
    """Record a task message of kind ``clear`` (others are ignored)."""
    if message.kind is not TaskKind.CLEAR:
        return
    entry = seen.setdefault(message.guid, ClearSeen(message.task_id))
    if message.put_down_xy_m is not None:
        entry.put_down_xy_m = (message.put_down_xy_m[0], message.put_down_xy_m[1])
    if message.status is TaskStatus.ASSIGNED:
        entry.robot_id = message.robot_id or entry.robot_id
        if entry.assigned_s is None:
            entry.assigned_s = message.sim_time_s
    elif message.status in (TaskStatus.DONE, TaskStatus.FAILED) and entry.cleared is None:
        entry.cleared = message.status is TaskStatus.DONE
        entry.ended_s = message.sim_time_s
        entry.reason = message.reason
        entry.robot_id = entry.robot_id or message.robot_id


def clear_entry(entry: ClearSeen | None) -> dict[str, Any] | None:
    """``cleared_away`` of a component's report entry (None: it was never in the robots' way)."""
    if entry is None:
        return None
    return {
        "task_id": entry.task_id,
        "cleared": entry.cleared,
        "robot_id": entry.robot_id,
        "assigned_s": entry.assigned_s,
        "cleared_s": entry.ended_s if entry.cleared else None,
        "took_s": difference(entry.ended_s, entry.assigned_s) if entry.cleared else None,
        "put_down_xy_m": list(entry.put_down_xy_m) if entry.put_down_xy_m is not None else None,
        "reason": dump_reason(entry.reason),
    }


def with_clear_note(reason: Reason | None, entry: ClearSeen | None, max_chars: int) -> Reason | None:
    """A failed component's reason, saying so when its body was left in the robots' way."""
    if reason is None or entry is None or entry.cleared is not False or entry.reason is None:
        return reason
    note = f"; its body lies in the robots' way and was not cleared away: {entry.reason.message}"
    return reason.model_copy(update={"message": (reason.message + note)[:max_chars]})


def clear_totals(seen: dict[str, ClearSeen]) -> dict[str, Any]:
    """How many bodies were cleared away, how many left in the way, and the sim time clearing took."""
    cleared = [entry for entry in seen.values() if entry.cleared]
    return {
        "cleared_away": len(cleared),
        "not_cleared_away": sum(1 for entry in seen.values() if entry.cleared is False),
        "clear_away_s": sum(difference(e.ended_s, e.assigned_s) or 0.0 for e in cleared),
    }
