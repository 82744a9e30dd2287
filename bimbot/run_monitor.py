"""What ``bimbot run`` hears of a build: component states, robots, progress and the clock, as a report.

The subscriber callbacks only validate and enqueue (:class:`bimbot.shared.bus.Inbox`);
:meth:`RunMonitor.drain`, called from the run's waiting loop, feeds the messages to the observer's pure
:class:`bimbot.services.observer.report.ReportCollector`, so ``report.json``/``report.png`` are written
at the end of every run, with or without the observer (laser scans and plans are not subscribed: the
report does not use them).

It also keeps what the run's terminal and watchdog need: each robot's last state message, each task's
last message, and ``changes``, a count of every change on the site (a component state change, a change
of the planner's progress counts), which the stall watchdog (:mod:`bimbot.run_watchdog`) watches.
"""

from __future__ import annotations

import zenoh
from pydantic import BaseModel

from bimbot.services.observer.report import UNFINISHED, ReportCollector, RunEnding
from bimbot.shared.asked import Asked
from bimbot.shared.bus import Inbox, InvalidPayloads, Received
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import (
    CLOCK,
    COMPONENT_STATE,
    PLANNER_PLAN,
    PROGRESS,
    ROBOT_POSE,
    ROBOT_STATE,
    TASK,
    ClockMsg,
    ComponentState,
    ComponentStateMsg,
    ProgressMsg,
    RobotStateMsg,
    TaskMsg,
)


class RunMonitor:
    """Subscribes on ``session`` at construction; :meth:`drain` applies what arrived since the last call."""

    def __init__(self, manifest: Manifest, session: zenoh.Session) -> None:
        site = manifest.site
        self.invalid = InvalidPayloads()
        self.collector = ReportCollector(manifest)
        # the plan the planner builds by (its order is the report's sequence column), asked, never read
        self.plan = Asked(session, PLANNER_PLAN, self.invalid, site=site)
        self.states: dict[str, ComponentState] = {}
        self.misplacements = 0
        self.sim_time_s = 0.0
        self.done = False
        self.changes = 0
        self.robots: dict[str, RobotStateMsg] = {}
        self.tasks: dict[str, TaskMsg] = {}
        self.progress: ProgressMsg | None = None
        self.names = {c.guid: c.name for c in manifest.components}
        self.total = len(manifest.components)
        self._inbox = Inbox(self.invalid)
        inbox = self._inbox
        self._subscribers = [
            inbox.subscribe(session, COMPONENT_STATE, site=site, key="*"),
            inbox.subscribe(session, ROBOT_STATE, site=site, robot_id="*"),
            inbox.subscribe(session, ROBOT_POSE, site=site, robot_id="*"),
            inbox.subscribe(session, PROGRESS, site=site),
            inbox.subscribe(session, TASK, site=site, task_id="*"),
            inbox.subscribe(session, CLOCK, site=site),
        ]

    def drain(self, wait_s: float = 0.0) -> None:
        """Apply every queued message (waiting up to ``wait_s`` for the first)."""
        plan = self.plan.poll()
        if plan is not None and not self.collector.sequence_guids:
            self.collector.sequence_guids = list(plan.order)
        for item in self._inbox.drain(first_timeout_s=wait_s):
            if isinstance(item, Received):
                self.apply(item.message)

    def apply(self, message: BaseModel) -> None:
        self.collector.add(message)
        if isinstance(message, ComponentStateMsg):
            if self.states.get(message.guid) != message.state:
                self.changes += 1
            self.states[message.guid] = message.state
            if message.state == ComponentState.MISPLACED and message.previous is not None:
                self.misplacements += 1
        elif isinstance(message, ClockMsg):
            self.sim_time_s = max(self.sim_time_s, message.sim_time_s)
        elif isinstance(message, ProgressMsg):
            if self.progress is None or _progress_facts(message) != _progress_facts(self.progress):
                self.changes += 1
            self.progress = message
            self.done = self.done or message.done
        elif isinstance(message, RobotStateMsg):
            self.robots[message.robot_id] = message
        elif isinstance(message, TaskMsg):
            self.tasks[message.task_id] = message

    @property
    def constructed(self) -> int:
        return sum(state == ComponentState.CONSTRUCTED for state in self.states.values())

    def report(self, ending: RunEnding = UNFINISHED) -> dict:
        return self.collector.report(ending)


def _progress_facts(progress: ProgressMsg) -> tuple:
    """What of a progress message is a change on the site (not its time stamp or its estimate)."""
    return (sorted(progress.counts.items()), progress.failed, progress.blocked, progress.done)
