"""The planner's Zenoh adapter: feeds :class:`~.scheduler.PlannerCore` from the bus and publishes its output.

Start-up, in order:

1. declare the liveliness token ``alive/planner/main`` and subscribe (callbacks only enqueue, see
   :class:`bimbot.shared.bus.Inbox`) to ``components/*/state``, ``components/*/pose``, ``robots/*/state``,
   ``clock`` and the liveliness of ``alive/robot/*`` and ``alive/component/*``;
2. wait until every component agent of the manifest is alive (``agents_timeout_s``; then the missing ones
   are logged and the planner goes on);
3. ask every agent for its digital twin (``get components/*/twin``) so components that are already further
   on (agents restarted with constructed components) are never released again; tasks of robots that are
   not alive are given back.

Then the loop: drain the inbox into the core, ``step`` it, publish events (``components/<key>/event``) and
tasks (``tasks/<task_id>``), and publish progress (``progress``) when it changes and at least every
``progress_interval_s``. When the core says nothing on site can happen before a known sim time (curing,
timed work in place; :mod:`.quiet`), the loop asks physics to skip its clock there (:mod:`.skip_requests`,
``skip_quiet``). With ``exit_when_done`` the planner returns when every task is done, failed or
blocked: 0 when everything was constructed, 1 (with a summary naming the failed and blocked components)
otherwise. It also returns (0) when ``stop`` is set.
"""

from __future__ import annotations

import json
import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import zenoh

from bimbot.shared.bus import (
    Answer,
    BusOptions,
    Inbox,
    LivelinessChange,
    Received,
    encode,
    open_session,
    query_first,
)
from bimbot.shared.clock_guard import ClockGuard
from bimbot.shared.identifiers import guid_to_key
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import (
    ALIVE_KEY,
    CLOCK,
    COMPONENT_EVENT_KEY,
    COMPONENT_POSE,
    COMPONENT_STATE,
    COMPONENT_TWIN,
    PHYSICS_INFO,
    PLANNER_PLAN,
    PLANNER_PREPARING_KEY,
    PROGRESS_KEY,
    ROBOT_STATE,
    TASK_KEY,
    ClockMsg,
    ComponentEventMsg,
    ComponentPoseMsg,
    ComponentStateMsg,
    PlannedSequenceMsg,
    ProgressMsg,
    RobotStateMsg,
    SiteInfoMsg,
    TaskMsg,
    TwinMsg,
    key,
)
from bimbot.shared.reasons import Reason
from bimbot.shared.service_runner import BuildInput
from bimbot.shared.state_table import TERMINAL
from bimbot.shared.twin_query import ask_twins

from .capability import site_robots
from .feasibility import infeasible
from .preparing import PreparationReporter, Report, no_report
from .scheduler import Outgoing, PlannerCore, PlannerLimits
from .skip_requests import SkipAnswer, Skipper, bus_sender
from .sources import Plan, PlanSource, load_plan
from .stepped import SteppedLoop, stepped_skipper

if TYPE_CHECKING:
    from .access_hold import AccessGuard

_log = logging.getLogger(__name__)

TWIN_REFRESH_S = 10.0  # wall seconds between asking the twins of components in flight (missed messages)
TWIN_ASK_TIMEOUT_S = 5.0  # wall seconds for a twin to confirm a constructed/failed/blocked claim


@dataclass(frozen=True)
class PlannerOptions:
    exit_when_done: bool = False
    agents_timeout_s: float = 30.0  # wall seconds to wait for every component agent's liveliness
    resend_s: float = 2.0  # wall seconds before an unobserved event or assignment is sent again
    progress_interval_s: float = 1.0  # progress is published at least this often (wall seconds)
    twin_timeout_s: float = 5.0  # wall seconds for the start-up twin query
    poll_s: float = 0.05  # longest wait for bus input per loop turn
    # wall seconds to wait for physics' site info (robot types, site): loading a large model on a busy machine
    # takes physics minutes, and without it the planner cannot tell what each robot can build
    site_info_timeout_s: float = 300.0
    strict: bool = False  # a sequence step that cuts off later work is an error, not a warning
    skip_quiet: bool = True  # ask physics to skip its clock over a quiet site (curing, timed work)
    # a lock-step participant (physics waits for its answer to each step: bimbot run's --step-with):
    # decisions at clock steps from the inputs of a defined step (:mod:`.stepped`)
    stepped: bool = False
    limits: PlannerLimits = field(default_factory=PlannerLimits)


def outgoing_key(site: str, message: Outgoing | ProgressMsg) -> str:
    """Where a planner message is published."""
    if isinstance(message, ComponentEventMsg):
        return key(COMPONENT_EVENT_KEY, site=site, key=guid_to_key(message.guid))
    if isinstance(message, TaskMsg):
        return key(TASK_KEY, site=site, task_id=message.task_id)
    return key(PROGRESS_KEY, site=site)


def main(
    bus: BusOptions, build: BuildInput, options: PlannerOptions, source: PlanSource, stop: threading.Event
) -> int:
    """Run the planner on the bus until done (``exit_when_done``) or ``stop``; the exit code."""
    manifest = build.manifest
    plan = load_plan(manifest, build.dir, source)
    site = manifest.site
    inbox = Inbox(in_order=True)
    with open_session(bus) as session:
        info = query_first(
            session, PHYSICS_INFO, inbox.invalid, timeout_s=options.site_info_timeout_s, stop=stop, site=site
        )
        report = PreparationReporter(
            lambda message: session.put(key(PLANNER_PREPARING_KEY, site=site), encode(message))
        )
        plan, cannot = _checked_plan(plan, manifest, info, options.strict, report)
        core = PlannerCore(
            manifest,
            plan,
            resend_s=options.resend_s,
            limits=options.limits,
            robots=site_robots(info) if info is not None else None,
            slots=dict(info.layout.slots) if info is not None else None,
            access=_access_guard(manifest, info, plan, report),
        )
        plan_queryable = _serve_plan(session, site, plan)
        stepped = options.stepped and info is not None and info.lock_step
        subscribers = [
            inbox.subscribe(session, COMPONENT_STATE, site=site, key="*"),
            inbox.subscribe(session, COMPONENT_POSE, site=site, key="*"),
            inbox.subscribe(session, ROBOT_STATE, site=site, robot_id="*"),
            inbox.subscribe(session, CLOCK, site=site),
            inbox.subscribe_liveliness(session, key(ALIVE_KEY, site=site, kind="robot", id="*")),
            inbox.subscribe_liveliness(session, key(ALIVE_KEY, site=site, kind="component", id="*")),
        ]
        alive = key(ALIVE_KEY, site=site, kind="planner", id="main")
        # stepped: alive once synced (physics holds its clock at 0 until then: the start-up is not sim time)
        token = None if stepped else session.liveliness().declare_token(alive)
        feed = _Feeder(
            core,
            lambda guid: inbox.ask(
                session, COMPONENT_TWIN, timeout_s=TWIN_ASK_TIMEOUT_S, site=site, key=guid_to_key(guid)
            ),
        )
        _log.info("planner for %s: %d task(s) from %s", site, len(plan.order), plan.source)
        report("waiting for the component agents", len(feed.alive_components), len(manifest.components))
        _wait_for_agents(inbox, feed, manifest, options.agents_timeout_s, stop)
        _sync_twins(session, site, core, inbox, options.twin_timeout_s)
        core.finish_sync()
        core.fail_at_start(cannot)
        if stepped:
            token = session.liveliness().declare_token(alive)
            code = _run_stepped(session, site, core, inbox, feed, options, stop)
        else:
            skipper = Skipper(bus_sender(session, site, inbox)) if options.skip_quiet else None
            code = _Loop(session, site, core, inbox, feed, skipper=skipper).run(options, stop)
        assert token is not None
        token.undeclare()
        plan_queryable.undeclare()
        for subscriber in subscribers:
            subscriber.undeclare()
    return code


def _run_stepped(  # noqa: PLR0917 - the planner's parts, named at the single call
    session: zenoh.Session,
    site: str,
    core: PlannerCore,
    inbox: Inbox,
    feed: _Feeder,
    options: PlannerOptions,
    stop: threading.Event,
) -> int:
    """The lock-step loop (:mod:`.stepped`); the exit code as :class:`_Loop`'s."""
    sender = bus_sender(session, site, inbox)
    loop = SteppedLoop(
        session,
        site,
        core,
        inbox,
        feed.ask_twin,
        lambda message: session.put(outgoing_key(site, message), encode(message)),
        skipper=stepped_skipper(sender) if options.skip_quiet else None,
        robot_liveliness=core.robot_liveliness,
    )
    _log.info("planner in lock-step: decisions at clock steps, from the inputs of step k - 2")
    progress = loop.run(stop, options.poll_s, options.exit_when_done)
    if progress is not None:
        return _summary(progress)
    _log.info("planner stopped (%.0f %% constructed)", core.progress().percent_constructed)
    return 0


def _checked_plan(
    plan: Plan, manifest: Manifest, info: SiteInfoMsg | None, strict: bool, report: Report = no_report
) -> tuple[Plan, dict[str, Reason]]:
    """The plan after the access check, and the components that cannot be built (GUID → reason): too
    heavy or out of reach for every robot type on site, or never accessible at their turn."""
    if info is None:
        _log.warning(
            "physics did not answer with the site info: robot feasibility and site access not checked"
        )
        return plan, {}
    from .access_plan import access_plan  # scipy.ndimage: not for `bimbot run`'s argument check

    outcome = access_plan(plan, manifest, info, adjust=plan.derived, strict=strict, report=report)
    cannot = {
        **outcome.unreachable,
        **infeasible(manifest.components, site_robots(info), info.layout.slots),
    }
    if cannot:
        _log.warning(
            "%d component(s) cannot be built with the robots on site; failed before the build", len(cannot)
        )
    checked = replace(outcome.plan, warnings=(*outcome.plan.warnings, *outcome.warnings))
    return checked, cannot


def _access_guard(
    manifest: Manifest, info: SiteInfoMsg | None, plan: Plan, report: Report = no_report
) -> AccessGuard | None:
    """What holds a ready task that would cut off work still to be built (needs the site: physics')."""
    if info is None:
        return None
    from .access_hold import AccessGuard  # scipy.ndimage: not for `bimbot run`'s argument check

    def grid(done: int, total: int) -> None:
        report("access guard: the site grid at 0.1 m", done, total)

    return AccessGuard.for_site(manifest, info, plan.predecessors, grid)


def planned_sequence(plan: Plan) -> PlannedSequenceMsg:
    """What the planner answers on ``planner/plan``: the plan it builds by, with its warnings."""
    return PlannedSequenceMsg(
        source=plan.source,
        order=list(plan.order),
        predecessors={guid: sorted(plan.predecessors.get(guid, ())) for guid in plan.order},
        warnings=list(plan.warnings),
    )


def _serve_plan(session: zenoh.Session, site: str, plan: Plan) -> zenoh.Queryable:
    """Answer ``planner/plan`` from Zenoh's thread: the answer never changes, so no state is touched."""
    selector = PLANNER_PLAN.key(site=site)
    answer = encode(planned_sequence(plan))
    return session.declare_queryable(selector, lambda query: query.reply(selector, answer))


@dataclass
class _Asking:
    claim: tuple[object, ...]  # (state, previous, attempt, sim time) of the state message
    asked_wall_s: float
    repeated: bool = False  # the same claim arrived again before the answer


class _Feeder:
    """Hands inbox items to the core; keeps the set of alive component keys.

    A state message is a hint, the twin is the truth: a claim that a component is constructed, failed or
    blocked (what releases its dependents or ends the build) is never taken from the message, which
    anyone on an open bus can put; the planner asks that component's twin and takes its answer."""

    def __init__(self, core: PlannerCore, ask_twin: Callable[[str], None]) -> None:
        self.core = core
        self.ask_twin = ask_twin
        self.alive_components: set[str] = set()
        self.clock_guard = ClockGuard("planner clock")
        self._asking: dict[str, _Asking] = {}  # GUID → the claim asked about, not answered yet

    def _claimed(self, message: ComponentStateMsg) -> None:
        """A constructed/failed/blocked claim: ask the component's twin (once per claim in flight)."""
        claim = (message.state, message.previous, message.attempt, message.sim_time_s)
        asking = self._asking.get(message.guid)
        in_flight = asking is not None and time.monotonic() - asking.asked_wall_s <= TWIN_ASK_TIMEOUT_S
        if asking is not None and in_flight and asking.claim == claim:
            asking.repeated = True
            return
        self._ask(message.guid, claim)

    def _ask(self, guid: str, claim: tuple[object, ...]) -> None:
        self._asking[guid] = _Asking(claim, time.monotonic())
        self.ask_twin(guid)

    def __call__(self, item: object) -> None:
        core = self.core
        match item:
            case Received(message=ComponentStateMsg() as message) if message.state in TERMINAL:
                self._claimed(message)
            case Answer(message=TwinMsg() as twin):
                asking = self._asking.pop(twin.guid, None)
                if asking is not None and asking.repeated and twin.state != asking.claim[0]:
                    self._ask(twin.guid, asking.claim)  # the claim came again while its twin was asked
                core.observe_twin(twin)
            case Received(message=ComponentStateMsg() as message):
                core.observe_component_state(message)
            case Received(message=ComponentPoseMsg() as message):
                core.observe_component_pose(message)
            case Received(message=RobotStateMsg() as message):
                core.observe_robot_state(message)
            case Received(message=ClockMsg() as message):
                if self.clock_guard.check(message, time.monotonic()).accepted:
                    core.observe_clock(message.sim_time_s)
            case LivelinessChange() if item.kind == "robot":
                core.robot_liveliness(item.id, item.alive)
            case LivelinessChange():
                (self.alive_components.add if item.alive else self.alive_components.discard)(item.id)


def _wait_for_agents(
    inbox: Inbox, feed: _Feeder, manifest: Manifest, timeout_s: float, stop: threading.Event
) -> None:
    wanted = {component.key for component in manifest.components}
    deadline = time.monotonic() + timeout_s
    while not stop.is_set() and not wanted <= feed.alive_components:
        left = deadline - time.monotonic()
        if left <= 0:
            missing = sorted(
                component.guid
                for component in manifest.components
                if component.key not in feed.alive_components
            )
            shown = ", ".join(missing[:10]) + (" …" if len(missing) > 10 else "")
            _log.warning(
                "%d of %d component agent(s) not alive after %.0f s (going on): %s",
                len(missing),
                len(wanted),
                timeout_s,
                shown,
            )
            return
        for item in inbox.drain(first_timeout_s=min(left, 0.1)):
            feed(item)
    _log.info("%d of %d component agent(s) alive", len(wanted & feed.alive_components), len(wanted))


def _sync_twins(session: zenoh.Session, site: str, core: PlannerCore, inbox: Inbox, timeout_s: float) -> None:
    """Apply every agent's twin record: what is already released or constructed is not released again."""
    count = 0
    for twin in ask_twins(session, site, timeout_s, inbox.invalid):
        core.observe_twin(twin)
        count += 1
    _log.info("synced %d digital twin(s)", count)


class _Loop:
    """The planner's main loop: inbox → core → bus."""

    def __init__(
        self,
        session: zenoh.Session,
        site: str,
        core: PlannerCore,
        inbox: Inbox,
        feed: _Feeder,
        *,
        skipper: Skipper | None = None,
    ) -> None:
        self.session, self.site, self.core, self.inbox, self.feed = session, site, core, inbox, feed
        self.skipper = skipper

    def run(self, options: PlannerOptions, stop: threading.Event) -> int:
        last_progress: str | None = None
        last_progress_wall = 0.0
        progress_revision = -1
        next_refresh_s = time.monotonic() + TWIN_REFRESH_S
        while not stop.is_set():
            for item in self.inbox.drain(first_timeout_s=options.poll_s):
                if isinstance(item, SkipAnswer):
                    if self.skipper is not None:
                        self.skipper.answered(item)
                else:
                    self.feed(item)
            if time.monotonic() >= next_refresh_s:  # recover a state message that went missing
                next_refresh_s = time.monotonic() + TWIN_REFRESH_S
                for guid in self.core.in_flight():
                    self.feed.ask_twin(guid)
            for message in self.core.step(time.time()):
                self.session.put(outgoing_key(self.site, message), encode(message))
            if self.skipper is not None:
                self.skipper.tick(self.core.quiet_until, time.monotonic())
            now = time.monotonic()
            due = now - last_progress_wall >= options.progress_interval_s
            if self.core.revision == progress_revision and not due:
                continue  # nothing changed since the last progress (a pass over every component)
            progress_revision = self.core.revision
            progress = self.core.progress()
            signature = _progress_signature(progress)
            if signature != last_progress or due:
                self.session.put(outgoing_key(self.site, progress), encode(progress))
                last_progress, last_progress_wall = signature, now
            if progress.done and options.exit_when_done:
                return _summary(progress)
        _log.info("planner stopped (%.0f %% constructed)", self.core.progress().percent_constructed)
        return 0


def _progress_signature(progress: ProgressMsg) -> str:
    """What makes a progress message new (not the sim time, which moves all the time)."""
    return json.dumps([progress.counts, progress.failed, progress.blocked, progress.done], sort_keys=True)


def _summary(progress: ProgressMsg) -> int:
    if not progress.failed and not progress.blocked:
        _log.info("construction done: all %d component(s) constructed", progress.total)
        return 0
    _log.error(
        "construction finished with %d failed and %d blocked component(s): failed %s; blocked %s",
        len(progress.failed),
        len(progress.blocked),
        ", ".join(progress.failed) or "none",
        ", ".join(progress.blocked) or "none",
    )
    return 1
