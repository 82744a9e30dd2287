"""The report's fleet view: robots grouped by type, utilisation per type, and task kinds (build / hand-off).

Why: with a mixed fleet (Husky, carrier, tower crane) a single utilisation hides which type is the
bottleneck — a crane busy 90 % of the makespan while two carriers wait says "add a crane", not "add
robots". And a component a ground robot hands off to a crane costs two tasks (the hand-off, then the
crane's build), which must be visible as such. Pure functions over the report dictionary
(:mod:`.collector`) and the task ids; no bus, no files.

* Utilisation of a type: the busy time of its robots summed, over (its robots × the makespan); a robot on
  site that never left idle counts with 0 s. Where long waits fill the makespan (a 5-day cure), also over
  (its robots × the time some robot was at work): how busy it was while work went on.
* A task's kind: what its ``TaskMsg.kind`` said; a task never heard of is a hand-off when its id ends in
  ``-h<n>`` (the planner's ids for hand-offs: ``<build task id>-h<n>``), else a build.
* Lanes: robot types in the order of their first robot (natural id order: r2 before r10), the robots of a
  type together; robots of unknown type last.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from typing import Any

from bimbot.shared.messages import TaskKind

from .durations import duration_text
from .totals import busy_within_s

HAND_OFF_ID = re.compile(r"-h\d+$")
CLEAR_ID = re.compile(r"-c$")
UNKNOWN_TYPE = "unknown"
AT_WORK_SHARE = 0.5  # robots at work for less of the makespan than this: utilisation while at work too
_DIGITS = re.compile(r"(\d+)")


def task_kind(task_id: str | None, kinds: Mapping[str, TaskKind]) -> str | None:
    """``build`` or ``hand_off`` for ``task_id`` (None without a task id), see the module."""
    if task_id is None:
        return None
    kind = kinds.get(task_id)
    if kind is None:
        kind = TaskKind.HAND_OFF if HAND_OFF_ID.search(task_id) else TaskKind.BUILD
        kind = TaskKind.CLEAR if CLEAR_ID.search(task_id) else kind
    return kind.value


def natural_key(robot_id: str) -> tuple:
    """``r2`` before ``r10``: digit runs compare as numbers."""
    return tuple(int(part) if part.isdigit() else part for part in _DIGITS.split(robot_id))


def robot_order(robots: Mapping[str, Mapping[str, Any]]) -> list[str]:
    """Robot ids grouped by type (see the module), each robot report carrying its ``type``."""
    ids = sorted(robots, key=natural_key)
    first: dict[str, int] = {}
    for index, robot_id in enumerate(ids):
        first.setdefault(robots[robot_id].get("type") or UNKNOWN_TYPE, index)
    first[UNKNOWN_TYPE] = len(ids)  # unknown last
    return sorted(ids, key=lambda r: (first[robots[r].get("type") or UNKNOWN_TYPE], natural_key(r)))


def lane_label(robot_id: str, robot: Mapping[str, Any]) -> str:
    """``r2 (carrier)``; ``robot r2`` when its type is not known."""
    return f"{robot_id} ({robot['type']})" if robot.get("type") else f"robot {robot_id}"


def by_type(
    robots: Mapping[str, Mapping[str, Any]], window: tuple[float, float] | None
) -> dict[str, dict[str, Any]]:
    """Per robot type (in lane order): its robots, busy time, tasks by kind and utilisation: the busy
    time inside ``window`` (first release → last construction, sim s) over its robots × the makespan; None
    without a window."""
    out: dict[str, dict[str, Any]] = {}
    in_window: dict[str, float] = {}
    for robot_id in robot_order(robots):
        robot = robots[robot_id]
        name = robot.get("type") or UNKNOWN_TYPE
        entry = out.setdefault(
            name,
            {
                "robots": [],
                "busy_s": 0.0,
                "build_tasks": 0,
                "hand_off_tasks": 0,
                "clear_tasks": 0,
                "utilisation": None,
            },
        )
        entry["robots"].append(robot_id)
        entry["busy_s"] += robot["busy_s"]
        entry["build_tasks"] += _count(robot["tasks"], TaskKind.BUILD.value)
        entry["hand_off_tasks"] += _count(robot["tasks"], TaskKind.HAND_OFF.value)
        entry["clear_tasks"] += _count(robot["tasks"], TaskKind.CLEAR.value)
        in_window[name] = in_window.get(name, 0.0) + busy_within_s(robot, window)
    if window is not None and window[1] > window[0]:
        working_s = working_within_s(robots.values(), window)
        for name, entry in out.items():
            entry["utilisation"] = in_window[name] / (len(entry["robots"]) * (window[1] - window[0]))
            entry["utilisation_at_work"] = (
                in_window[name] / (len(entry["robots"]) * working_s) if working_s > 0.0 else None
            )
    return out


def working_within_s(robots: Iterable[Mapping[str, Any]], window: tuple[float, float]) -> float:
    """How long inside ``window`` some robot was at work (the union of every robot's tasks): the makespan
    less the waits when nothing could go on, such as a slab's cure before anything may rest on it."""
    spans = sorted(
        (max(window[0], task["start_s"]), min(window[1], task["end_s"]))
        for robot in robots
        for task in robot["tasks"]
        if min(window[1], task["end_s"]) > max(window[0], task["start_s"])
    )
    total_s, reach_s = 0.0, window[0]
    for start_s, end_s in spans:
        if end_s > reach_s:
            total_s += end_s - max(start_s, reach_s)
            reach_s = end_s
    return total_s


def utilisation_line(report: Mapping[str, Any]) -> str | None:
    """``utilisation by type (busy within the makespan / robots × makespan): husky 45 % (1 robot), …``,
    or None without types or a makespan; the part in brackets says what the percentages measure."""
    types = report.get("totals", {}).get("by_type") or {}
    parts = [
        f"{name} {percent(entry['utilisation'])} ({_robots(len(entry['robots']))})"
        for name, entry in types.items()
        if entry.get("utilisation") is not None
    ]
    if not parts:
        return None
    line = f"utilisation by type (busy within the makespan / robots × makespan): {', '.join(parts)}"
    at_work = [(name, entry) for name, entry in types.items() if entry.get("utilisation_at_work") is not None]
    working_s = report["totals"].get("working_s")
    makespan_s = report["totals"].get("makespan_s") or 0.0
    if (
        at_work and working_s is not None and makespan_s and working_s < AT_WORK_SHARE * makespan_s
    ):  # long waits (a cure) in it
        shares = ", ".join(f"{name} {percent(entry['utilisation_at_work'])}" for name, entry in at_work)
        line += f"; while some robot was at work ({duration_text(working_s)} of it): {shares}"
    return line


def percent(share: float) -> str:
    """``45 %``; ``<1 %`` for a share above 0 that rounds to 0 (a robot that did work is not idle)."""
    shown = f"{share * 100:.0f}"
    return "<1 %" if share > 0.0 and shown == "0" else f"{shown} %"


def _count(tasks: Iterable[Mapping[str, Any]], kind: str) -> int:
    return sum(1 for task in tasks if (task.get("kind") or TaskKind.BUILD.value) == kind)


def _robots(count: int) -> str:
    return f"{count} robot{'' if count == 1 else 's'}"
