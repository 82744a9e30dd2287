"""The report's robots: one timeline per robot (busy intervals, distance driven) and its ``report.json``
entry. Pure: no bus, no files; apart from :mod:`.collector` so the collector stays about components.

* ``busy_s`` — the time between leaving ``idle`` and returning to it, summed (an interval still open at
  the end of the run is closed at the last sim time seen; a new task without idle between starts a new
  interval).
* ``tasks`` — those intervals with the component handled and the task's ``kind`` (``build``, or
  ``hand_off`` with its ``put_down_xy_m``; :mod:`.fleet`).
* ``distance_m`` — driven in the plane, from ground truth (``robots/<id>/pose``), else odometry, else the
  robot's own ``distance_m`` in its state messages, else its state poses (``distance_source`` says which).
* ``relocations`` — how often a truck-mounted machine moved to another set-up position (its own count in
  its state messages; 0 for every other robot).
* ``built`` and ``given_back`` — its tasks apart by how they ended: components it placed that were judged
  constructed, and tasks it gave back (its ``abandon`` events); the collector counts them.
* ``walled_in`` — each time it said it was walled in (no way to its depot start): ``since_s``, where it
  stood (``xy_m``) and ``until_s`` (None: still walled in when the run ended).
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from bimbot.shared.messages import ComponentState, RobotState, RobotStateMsg, TaskKind

from .fleet import task_kind

DISTANCE_SOURCES = ("ground_truth", "odom", "robot_state", "state_poses")  # best first


@dataclass
class BusyInterval:
    start_s: float
    end_s: float | None = None
    guid: str | None = None
    task_id: str | None = None


@dataclass
class WalledIn:
    """A robot walled in: since when, where it stood, and until when (None: still at the end)."""

    since_s: float
    xy_m: tuple[float, float]
    until_s: float | None = None


@dataclass
class RobotTimeline:
    """What one robot did: its last state, its busy intervals and the distance it drove, per source."""

    state: RobotState | None = None
    intervals: list[BusyInterval] = field(default_factory=list)
    distances_m: dict[str, float] = field(default_factory=lambda: dict.fromkeys(DISTANCE_SOURCES, 0.0))
    last_xy: dict[str, tuple[float, float]] = field(default_factory=dict)
    reported_distance_m: float = 0.0
    relocations: int = 0
    walled_in: list[WalledIn] = field(default_factory=list)

    def take_state(self, msg: RobotStateMsg) -> None:
        """A state message of this robot: opens, names or closes its busy interval and its time walled in."""
        self.reported_distance_m = max(self.reported_distance_m, msg.distance_m)
        self.relocations = max(self.relocations, msg.relocations)
        self._walled_in(msg)
        self.travel("state_poses", msg.pose_xy_yaw)
        busy = msg.state != RobotState.IDLE
        open_interval = self.intervals[-1] if self.intervals and self.intervals[-1].end_s is None else None
        if (
            busy
            and open_interval is not None
            and open_interval.task_id is not None
            and msg.task_id not in (None, open_interval.task_id)
        ):  # the next task without idle between: its own interval
            open_interval.end_s = max(msg.sim_time_s, open_interval.start_s)
            open_interval = None
        if busy and open_interval is None:
            self.intervals.append(BusyInterval(start_s=msg.sim_time_s, guid=msg.guid, task_id=msg.task_id))
        elif busy and open_interval is not None and open_interval.guid is None:
            open_interval.guid, open_interval.task_id = msg.guid, msg.task_id
        elif not busy and open_interval is not None:
            open_interval.end_s = max(msg.sim_time_s, open_interval.start_s)
        self.state = msg.state

    def _walled_in(self, msg: RobotStateMsg) -> None:
        last = self.walled_in[-1] if self.walled_in else None
        open_episode = last if last is not None and last.until_s is None else None
        if msg.walled_in_since_s is not None and open_episode is None:
            if last is None or last.since_s != msg.walled_in_since_s:  # (a late message of a closed one: no)
                xy = (msg.pose_xy_yaw[0], msg.pose_xy_yaw[1])
                self.walled_in.append(WalledIn(msg.walled_in_since_s, xy))
        elif msg.walled_in_since_s is None and open_episode is not None:
            open_episode.until_s = max(msg.sim_time_s, open_episode.since_s)

    def travel(self, source: str, pose_xy_yaw: tuple[float, float, float]) -> None:
        """A pose of this robot from ``source`` (one of :data:`DISTANCE_SOURCES`): adds the leg driven."""
        xy = (pose_xy_yaw[0], pose_xy_yaw[1])
        last = self.last_xy.get(source)
        if last is not None:
            self.distances_m[source] += math.dist(last, xy)
        self.last_xy[source] = xy


def tasks_by_end(components: list[dict[str, Any]]) -> tuple[Counter[str], Counter[str]]:
    """Per robot, from the report's component entries: its placements judged constructed, and the tasks it
    gave back (``given_back_by``)."""
    built: Counter[str] = Counter()
    given_back: Counter[str] = Counter()
    for component in components:
        built.update(
            placement["robot_id"]
            for placement in component.get("placements", [])
            if placement.get("robot_id") and placement.get("verdict") == ComponentState.CONSTRUCTED.value
        )
        given_back.update(robot_id for robot_id in component.get("given_back_by", []) if robot_id)
    return built, given_back


def robot_entry(
    robot: RobotTimeline,
    robot_type: str | None,
    task_kinds: Mapping[str, TaskKind],
    put_downs: Mapping[str, tuple[float, float]],
    end_s: float,
    *,
    built: int = 0,
    given_back: int = 0,
) -> dict[str, Any]:
    """A robot as ``report.json`` lists it (see the module); ``end_s`` closes an interval still open;
    ``built`` and ``given_back``: its tasks by how they ended (the collector counts them)."""
    tasks: list[dict[str, Any]] = [
        {
            "guid": interval.guid,
            "task_id": interval.task_id,
            "kind": task_kind(interval.task_id, task_kinds),
            "start_s": interval.start_s,
            "end_s": interval.end_s if interval.end_s is not None else max(end_s, interval.start_s),
            "open": interval.end_s is None,
        }
        for interval in robot.intervals
    ]
    for task in tasks:
        if task["kind"] in (TaskKind.HAND_OFF.value, TaskKind.CLEAR.value):
            task["put_down_xy_m"] = put_downs.get(task["task_id"])
    distance, source = robot.reported_distance_m, "robot_state"
    for candidate in ("ground_truth", "odom"):
        if candidate in robot.last_xy:
            distance, source = robot.distances_m[candidate], candidate
            break
    else:
        if robot.reported_distance_m <= 0.0:
            distance, source = robot.distances_m["state_poses"], "state_poses"
    return {
        "type": robot_type,
        "busy_s": sum(task["end_s"] - task["start_s"] for task in tasks),
        "distance_m": distance,
        "distance_source": source,
        "relocations": robot.relocations,
        "tasks": tasks,
        "built": built,
        "given_back": given_back,
        "walled_in": [
            {"since_s": spell.since_s, "xy_m": list(spell.xy_m), "until_s": spell.until_s}
            for spell in robot.walled_in
        ],
        "state": robot.state.value if robot.state else None,
    }
