"""Live progress of ``bimbot run`` in the terminal: constructed/total, sim time, real-time factor, robots.

A slow build and a stuck one must look different while they run. On a terminal the progress is a rich
``Live`` display (redrawn a few times a second, one row per robot at work, named with its type: state,
task, component, what it is doing; the idle ones in one row); when stdout is not a terminal (a log file,
CI) it is one plain line as the clock starts, then one every ``PLAIN_EVERY_S`` wall seconds, so logs stay
readable (with more than ``PLAIN_ROBOTS_NAMED`` robots at work, those grouped by state); ``-q`` turns it
off. Sim time is said in minutes, hours or days once long (a plan run covers
days in seconds), the speed-up as ``×47,001``. The text is made by pure functions (:func:`progress_line`,
:func:`robot_lines`, :class:`RateWindow`); the displays only show it.
"""

from __future__ import annotations

import sys
from collections import deque
from collections.abc import Callable, Mapping
from typing import Protocol, TextIO

from rich.console import Console, Group
from rich.live import Live
from rich.text import Text

from bimbot.shared.messages import PreparingMsg, RobotState, RobotStateMsg
from bimbot.shared.report.durations import short_duration_text
from bimbot.shared.report.fleet import natural_key

PLAIN_EVERY_S = 10.0  # wall seconds between two plain progress lines
RATE_WINDOW_S = 10.0  # wall seconds over which the real-time factor is measured
LIVE_REFRESH_HZ = 4.0
MAX_ACTIVITY_CHARS = 60
# a plain line names each robot at work with its task and component up to this many robots; with more, the
# robots at work are grouped by state (11 robots made a 900-character line a log reader could not follow)
PLAIN_ROBOTS_NAMED = 3


class RateWindow:
    """The real-time factor (sim seconds per wall second) over the last ``window_s`` wall seconds."""

    def __init__(self, window_s: float = RATE_WINDOW_S) -> None:
        self.window_s = window_s
        self._samples: deque[tuple[float, float]] = deque()

    def add(self, wall_s: float, sim_time_s: float) -> None:
        if sim_time_s <= 0.0:  # the clock has not started (physics waits for the robots): no rate yet
            self._samples.clear()
            return
        self._samples.append((wall_s, sim_time_s))
        while len(self._samples) > 2 and wall_s - self._samples[1][0] >= self.window_s:
            self._samples.popleft()

    def factor(self) -> float | None:
        if len(self._samples) < 2:
            return None
        (wall0, sim0), (wall1, sim1) = self._samples[0], self._samples[-1]
        return (sim1 - sim0) / (wall1 - wall0) if wall1 > wall0 else None


def robot_label(robot_id: str, types: Mapping[str, str]) -> str:
    """``r1 (husky)``, as the summary names it; ``r1`` when its type is not known."""
    robot_type = types.get(robot_id)
    return f"{robot_id} ({robot_type})" if robot_type else robot_id


def robot_line(
    msg: RobotStateMsg, names: Mapping[str, str | None], types: Mapping[str, str] | None = None
) -> str:
    """``r1 (husky) pick_up T0004 Column A1: driving to the yard``."""
    parts = [robot_label(msg.robot_id, types or {}), msg.state.value]
    if msg.task_id:
        parts.append(msg.task_id)
    if msg.guid:
        parts.append(names.get(msg.guid) or msg.guid)  # a whole GUID: Revit's share their first characters
    line = " ".join(parts)
    if msg.activity:
        activity = msg.activity
        if len(activity) > MAX_ACTIVITY_CHARS:
            activity = activity[: MAX_ACTIVITY_CHARS - 1] + "…"
        line += f": {activity}"
    return line


def idle_line(robot_ids: list[str], types: Mapping[str, str], state: str = "idle") -> str:
    """``idle: r2 (carrier), r3, r4 (tower_crane)``: the robots idle with nothing to say (or all in one
    ``state``), those of a type together, in one line instead of one per robot."""
    by_type: dict[str, list[str]] = {}
    for robot_id in robot_ids:
        by_type.setdefault(types.get(robot_id, ""), []).append(robot_id)
    groups = [", ".join(ids) + (f" ({name})" if name else "") for name, ids in by_type.items()]
    return f"{state}: " + ", ".join(groups)


def grouped_robot_lines(robots: Mapping[str, RobotStateMsg], types: Mapping[str, str]) -> list[str]:
    """The robots at work grouped by state (``pick_up: r1, r5 (carrier)``), each state once, in the
    order of the task cycle; a robot with something to say keeps its own line; the idle ones last, as in
    :func:`robot_lines`. For a many-robot site in a plain log line."""
    lines: list[str] = []
    by_state: dict[RobotState, list[str]] = {}
    for robot_id in sorted(robots, key=natural_key):
        msg = robots[robot_id]
        if msg.activity:
            lines.append(robot_line(msg, {}, types))
        else:
            by_state.setdefault(msg.state, []).append(robot_id)
    order = list(RobotState)
    grouped = [idle_line(by_state[state], types, state.value) for state in order[1:] if state in by_state]
    idle = [idle_line(by_state[RobotState.IDLE], types)] if RobotState.IDLE in by_state else []
    return [*grouped, *lines, *idle]


def robot_lines(
    robots: Mapping[str, RobotStateMsg], names: Mapping[str, str | None], types: Mapping[str, str]
) -> list[str]:
    """A line per robot at work or with something to say (:func:`robot_line`), then the idle ones in one
    (:func:`idle_line`), in natural id order (r2 before r10)."""
    lines, idle = [], []
    for robot_id in sorted(robots, key=natural_key):
        msg = robots[robot_id]
        if msg.state is RobotState.IDLE and not msg.activity and not msg.task_id:
            idle.append(robot_id)
        else:
            lines.append(robot_line(msg, names, types))
    return [*lines, idle_line(idle, types)] if idle else lines


def speed_text(rtf: float | None) -> str:
    """``real time ×8.1``, ``×93``, ``×47,001`` (a plan run's clock jumps by events): sim seconds per
    wall second, as many digits as mean something."""
    if rtf is None:
        return "real time not yet measured"
    if rtf < 10.0:
        return f"real time ×{rtf:.1f}"
    return f"real time ×{rtf:,.0f}"


def progress_line(
    constructed: int,
    total: int,
    sim_time_s: float,
    rtf: float | None,
    wall_s: float,
    *,
    not_built: int = 0,
    preparing: PreparingMsg | None = None,
) -> str:
    """``constructed 3/9 · sim 412 s · real time ×8.1 · wall 51 s`` (sim time in minutes, hours or days
    when long: ``sim 13.1 h``), with ``· 2 will not be built (the
    table at the end says why)`` once the planner has failed or blocked some (those no robot on site can
    build fail before the build starts: "13/85" alone read as a run going badly); before the clock moves,
    that the services are still starting (physics holds its clock until every robot is up), or, while the
    planner prepares its plan (``preparing``, its last report), how far it is."""
    lost = f" · {not_built} will not be built (the table at the end says why)" if not_built else ""
    if sim_time_s == 0.0 and constructed == 0:
        waiting = "starting the services (the clock waits for the robots)"
        if preparing is not None:
            waiting = f"the planner prepares its plan: {preparing.stage}, {preparing.done}/{preparing.total}"
        return f"constructed 0/{total}{lost} · {waiting} · wall {wall_s:.0f} s"
    sim = short_duration_text(sim_time_s)
    return f"constructed {constructed}/{total}{lost} · sim {sim} · {speed_text(rtf)} · wall {wall_s:.0f} s"


class ProgressView(Protocol):
    """What the run's waiting loop calls: ``update`` often, ``close`` once."""

    def update(
        self,
        constructed: int,
        total: int,
        sim_time_s: float,
        robots: Mapping[str, RobotStateMsg],
        wall_s: float,
        *,
        not_built: int = 0,
        preparing: PreparingMsg | None = None,
    ) -> None: ...

    def close(self) -> None: ...


class _Base:
    def __init__(self, names: Mapping[str, str | None], types: Mapping[str, str] | None = None) -> None:
        self.names, self.types = names, types or {}
        self.rate = RateWindow()

    def update(
        self,
        constructed: int,
        total: int,
        sim_time_s: float,
        robots: Mapping[str, RobotStateMsg],
        wall_s: float,
        *,
        not_built: int = 0,
        preparing: PreparingMsg | None = None,
    ) -> None:
        self.rate.add(wall_s, sim_time_s)
        factor = self.rate.factor()
        head = progress_line(
            constructed, total, sim_time_s, factor, wall_s, not_built=not_built, preparing=preparing
        )
        self._show(head, self._robot_lines(robots), wall_s, sim_time_s)

    def _robot_lines(self, robots: Mapping[str, RobotStateMsg]) -> list[str]:
        return robot_lines(robots, self.names, self.types)

    def _show(self, head: str, robot_lines: list[str], wall_s: float, sim_time_s: float) -> None:
        raise NotImplementedError


class NoProgress:
    """``-q``: nothing."""

    def update(self, *_: object, **__: object) -> None:
        pass

    def close(self) -> None:
        pass


class PlainProgress(_Base):
    """One line as the site's clock starts, then one every ``every_s`` wall seconds (stdout is not a
    terminal: a log, a pipe, CI; the first line had come only after ``every_s``)."""

    def __init__(
        self,
        names: Mapping[str, str | None],
        say: Callable[[str], None],
        every_s: float = PLAIN_EVERY_S,
        types: Mapping[str, str] | None = None,
    ) -> None:
        super().__init__(names, types)
        self.say, self.every_s = say, every_s
        self._next_s = every_s
        self._clock_seen = False

    def _robot_lines(self, robots: Mapping[str, RobotStateMsg]) -> list[str]:
        at_work = sum(1 for msg in robots.values() if msg.state is not RobotState.IDLE or msg.task_id)
        if at_work > PLAIN_ROBOTS_NAMED:
            return grouped_robot_lines(robots, self.types)
        return super()._robot_lines(robots)

    def _show(self, head: str, robot_lines: list[str], wall_s: float, sim_time_s: float) -> None:
        if not self._clock_seen and sim_time_s > 0.0:
            self._clock_seen = True
            self._next_s = min(self._next_s, wall_s)
        if wall_s >= self._next_s:
            self._next_s = wall_s + self.every_s
            self.say(f"progress: {head}" + "".join(f"; {line}" for line in robot_lines))

    def close(self) -> None:
        pass


class LiveProgress(_Base):
    """A rich ``Live`` display on a terminal; lines written to stdout meanwhile appear above it."""

    def __init__(
        self, names: Mapping[str, str | None], stream: TextIO, types: Mapping[str, str] | None = None
    ) -> None:
        super().__init__(names, types)
        self._live = Live(
            Text("starting…"),
            console=Console(file=stream),
            refresh_per_second=LIVE_REFRESH_HZ,
            transient=True,
        )
        self._live.start()

    def _show(self, head: str, robot_lines: list[str], wall_s: float, sim_time_s: float) -> None:
        rows = [Text(head, style="bold")] + [
            Text(f"  {line}", overflow="ellipsis", no_wrap=True) for line in robot_lines
        ]
        self._live.update(Group(*rows))

    def close(self) -> None:
        self._live.stop()


def make_progress(
    names: Mapping[str, str | None],
    quiet: bool,
    say: Callable[[str], None],
    stream: TextIO | None = None,
    types: Mapping[str, str] | None = None,
) -> ProgressView:
    """The display that fits: none with ``quiet``, live on a terminal, plain lines otherwise; ``types``:
    robot id → its type, named beside each robot."""
    stream = stream or sys.stdout
    if quiet:
        return NoProgress()
    if stream.isatty():
        return LiveProgress(names, stream, types)
    return PlainProgress(names, say, types=types)
