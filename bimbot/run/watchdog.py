"""The stall watchdog of ``bimbot run``: a build where nothing changes any more ends, and says so.

A site has stalled when no component changed state and the planner's progress did not change (counts,
failed, blocked) for ``stall_after_s`` seconds of *sim* time: robots that wait for a path that never comes,
a task handed back and forth without a state change, a planner that waits for nobody. The sim clock is
the measure, so a run at 50× real time stalls after the same simulated minutes as one at 1×; the verdict
stands once the planner confirms it (a progress said past the bound: news in flight when the clock jumped
come first), or after ``confirm_wall_s`` of wall time. Should the
clock itself stop (a service hung in lock-step, physics stuck), sim time no longer passes; then the
fallback bound is in wall time: the clock stood still for ``clock_stall_wall_s`` real seconds, with no
report of the planner's preparation meanwhile (it holds the clock at 0 while it works). Timed work
that says when it ends (a robot's ``busy_until_s``: formwork, a pour, a course) and curing holds (the
planner's progress) are changes scheduled ahead: the quiet time counts from the latest of them once it has
passed, so a site that skipped its clock over a three-day cure is not a stalled one.

:class:`StallWatchdog` is the pure core (no bus, no clock of its own: every call passes the times), fed by
the run's waiting loop. :func:`stall_details` says what each robot and each open component was doing when
the run ended (from the run monitor's last messages), the lines a user needs to see why.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from bimbot.shared.identifiers import named_guid
from bimbot.shared.messages import ComponentState, PreparingMsg, RobotStateMsg, TaskMsg, TaskStatus

DEFAULT_STALL_AFTER_S = 1500.0  # sim seconds without a change on the site (above every lower watchdog)
# A stall in sim time ends the run once the planner confirms it: a progress said at a sim time past the
# bound (news said before the clock moved, the planner's progress with a curing hold, comes from another
# service than the clock and may arrive after it: a clock that jumped over a 3-day cure is no stall). A
# planner that says nothing confirms it after this many wall seconds.
STALL_CONFIRM_WALL_S = 60.0
DEFAULT_CLOCK_STALL_WALL_S = 300.0  # wall seconds without the clock advancing (covers start-up: ≤ 120 s)
PLANNER_NOT_READY = (
    "the planner never said it was ready (no progress on the bus) and said nothing of its preparation for "
    "the wall bound: it hung, or one step of its preparation took that long on a busy machine (give it "
    "longer with --stall-wall-s); see logs/planner.log"
)
_SETTLED = (ComponentState.PLANNED, ComponentState.CONSTRUCTED, ComponentState.FAILED, ComponentState.BLOCKED)


@dataclass
class StallWatchdog:
    """Ends a run where nothing changes. Call :meth:`observe` as often as convenient; :meth:`verdict` is
    ``None`` while the site is alive, else the sentence (with the numbers) of why it is stalled."""

    stall_after_s: float = DEFAULT_STALL_AFTER_S
    clock_stall_wall_s: float = DEFAULT_CLOCK_STALL_WALL_S
    confirm_wall_s: float = STALL_CONFIRM_WALL_S
    _quiet_since_wall_s: float | None = None  # since when (wall) the sim-time bound has been passed
    _planner_sim_s: float | None = None
    _changes: int = -1
    _last_change_sim_s: float = 0.0
    _awaited_sim_s: float = 0.0  # the latest sim time something was scheduled to happen (timed work)
    _sim_s: float = 0.0
    _clock_sim_s: float | None = None
    _clock_moved_wall_s: float | None = None
    _wall_s: float = 0.0
    _preparing: int = 0

    def observe(  # noqa: PLR0917 - the facts of one observation, named at the call
        self,
        changes: int,
        sim_time_s: float,
        wall_s: float,
        awaited_sim_s: float = 0.0,
        preparing_heard: int = 0,
        planner_sim_s: float | None = None,
    ) -> None:
        """``changes`` counts every change on the site so far (state changes, progress changes);
        ``sim_time_s`` is the latest clock, ``wall_s`` a monotonic wall time; ``awaited_sim_s`` the latest
        sim time a change is scheduled for (timed work, curing), 0 when none; ``preparing_heard`` counts the
        planner's reports while it prepares its plan (the clock waits for it: a new one restarts the wall
        bound, so a planner that works is not taken for one that hung); ``planner_sim_s`` the sim time of
        the planner's latest progress (None: none yet), which confirms a stall in sim time."""
        self._planner_sim_s = planner_sim_s
        self._awaited_sim_s = max(self._awaited_sim_s, awaited_sim_s)
        if self._clock_moved_wall_s is None:
            self._clock_moved_wall_s = wall_s  # the wall bound counts from the first observation
        if self._clock_sim_s is None or sim_time_s > self._clock_sim_s or preparing_heard != self._preparing:
            self._clock_sim_s, self._clock_moved_wall_s = max(sim_time_s, self._clock_sim_s or 0.0), wall_s
            self._preparing = preparing_heard
        if changes != self._changes:
            self._changes, self._last_change_sim_s = changes, sim_time_s
        self._sim_s = max(self._sim_s, sim_time_s)
        self._wall_s = wall_s
        if not (self.stall_after_s > 0 and self.quiet_sim_s >= self.stall_after_s):
            self._quiet_since_wall_s = None
        elif self._quiet_since_wall_s is None:
            self._quiet_since_wall_s = wall_s

    @property
    def quiet_sim_s(self) -> float:
        """Sim seconds since the last change on the site (or since a scheduled one came due)."""
        return max(0.0, self._sim_s - self._quiet_from_sim_s)

    @property
    def _quiet_from_sim_s(self) -> float:
        return max(self._last_change_sim_s, min(self._awaited_sim_s, self._sim_s))

    def _stall_confirmed(self) -> bool:
        """The planner said its progress at a sim time past the bound, or nothing for ``confirm_wall_s``."""
        if self._quiet_since_wall_s is None:
            return False
        passed_s = self._quiet_from_sim_s + self.stall_after_s
        if self._planner_sim_s is not None and self._planner_sim_s >= passed_s:
            return True
        return self._wall_s - self._quiet_since_wall_s >= self.confirm_wall_s

    @property
    def clock_still_wall_s(self) -> float:
        """Wall seconds since the clock last advanced."""
        return 0.0 if self._clock_moved_wall_s is None else self._wall_s - self._clock_moved_wall_s

    def verdict(self) -> str | None:
        if self._stall_confirmed():
            return (
                f"nothing on the site changed for {self.quiet_sim_s:.0f} s of sim time "
                f"(last change at sim {self._last_change_sim_s:.1f} s, now {self._sim_s:.1f} s; "
                f"--stall-after-s {self.stall_after_s:g})"
            )
        if self.clock_stall_wall_s > 0 and self.clock_still_wall_s >= self.clock_stall_wall_s:
            return (
                f"the sim clock stood still at {self._sim_s:.1f} s for {self.clock_still_wall_s:.0f} s "
                f"of wall time (bound {self.clock_stall_wall_s:g} s)"
            )
        return None


def stall_details(
    robots: Mapping[str, RobotStateMsg],
    tasks: Mapping[str, TaskMsg],
    states: Mapping[str, ComponentState],
    names: Mapping[str, str | None],
    expected: Sequence[str] = (),
    *,
    planner_ready: bool = True,
    preparing: PreparingMsg | None = None,
) -> list[str]:
    """One line per robot (its last state message: state, task, component, activity; a robot of
    ``expected`` that never said a word: that, and where its log is) and per open task or component in
    progress (assigned to whom, in which state); first, unless ``planner_ready``, that the planner never
    said it was ready (and, when it said, how far its preparation went)."""
    lines = [] if planner_ready else [PLANNER_NOT_READY]
    if not planner_ready and preparing is not None:
        lines.append(f"the planner's last word: {preparing.stage}, {preparing.done} of {preparing.total}")
    lines += [
        f"robot {robot_id}: never said it was up (no state on the bus): its process hung or failed while "
        f"starting; see logs/robot-{robot_id}.log"
        for robot_id in expected
        if robot_id not in robots
    ]
    for robot_id, msg in sorted(robots.items()):
        on_task = f" task {msg.task_id}" if msg.task_id else ""
        guid = f" on {_label(msg.guid, names)}" if msg.guid else ""
        activity = f": {msg.activity}" if msg.activity else ""
        lines.append(
            f"robot {robot_id}: {msg.state.value}{on_task}{guid}{activity} (at sim {msg.sim_time_s:.1f} s)"
        )
    open_guids = set()
    for task_id, task in sorted(tasks.items()):
        if task.status not in (TaskStatus.RELEASED, TaskStatus.ASSIGNED):
            continue
        open_guids.add(task.guid)
        state = states.get(task.guid)
        whom = f" to {task.robot_id}" if task.robot_id else ", waiting for a robot"
        lines.append(
            f"task {task_id} ({_label(task.guid, names)}): {task.status.value}{whom}, attempt {task.attempt}"
            + (f", component {state.value}" if state else "")
        )
    for guid, state in sorted(states.items()):
        if state not in _SETTLED and guid not in open_guids:
            lines.append(f"component {_label(guid, names)}: {state.value}")
    return lines


def _label(guid: str, names: Mapping[str, str | None]) -> str:
    return named_guid(guid, names.get(guid))
