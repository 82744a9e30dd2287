"""What ``bimbot run`` hears of a build: component states, robots, progress and the clock, as a report.

The subscriber callbacks only validate and enqueue (:class:`bimbot.shared.bus.Inbox`);
:meth:`RunMonitor.drain`, called from the run's waiting loop, feeds the messages to the observer's pure
:class:`bimbot.shared.report.collector.ReportCollector`, so ``report.json``/``report.png`` are written
at the end of every run, with or without the observer (laser scans and plans are not subscribed: the
report does not use them). Physics' site info is asked once it answers: the robots' types, by which the report
groups its lanes and gives utilisation per type.

What is constructed comes from the agents' twins, never from a state message alone
(:mod:`bimbot.shared.trusted_states`): a state message is a hint; a claim of a terminal
state (or a message that does not follow from what is known) makes the monitor ask that component's twin,
once, without blocking (the answer comes back through the inbox, at most one question per component
every ``TWIN_RETRY_S``), and only the twin's answer counts; a transition the agents' state table does
not allow is dropped at once.
A component's timeline in the report is rebuilt from its twin whenever one answers.

At the end, before the services stop, :meth:`RunMonitor.audit` asks every twin at once
(``components/*/twin``: the last word on each component's state) and physics for every pose
(``physics/poses``), and compares the constructed components with their BIM targets
(:mod:`bimbot.run.as_built`); :meth:`RunMonitor.report` includes the result.

It also keeps what the run's terminal and watchdog need: each robot's last state message, each task's
last message, and ``changes``, a count of every change on the site (a component state change, a change
of the planner's progress counts), which the stall watchdog (:mod:`bimbot.run.watchdog`) watches.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Mapping
from typing import Any

import zenoh
from pydantic import BaseModel

from bimbot.run.as_built import AGENT_TOLERANCES, AsBuiltAudit, add_to_report, audit_as_built
from bimbot.shared.asked import Asked
from bimbot.shared.bus import Answer, Inbox, InvalidPayloads, Received, query_first
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import (
    CLOCK,
    COMPONENT_POSE,
    COMPONENT_STATE,
    COMPONENT_TWIN,
    PHYSICS_INFO,
    PHYSICS_POSES,
    PLANNER_PLAN,
    PLANNER_PREPARING,
    PROGRESS,
    ROBOT_POSE,
    ROBOT_STATE,
    TASK,
    ComponentState,
    ComponentStateMsg,
    PreparingMsg,
    ProgressMsg,
    RobotStateMsg,
    TaskMsg,
    TwinMsg,
)
from bimbot.shared.report.collector import UNFINISHED, ReportCollector, RunEnding
from bimbot.shared.trusted_states import Judgement, TrustedStates
from bimbot.shared.twin_query import ask_twin, ask_twins
from bimbot.shared.verification import Tolerances

_log = logging.getLogger(__name__)

TWIN_RETRY_S = 1.0  # wall seconds: one component's twin is asked at most this often
AUDIT_TIMEOUT_S = 5.0  # wall seconds for the end-of-run twin sweep and physics' poses together
MIN_POSES_TIMEOUT_S = 1.0  # physics' poses get at least this long, whatever the sweep took


class RunMonitor:
    """Subscribes on ``session`` at construction; :meth:`drain` applies what arrived since the last call."""

    def __init__(
        self,
        manifest: Manifest,
        session: zenoh.Session,
        tolerances: Tolerances = AGENT_TOLERANCES,
        robot_types: Mapping[str, str] | None = None,
    ) -> None:
        """``robot_types``: robot id → type of the fleet the run started, so a robot's type is known even
        when the run ends before physics' site info arrives (that info still wins when it does)."""
        site = manifest.site
        self.manifest, self.tolerances = manifest, tolerances
        self.invalid = InvalidPayloads()
        self.collector = ReportCollector(manifest)
        self.collector.robot_type_of.update(robot_types or {})
        # the plan the planner builds by (its order is the report's sequence column), asked, never read
        self.plan = Asked(session, PLANNER_PLAN, self.invalid, site=site)
        # physics' site info: the robots' types, by which the report groups its lanes and utilisation
        self.site_info = Asked(session, PHYSICS_INFO, self.invalid, site=site)
        self._site_info_taken = False
        self.trusted = TrustedStates(c.guid for c in manifest.components)
        self.sim_time_s = 0.0
        self.done = False
        self.changes = 0
        self.robots: dict[str, RobotStateMsg] = {}
        # the latest end of timed work any robot's state said, kept as each message comes: a robot's next
        # state (its pour's end asked of physics: no end said) can come in the same batch before the
        # watchdog looks, and the clock jumps to that end at once in the plan fidelity; the restaurant's
        # run ended 'stalled' 0.6 s of sim time before a 6,865 s pour ended, on a loaded machine
        self._busy_until_s = 0.0
        self.tasks: dict[str, TaskMsg] = {}
        self.progress: ProgressMsg | None = None
        self.preparing: PreparingMsg | None = None  # the planner's last word while it prepared its plan
        self.preparing_heard = 0  # how many such words: each one a sign of life while the clock waits
        self.names = {c.guid: c.name for c in manifest.components}
        self.total = len(manifest.components)
        self.as_built: AsBuiltAudit | None = None  # set by audit()
        self._session, self._site = session, site
        self._twin_keys = {c.guid: COMPONENT_TWIN.key(site=site, key=c.key) for c in manifest.components}
        self._component_keys = {c.guid: c.key for c in manifest.components}
        self._to_ask: set[str] = set()  # components whose twin must be asked (when due)
        self._asked_at: dict[str, float] = {}
        self._inbox = Inbox(self.invalid)
        inbox = self._inbox
        self._subscribers = [
            inbox.subscribe(session, COMPONENT_STATE, site=site, key="*"),
            inbox.subscribe(session, COMPONENT_POSE, site=site, key="*"),  # connections, temporary supports
            inbox.subscribe(session, ROBOT_STATE, site=site, robot_id="*"),
            inbox.subscribe(session, ROBOT_POSE, site=site, robot_id="*"),
            inbox.subscribe(session, PROGRESS, site=site),
            inbox.subscribe(session, TASK, site=site, task_id="*"),
            inbox.subscribe(session, CLOCK, site=site),
            inbox.subscribe(session, PLANNER_PREPARING, site=site),
        ]

    @property
    def states(self) -> dict[str, ComponentState]:
        """Each component's state as the run trusts it (terminal states only from twins)."""
        return self.trusted.states

    @property
    def constructed(self) -> int:
        """Components whose agents' twins said ``constructed``."""
        return sum(state == ComponentState.CONSTRUCTED for state in self.trusted.states.values())

    def awaited_sim_s(self) -> float:
        """The latest sim time a change is scheduled for: a robot's timed work (as any of its states said,
        not only the last one heard), a curing hold; 0: none."""
        times = [self._busy_until_s]
        if self.progress is not None:
            times += [hold.until_s for hold in self.progress.curing]
        return max(times, default=0.0)

    @property
    def misplacements(self) -> int:
        """Misplacements caught and retried, as the (twin-checked) timelines hold them."""
        return sum(timeline.retries for timeline in self.collector.components.values())

    def drain(self, wait_s: float = 0.0) -> None:
        """Apply every queued message and twin answer (waiting up to ``wait_s`` for the first); ask the
        twins that are due."""
        plan = self.plan.poll()
        if plan is not None and not self.collector.sequence_guids:
            self.collector.sequence_guids = list(plan.order)
        if not self._site_info_taken and (info := self.site_info.poll()) is not None:
            self.collector.add(info)
            self.tolerances = info.tolerances  # the tolerances in force: the audit judges with them
            self._site_info_taken = True
        for item in self._inbox.drain(first_timeout_s=wait_s):
            if isinstance(item, Received):
                self.apply(item.message)
            elif isinstance(item, Answer) and isinstance(item.message, TwinMsg):
                self.take_twin(item.key, item.message)
        self._ask_due_twins()

    def apply(self, message: BaseModel) -> None:
        """A message heard on the bus (a state message is judged first, see
        :mod:`bimbot.shared.trusted_states`). The run's sim time is the latest any message was said at: in
        plan fidelity the clock jumps, and its own messages may lag the work they let happen."""
        said_at_s = getattr(message, "sim_time_s", None)  # the clock as far as anyone on the bus has seen it
        if isinstance(said_at_s, float | int):
            self.sim_time_s = max(self.sim_time_s, float(said_at_s))
        if isinstance(message, ComponentStateMsg):
            self._component_state(message)
            return
        if isinstance(message, PreparingMsg):
            self.preparing, self.preparing_heard = message, self.preparing_heard + 1
            return
        self.collector.add(message)
        if isinstance(message, ProgressMsg):
            if self.progress is None or _progress_facts(message) != _progress_facts(self.progress):
                self.changes += 1
            self.progress = message
            self.done = self.done or message.done
        elif isinstance(message, RobotStateMsg):
            self.robots[message.robot_id] = message
            if message.busy_until_s is not None:
                self._busy_until_s = max(self._busy_until_s, message.busy_until_s)
        elif isinstance(message, TaskMsg):
            self.tasks[message.task_id] = message

    def take_twin(self, reply_key: str, twin: TwinMsg) -> None:
        """A twin as its agent answered on ``reply_key``: the component's state and timeline from it. A
        twin answered on another component's key is not taken."""
        if self._twin_keys.get(twin.guid) != reply_key or twin.key != self._component_keys.get(twin.guid):
            self.invalid.record(reply_key, f"a twin of {twin.guid!r} answered on another key")
            return
        if self.trusted.take_twin(twin):
            self.changes += 1
        self.collector.replace_from_twin(twin)

    def _component_state(self, message: ComponentStateMsg) -> None:
        judgement = self.trusted.judge(message)
        if judgement is Judgement.APPLY:
            if self.trusted.apply(message):
                self.changes += 1
            self.collector.add(message)
        elif judgement is Judgement.ASK:
            self._to_ask.add(message.guid)

    def _ask_due_twins(self) -> None:
        """One bounded, non-blocking question per component whose twin is wanted and was not asked within
        ``TWIN_RETRY_S``; the answers come back through the inbox."""
        if not self._to_ask:
            return
        now = time.monotonic()
        for guid in [g for g in self._to_ask if now - self._asked_at.get(g, -TWIN_RETRY_S) >= TWIN_RETRY_S]:
            self._to_ask.discard(guid)
            self._asked_at[guid] = now
            ask_twin(self._inbox, self._session, self._site, self._component_keys[guid])

    def confirm_twins(self, timeout_s: float) -> int:
        """Ask every twin at once (``components/*/twin``, blocking, at most ``timeout_s``) and take each
        answer: the last word on every component's state. Returns how many answered."""
        self.drain()  # what is queued first, so an older answer does not come after the sweep's
        answered: set[str] = set()
        for twin in ask_twins(self._session, self._site, timeout_s, self.invalid):
            self.take_twin(COMPONENT_TWIN.key(site=self._site, key=twin.key), twin)
            answered.add(twin.guid)
        answered &= set(self._twin_keys)
        if len(answered) < self.total:
            _log.warning(
                "%d of %d component twin(s) answered at the end; the others keep what the run heard",
                len(answered),
                self.total,
            )
        return len(answered)

    def audit(self, timeout_s: float = AUDIT_TIMEOUT_S) -> AsBuiltAudit:
        """The end-of-run audit, while the agents and physics still answer: every twin confirms its state
        (:meth:`confirm_twins`), then physics' poses of every component are compared with their BIM
        targets (:func:`bimbot.run.as_built.audit_as_built`). Bounded: about ``timeout_s`` wall seconds at
        most (physics gets at least ``MIN_POSES_TIMEOUT_S``). The result is kept for :meth:`report`."""
        asked_at_unix_s, deadline = time.time(), time.monotonic() + timeout_s
        self.confirm_twins(timeout_s)
        left_s = max(MIN_POSES_TIMEOUT_S, deadline - time.monotonic())
        poses = query_first(self._session, PHYSICS_POSES, self.invalid, timeout_s=left_s, site=self._site)
        if poses is None:
            _log.warning("physics did not answer physics/poses within %.1f s: no as-built audit", left_s)
        self.as_built = audit_as_built(
            self.manifest, poses, self.trusted.constructed(), self.tolerances, asked_at_unix_s=asked_at_unix_s
        )
        if self.as_built.errors:  # the run's summary lists them (once: not here as well)
            _log.info("as-built audit: %d error(s), listed in the summary", len(self.as_built.errors))
        return self.as_built

    def report(self, ending: RunEnding = UNFINISHED) -> dict[str, Any]:
        report = self.collector.report(ending)
        add_to_report(report, self.as_built, self.trusted.constructed())
        report["totals"]["state_messages_not_taken"] = self.trusted.rejected
        return report


def _progress_facts(progress: ProgressMsg) -> tuple:
    """What of a progress message is a change on the site (not its time stamp or its estimate)."""
    return (sorted(progress.counts.items()), progress.failed, progress.blocked, progress.done)
