"""A run: build a converted model with every service as its own process on a loopback bus.

Starts ``bimbot bus`` on a free loopback port, then physics (lock-step, as fast as the robots can
follow, unless told otherwise), the component agents, the planner and N robots, and optionally the
observer (a rerun recording; with ``--live`` also the web viewer, kept up after the build); waits until
the planner reports every task settled, the site stalls (:mod:`bimbot.run.watchdog`), the time limit
passes, a service dies or a SIGTERM/SIGINT comes (:mod:`bimbot.run.loop`); stops every service (and their
children); prints a summary with a table of every component not built and why (:mod:`bimbot.run.table`)
and writes the construction report (``report.json`` and ``report.png``, from what the run heard on the
bus; also every ``--report-every-s`` while it runs). Live progress on the terminal
(:mod:`bimbot.run.progress`) unless ``-q``.

Everything a run writes goes to its own run folder (:mod:`bimbot.shared.run_folder`), by default a new
``BUILD/runs/<time>/`` linked as ``BUILD/runs/latest``: ``state/`` (the agents' journal), ``logs/`` (one
log per service), ``report/`` and ``observer/<site>.rrd``. The build itself is only read. The report is
written here only: the observer of a run records, the run reports.

The command's entry, its summary and exit codes are :mod:`bimbot.run.main` and :mod:`bimbot.run.summary`.
"""

from __future__ import annotations

import logging
import re
import shutil
import signal
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

from bimbot.fork_server import ForkServer
from bimbot.fork_server import enabled as fork_server_enabled
from bimbot.forked_check import apply_answer, check_request
from bimbot.polling import wait_until
from bimbot.run.commands import (
    fleet_words,
    monitor_bus_options,
    restart_arguments,
    router_commands,
    run_fleet,
    secure_bus,
    service_commands,
    with_machines_for,
)
from bimbot.run.interim_reports import InterimReports
from bimbot.run.loop import LoopLimits, LoopResult, RunWatch, StopSignals
from bimbot.run.monitor import RunMonitor
from bimbot.run.options import ObserverOptions, RunOptions, default_timeout_s
from bimbot.run.preflight import check_build_and_run_folder, check_run_input
from bimbot.run.progress import NoProgress, ProgressView, make_progress
from bimbot.run.restarts import Restarter, RestartPolicy
from bimbot.run.settings import model_settings, run_settings
from bimbot.run.summary import RunOutcome, summary_text
from bimbot.run.watchdog import StallWatchdog
from bimbot.shared.bus import open_session
from bimbot.shared.errors import UserError
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import ComponentState
from bimbot.shared.report.collector import RunEnding
from bimbot.shared.run_folder import RunFolder, new_run_folder, remember_run_dir
from bimbot.supervisor import ServiceProcess, free_port, stop_all

_log = logging.getLogger(__name__)

OBSERVER_CLOSE_TIMEOUT_S = 120.0  # closing and compacting the recording after the build
_VIEWER_LINE = re.compile(r"web viewer: (http\S+)")


def run_build(build: Path, options: RunOptions, announce: Callable[[str], None] = _log.info) -> RunOutcome:
    """Run every service on ``build`` until the planner is done or the run is ended (stall, time limit,
    signal, a dead service); always stops them all and writes the report (``report.json``,
    ``report.png``). ``announce`` gets the lines a user must see while it runs (the viewer's URL)."""
    started = time.perf_counter()
    # the services' code loads in the fork server while this process checks the input
    launcher = ForkServer(say=announce) if fork_server_enabled() else None
    try:
        outcome = _run_build(build, options, announce, launcher, started)
        outcome.wall_time_s = time.perf_counter() - started  # up to the summary: report and stop included
        return outcome
    finally:
        if launcher is not None:
            launcher.close()


def _run_build(
    build: Path,
    options: RunOptions,
    announce: Callable[[str], None],
    launcher: ForkServer | None,
    started: float,
) -> RunOutcome:
    manifest = _check_input(build, options, launcher)  # bad input: one line and exit 2, before any service
    if options.timeout_s is None:
        options = replace(options, timeout_s=default_timeout_s(len(manifest.components)))
    options = with_machines_for(options, manifest)  # a pump comes for concrete, a block layer for masonry
    if options.off_site:
        announce(f"fleet: {fleet_words(options)}")
    run = RunFolder(options.run_dir) if options.run_dir is not None else new_run_folder(build)
    if options.run_dir is not None:
        remember_run_dir(build, options.run_dir)  # bimbot runs BUILD lists it
    log_dir = run.logs_dir
    if log_dir.exists():
        shutil.rmtree(log_dir)  # a --run-dir given again: this run's logs only
    report_dir = run.report_dir
    announce(f"run folder: {run.root}")
    if launcher is not None:
        log_dir.mkdir(parents=True, exist_ok=True)
        launcher.attach_log(log_dir / "fork-server.log")
    endpoints = [f"tcp/127.0.0.1:{free_port()}" for _ in range(options.routers)]
    endpoint = endpoints[0]
    services: list[ServiceProcess] = []
    restarter = Restarter(RestartPolicy(max_restarts=options.max_restarts))
    bus = secure_bus(run, options, manifest.site)  # None unless --secure; writes RUN/bus/
    with StopSignals().installed() as stop:
        routers = [
            ServiceProcess(name, args, log_dir, launcher=launcher)
            for name, args in router_commands(endpoints, bus)
        ]
        # the venv's own command, as the recording line names its viewer: a trial user without the venv
        # activated could not run a bare ``bimbot``
        watch = f"{Path(sys.executable).with_name('bimbot')} watch --build {build} --connect {endpoint}"
        if bus is not None:
            watch += f" --mode client --bus-config {bus.monitor}"
        if len(endpoints) > 1:
            watch += " --mode client"
        linked = "".join(f" and {other}, linked router to router" for other in endpoints[1:])
        announce(f"bus: {endpoint}{linked}{' (secured)' if bus else ''} (watch it: {watch})")
        progress: ProgressView = NoProgress()
        ended_how = "stopped: the run did not get to its end"
        try:
            with open_session(monitor_bus_options(endpoint, bus, options.routers)) as session:
                monitor = RunMonitor(manifest, session, robot_types=run_fleet(options).type_of())

                def report_of(ending: RunEnding) -> dict[str, Any]:
                    return {
                        **monitor.report(ending),
                        "settings": {**run_settings(options), "model": model_settings(manifest.source)},
                        "restarts": restarter.report(),
                    }

                for name, args in service_commands(
                    build, endpoint, options, run, bus, second_endpoint=endpoints[-1]
                ):
                    again = restart_arguments(args)
                    services.append(
                        ServiceProcess(name, args, log_dir, restart_args=again, launcher=launcher)
                    )
                by_name = {service.name: service for service in services}
                observer = by_name.get("observer")
                viewer_url = _announce_viewer(observer, options.observer, announce, stop)
                if options.show_progress:
                    types = run_fleet(options).type_of()
                    progress = make_progress(monitor.names, quiet=False, say=announce, types=types)
                building_from = time.perf_counter()
                _load_report_code_meanwhile()
                interim = _interim_reports(report_dir)
                result = RunWatch(
                    planner=by_name["planner"],
                    everyone=[*routers, *services],
                    monitor=monitor,
                    limits=LoopLimits(
                        timeout_s=options.timeout_s or 0.0, report_every_s=options.report_every_s
                    ),
                    watchdog=StallWatchdog(options.stall_after_s, options.clock_stall_wall_s),
                    progress=progress,
                    stop=stop,
                    write_report=lambda ending: interim.write(report_of(ending)),
                    restarter=restarter,
                ).run()
                ended_how = f"{result.ending.how}: {result.ending.message}"
                progress.close()
                if result.signum is not None:  # a user who pressed Ctrl-C sees at once that it was heard
                    name = signal.Signals(result.signum).name
                    announce(f"{name}: stopping the services and writing the report …")
                monitor.drain(wait_s=0.3)  # the last state messages
                monitor.audit()  # the twins confirm every state, physics' poses against the BIM targets
                outcome = _outcome(manifest, monitor, result, time.perf_counter() - started)
                outcome.startup_wall_s, outcome.build_wall_s = building_from - started, result.wall_s
                outcome.report_dir, outcome.viewer_url, outcome.run_dir = report_dir, viewer_url, run.root
                plan = monitor.plan.answer
                outcome.plan_warnings = list(plan.warnings) if plan is not None else []
                outcome.report = report_of(result.ending)
                if outcome.exit_code == 0 and (outcome.report.get("as_built") or {}).get("errors"):
                    outcome.exit_code = 1  # the bus says built, physics has it elsewhere
                if observer is None:  # audited and reported: nothing more is asked of the services
                    stop_all([*routers, *services])  # not stepping on while the chart is drawn
                _write_report(outcome.report, report_dir)
                if result.input_error is not None:
                    raise UserError(f"the planner rejected its input:\n{result.input_error}")
                if observer is not None and options.observer is not None:
                    outcome.rrd_path = run.recording_path(manifest.site)
                    if result.ending.how == "done":
                        if (
                            options.observer.keep_serving
                        ):  # the user sees the result while the viewer stays up
                            announce(summary_text(outcome).rstrip("\n"))
                            outcome.summary_announced = True
                        _let_observer_finish(observer, options.observer, announce, viewer_url, stop)
                return outcome
        finally:
            progress.close()
            stop_all([*routers, *services])
            run.mark_ended(ended_how)  # services started by hand later make a new run folder


def _check_input(build: Path, options: RunOptions, launcher: ForkServer | None) -> Manifest:
    """:func:`check_run_input`, in a child of the fork server when there is one (:mod:`bimbot.forked_check`:
    this process then never imports the services' code), else here; the build's manifest. The build and
    the run folder are checked here first, at once: the server answers once it has loaded that code."""
    manifest = check_build_and_run_folder(build, options).manifest
    if launcher is not None:
        answer = launcher.check(check_request(build, options))
        if answer is not None and apply_answer(answer):
            return manifest
    check_run_input(build, options)
    return manifest


def _load_report_code_meanwhile() -> None:
    """Import the report's plotting code (matplotlib: about a second of CPU) in the background while the
    build runs, when this process mostly waits, so that the report at the end does not wait for it. Not
    before the services start: they need the cores then."""

    def load() -> None:
        try:
            import bimbot.shared.report.png  # noqa: F401
        except Exception as error:  # the report imports it again, and says what fails then
            _log.debug("the report's code did not load in the background: %s", error)

    threading.Thread(target=load, name="report-imports", daemon=True).start()


def _write_report(report: dict[str, Any], report_dir: Path) -> None:
    """``report.json`` and ``report.png``; matplotlib is imported while the build runs
    (:func:`_load_report_code_meanwhile`), not before the services start (a quarter of a second of every
    run's start)."""
    from bimbot.shared.report.png import write_report_files

    write_report_files(report, report_dir)


def _interim_reports(report_dir: Path) -> InterimReports:
    """The reports written while the build goes on (:mod:`.interim_reports`); matplotlib is imported when
    the first is due, as for :func:`_write_report`."""

    def write_json(report: dict[str, Any], folder: Path) -> None:
        from bimbot.shared.report.png import write_report_json

        write_report_json(report, folder)

    def write_png(report: dict[str, Any], folder: Path) -> None:
        from bimbot.shared.report.png import write_report_png

        write_report_png(report, folder)

    return InterimReports(report_dir, write_json, write_png)


def _outcome(manifest: Manifest, monitor: RunMonitor, result: LoopResult, wall_s: float) -> RunOutcome:
    states = monitor.states
    failed = sorted(c.guid for c in manifest.components if states.get(c.guid) != ComponentState.CONSTRUCTED)
    if result.signum is not None:
        exit_code = 128 + result.signum  # 130 SIGINT, 143 SIGTERM, as a shell reports a killed command
    else:
        exit_code = 0 if result.planner_code == 0 and not failed else 1
    return RunOutcome(
        exit_code=exit_code,
        constructed=len(manifest.components) - len(failed),
        total=len(manifest.components),
        failed=failed,
        misplacements=monitor.misplacements,
        sim_time_s=monitor.sim_time_s,
        wall_time_s=wall_s,
        ending=result.ending,
    )


def _announce_viewer(
    observer: ServiceProcess | None,
    options: ObserverOptions | None,
    announce: Callable[[str], None],
    stop: StopSignals,
) -> str | None:
    """Wait for the observer's web viewer (when it serves one) and announce its URL."""
    if observer is None or options is None or not options.web:
        return None
    found: list[str] = []

    def served() -> bool:
        found.extend(match.group(1) for match in _VIEWER_LINE.finditer(observer.log()))
        return bool(found) or not observer.alive() or stop.event.is_set()

    wait_until(served, timeout_s=60.0, interval_s=0.1)
    if stop.event.is_set():
        return None
    if not found:
        tail = "\n".join(observer.log().splitlines()[-10:])
        raise UserError(f"the observer's web viewer did not start:\n{tail}")
    announce(f"web viewer: {found[0]}")
    return found[0]


def _let_observer_finish(
    observer: ServiceProcess,
    options: ObserverOptions,
    announce: Callable[[str], None],
    url: str | None,
    stop: StopSignals,
) -> None:
    """Without ``keep_serving``, give the observer the time to close (and compact) its recording; with it,
    keep the viewer up until Ctrl-C (or a TERM): from here on a signal only ends the wait, and the
    services are then stopped in order."""
    if not options.keep_serving:
        closed = wait_until(
            lambda: not observer.alive() or stop.event.is_set(),
            timeout_s=OBSERVER_CLOSE_TIMEOUT_S,
            interval_s=0.1,
        )
        if not closed:
            _log.warning("the observer did not finish its recording within %.0f s", OBSERVER_CLOSE_TIMEOUT_S)
        return
    announce(f"the build is done; the viewer stays up at {url} (Ctrl-C to stop)")
    while observer.alive() and not stop.event.wait(0.5):
        pass
    if stop.event.is_set():
        announce("stopping the viewer")
    else:
        _log.warning("the observer stopped on its own (exit %s); see %s", observer.wait(0), observer.log_path)
