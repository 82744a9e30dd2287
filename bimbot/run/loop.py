"""The waiting loop of ``bimbot run``: until the planner is done, or something ends the run first.

A run ends in one of these ways, each a :class:`~bimbot.shared.report.collector.RunEnding` that the
report gives every component left unbuilt without a reason of its own:

============  =====================================================================  ==================
``done``      the planner exited: every task settled (constructed, failed, blocked)  —
``stalled``   the stall watchdog: nothing changed for ``--stall-after-s`` sim s       ``stalled``
``interrupted``  SIGTERM or SIGINT                                                   ``interrupted``
``timeout``   ``--timeout-s`` wall seconds passed                                     ``interrupted``
``service_stopped``  a service died, or the planner crashed (its log tail: details)  ``interrupted``
============  =====================================================================  ==================

Signals are caught by :class:`StopSignals` (the handlers only set a flag; the loop acts on it), so a
Ctrl-C or a ``kill`` still stops every service and writes the report. While the run goes on, the report
is written every ``report_every_s`` wall seconds, so even a SIGKILL of ``bimbot run`` leaves a recent one.
"""

from __future__ import annotations

import logging
import signal
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass

from bimbot.cli import BUG_MARK
from bimbot.run.monitor import RunMonitor
from bimbot.run.progress import ProgressView
from bimbot.run.restarts import Restarter
from bimbot.run.watchdog import StallWatchdog, stall_details
from bimbot.shared.reasons import ReasonCode
from bimbot.shared.report.collector import RunEnding
from bimbot.shared.report.durations import duration_text
from bimbot.shared.signal_event import stop_handlers
from bimbot.supervisor import ServiceProcess

_log = logging.getLogger(__name__)

LOG_TAIL_LINES = 15
PLANNER_INPUT_ERROR = 2  # the planner's exit code for an unusable sequence (a UserError)
PLANNER_VERDICTS = (0, 1)  # --exit-when-done: everything constructed / something failed or blocked
PYTHON_TRACEBACK = "Traceback (most recent call last):"  # an exception nobody caught (bimbot.cli logs one)


class StopSignals:
    """SIGTERM/SIGINT set a flag instead of killing the run; :meth:`installed` restores the old handlers."""

    def __init__(self) -> None:
        self.signum: int | None = None
        self.event = threading.Event()

    def _note(self, signum: int) -> None:
        if self.signum is None:
            self.signum = signum

    @contextmanager
    def installed(self) -> Iterator[StopSignals]:
        with stop_handlers(self.event, on_signal=self._note):  # never the event's lock in a handler
            yield self


@dataclass
class LoopResult:
    ending: RunEnding
    planner_code: int | None = None  # the planner's exit code when it exited
    signum: int | None = None  # the signal that stopped the run
    input_error: str | None = None  # the planner rejected its input (exit 2): this is its log tail
    wall_s: float = 0.0  # from the loop's start (the services just started) to its end: the build's wall


@dataclass(frozen=True)
class LoopLimits:
    timeout_s: float
    report_every_s: float  # 0: only at the end


@dataclass
class RunWatch:
    """Everything the loop watches; :meth:`run` drains the monitor until one of the endings."""

    planner: ServiceProcess
    everyone: list[ServiceProcess]
    monitor: RunMonitor
    limits: LoopLimits
    watchdog: StallWatchdog
    progress: ProgressView
    stop: StopSignals
    write_report: Callable[[RunEnding], None]
    restarter: Restarter | None = None  # None: a dead service ends the run

    def run(self) -> LoopResult:
        monitor = self.monitor
        started = time.monotonic()
        next_report_s = started + self.limits.report_every_s
        while True:
            monitor.drain(wait_s=0.1)
            now = time.monotonic()
            planner = monitor.progress
            self.watchdog.observe(
                monitor.changes,
                monitor.sim_time_s,
                now,
                monitor.awaited_sim_s(),
                monitor.preparing_heard,
                planner.sim_time_s if planner is not None else None,
            )
            self.progress.update(
                monitor.constructed,
                monitor.total,
                monitor.sim_time_s,
                monitor.robots,
                now - started,
                not_built=len(planner.failed) + len(planner.blocked) if planner is not None else 0,
                preparing=monitor.preparing if planner is None else None,
            )
            result = self._ended(now - started)
            if result is not None:
                result.wall_s = now - started
                return result
            if self.limits.report_every_s > 0 and now >= next_report_s:
                next_report_s = now + self.limits.report_every_s
                self.write_report(
                    RunEnding("running", ReasonCode.INTERRUPTED, _so_far(monitor, now - started))
                )

    def _ended(self, wall_s: float) -> LoopResult | None:
        monitor, planner = self.monitor, self.planner
        built = f"{monitor.constructed}/{monitor.total} constructed"
        sim = duration_text(monitor.sim_time_s)
        at = f"after {wall_s:.0f} s wall of building, at sim {sim}, with {built}"
        if self.stop.signum is not None:
            name = signal.Signals(self.stop.signum).name
            ending = RunEnding("interrupted", ReasonCode.INTERRUPTED, f"stopped by {name} {at}")
            return LoopResult(ending, signum=self.stop.signum)
        if not planner.alive():
            code = planner.wait(0)
            if code == PLANNER_INPUT_ERROR:
                message = f"the planner rejected its input {at}"
                ending = RunEnding("service_stopped", ReasonCode.INTERRUPTED, message)
                return LoopResult(ending, planner_code=code, input_error=_tail(planner))
            if code not in PLANNER_VERDICTS or _crashed(planner):  # a bug, not a verdict: show its log
                if self._restarting(planner, code, wall_s):
                    return None
                message = (
                    f"the planner stopped unexpectedly (exit {code}){self._after_restarts(planner)} {at}"
                )
                return LoopResult(
                    RunEnding("service_stopped", ReasonCode.INTERRUPTED, message, _tail_details(planner)),
                    planner_code=code,
                )
            # the count is the audit's, made after this (the twins confirm every state): not said here
            outcome = (
                "every component constructed"
                if code == 0
                else "every component constructed, failed or blocked"
            )
            when = f"after {wall_s:.0f} s wall of building, at sim {duration_text(monitor.sim_time_s)}"
            ending = RunEnding(
                "done", None, f"the planner finished the build ({outcome}, exit {code}) {when}"
            )
            return LoopResult(ending, planner_code=code)
        for service in self.everyone:
            if service is not planner and service.name != "observer" and not service.alive():
                code = service.wait(0)
                if self._restarting(service, code, wall_s):
                    continue
                message = (
                    f"{service.name} stopped unexpectedly (exit {code}){self._after_restarts(service)} {at}"
                )
                return LoopResult(
                    RunEnding("service_stopped", ReasonCode.INTERRUPTED, message, _tail_details(service))
                )
        verdict = self.watchdog.verdict()
        if verdict is not None:
            message = f"the site stalled: {verdict}; the run ended with {built}"
            return LoopResult(RunEnding("stalled", ReasonCode.STALLED, message, self._details()))
        if wall_s >= self.limits.timeout_s:
            message = f"the run reached its --timeout-s limit of {self.limits.timeout_s:g} s wall {at}"
            return LoopResult(RunEnding("timeout", ReasonCode.INTERRUPTED, message, self._details()))
        return None

    def _restarting(self, service: ServiceProcess, code: int | None, wall_s: float) -> bool:
        """Whether the dead ``service`` is (or will be) started again (:mod:`bimbot.run.restarts`)."""
        if self.restarter is None:
            return False
        return self.restarter.keep_going(service, code, wall_s, self.monitor.sim_time_s)

    def _after_restarts(self, service: ServiceProcess) -> str:
        count = self.restarter.restarts(service.name) if self.restarter is not None else 0
        return f" after {count} restart(s)" if count else ""

    def _details(self) -> tuple[str, ...]:
        monitor = self.monitor
        robots = [s.name.removeprefix("robot-") for s in self.everyone if s.name.startswith("robot-")]
        details = stall_details(
            monitor.robots,
            monitor.tasks,
            monitor.states,
            monitor.names,
            expected=robots,
            planner_ready=monitor.progress is not None,
            preparing=monitor.preparing,
        )
        return tuple(details)


def _so_far(monitor: RunMonitor, wall_s: float) -> str:
    return (
        f"the run was still going when this report was written ({wall_s:.0f} s wall, "
        f"sim {monitor.sim_time_s:.1f} s, {monitor.constructed}/{monitor.total} constructed)"
    )


def _tail(service: ServiceProcess) -> str:
    """The last :data:`LOG_TAIL_LINES` lines of the service's log (a traceback ends there)."""
    return "\n".join(service.log().splitlines()[-LOG_TAIL_LINES:])


def _tail_details(service: ServiceProcess) -> tuple[str, ...]:
    """The log tail as the ending's details, each line naming the log it comes from."""
    return tuple(f"{service.name}.log: {line}" for line in _tail(service).splitlines())


def _crashed(service: ServiceProcess) -> bool:
    """Whether the service's log holds a traceback (an exit code of 1 is also the planner's verdict)."""
    log = service.log()
    return BUG_MARK in log or PYTHON_TRACEBACK in log
