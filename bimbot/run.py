"""``bimbot run OUT/``: build a converted model with every service as its own process on a loopback bus.

Starts ``bimbot bus`` on a free loopback port, then physics (lock-step, as fast as the robots can
follow, unless told otherwise), the component agents, the planner and N robots, and optionally the
observer (a rerun recording; with ``--live`` also the web viewer, kept up after the build); waits until
the planner reports every task settled, the site stalls (:mod:`bimbot.run_watchdog`), the time limit
passes, a service dies or a SIGTERM/SIGINT comes (:mod:`bimbot.run_loop`); stops every service (and their
children); prints a summary with a table of every component not built and why (:mod:`bimbot.run_table`)
and writes the construction report (``report.json`` and ``report.png``, from what the run heard on the
bus; also every ``--report-every-s`` while it runs). Live progress on the terminal
(:mod:`bimbot.run_progress`) unless ``-q``.

Everything a run writes goes to its own run folder (:mod:`bimbot.shared.run_folder`), by default a new
``BUILD/runs/<time>/`` linked as ``BUILD/runs/latest``: ``state/`` (the agents' journal), ``logs/`` (one
log per service), ``report/`` and ``observer/<site>.rrd``. The build itself is only read. The report is
written here only: the observer of a run records, the run reports.

Exit codes: 0 when every component is constructed; 1 otherwise (failed, blocked, stalled, timed out, a
service died); 130 after SIGINT and 143 after SIGTERM (128 + the signal, as shells do); 2 for unusable
input.
"""

from __future__ import annotations

import argparse
import logging
import re
import shutil
import signal
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from bimbot.as_built import as_built_line
from bimbot.fork_server import ForkServer
from bimbot.fork_server import enabled as fork_server_enabled
from bimbot.forked_check import apply_answer, check_request
from bimbot.run_args import (
    ObserverOptions,
    RunOptions,
    add_run_arguments,
    run_options,
)
from bimbot.run_commands import (
    monitor_bus_options,
    restart_arguments,
    router_commands,
    run_fleet,
    secure_bus,
    service_commands,
)
from bimbot.run_loop import LoopLimits, LoopResult, RunWatch, StopSignals
from bimbot.run_monitor import RunMonitor
from bimbot.run_preflight import check_run_input
from bimbot.run_progress import NoProgress, ProgressView, make_progress
from bimbot.run_restarts import Restart, Restarter, RestartPolicy
from bimbot.run_settings import run_settings
from bimbot.run_table import not_built_table
from bimbot.run_watchdog import StallWatchdog
from bimbot.services.observer.report import RunEnding
from bimbot.services.observer.report_fleet import lane_label, robot_order, utilisation_line
from bimbot.services.observer.report_methods import curing_line
from bimbot.services.observer.report_placements import caught_on_last_attempt, placement_line
from bimbot.services.observer.report_time import duration_text
from bimbot.services.observer.report_totals import busy_within_s, makespan_window
from bimbot.shared.bus import open_session
from bimbot.shared.errors import UserError
from bimbot.shared.manifest import Manifest, load_manifest
from bimbot.shared.messages import ComponentState
from bimbot.shared.run_folder import RunFolder, new_run_folder
from bimbot.supervisor import ServiceProcess, free_port, stop_all, wait_until

_log = logging.getLogger(__name__)

OBSERVER_CLOSE_TIMEOUT_S = 120.0  # closing and compacting the recording after the build
MAX_PLAN_WARNINGS_SHOWN = 5
_VIEWER_LINE = re.compile(r"web viewer: (http\S+)")
__all__ = [  # the options live in bimbot.run_args; benches and tests import them from here too
    "ObserverOptions",
    "RunOptions",
    "RunOutcome",
    "run_build",
]


@dataclass
class RunOutcome:
    exit_code: int
    constructed: int
    total: int
    failed: list[str] = field(default_factory=list)
    misplacements: int = 0
    sim_time_s: float = 0.0
    wall_time_s: float = 0.0
    report: dict[str, Any] = field(default_factory=dict)
    report_dir: Path | None = None
    run_dir: Path | None = None
    plan_warnings: list[str] = field(default_factory=list)  # what the planner found wrong with its input
    rrd_path: Path | None = None
    viewer_url: str | None = None
    summary_announced: bool = False  # the summary went out through ``announce`` already (--live)
    ending: RunEnding | None = None


def run_build(build: Path, options: RunOptions, announce: Callable[[str], None] = _log.info) -> RunOutcome:
    """Run every service on ``build`` until the planner is done or the run is ended (stall, time limit,
    signal, a dead service); always stops them all and writes the report (``report.json``,
    ``report.png``). ``announce`` gets the lines a user must see while it runs (the viewer's URL)."""
    started = time.perf_counter()
    # the services' code loads in the fork server while this process checks the input
    launcher = ForkServer() if fork_server_enabled() else None
    try:
        return _run_build(build, options, announce, launcher, started)
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
    _check_input(build, options, launcher)  # bad input: one line and exit 2, before any service starts
    manifest = load_manifest(build)
    run = RunFolder(options.run_dir) if options.run_dir is not None else new_run_folder(build)
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
        watch = f"bimbot watch --build {build} --connect {endpoint}"
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
                        "settings": run_settings(options),
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
                    progress = make_progress(monitor.names, quiet=False, say=announce)
                result = RunWatch(
                    planner=by_name["planner"],
                    everyone=[*routers, *services],
                    monitor=monitor,
                    limits=LoopLimits(timeout_s=options.timeout_s, report_every_s=options.report_every_s),
                    watchdog=StallWatchdog(options.stall_after_s, options.clock_stall_wall_s),
                    progress=progress,
                    stop=stop,
                    write_report=lambda ending: _write_report(report_of(ending), report_dir),
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
                outcome.report_dir, outcome.viewer_url, outcome.run_dir = report_dir, viewer_url, run.root
                plan = monitor.plan.answer
                outcome.plan_warnings = list(plan.warnings) if plan is not None else []
                outcome.report = report_of(result.ending)
                if outcome.exit_code == 0 and (outcome.report.get("as_built") or {}).get("errors"):
                    outcome.exit_code = 1  # the bus says built, physics has it elsewhere
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


def _check_input(build: Path, options: RunOptions, launcher: ForkServer | None) -> None:
    """:func:`check_run_input`, in a child of the fork server when there is one (:mod:`bimbot.forked_check`:
    this process then never imports the services' code), else here."""
    if launcher is not None:
        answer = launcher.check(check_request(build, options))
        if answer is not None and apply_answer(answer):
            return
    check_run_input(build, options)


def _write_report(report: dict[str, Any], report_dir: Path) -> None:
    """``report.json`` and ``report.png``; matplotlib is imported here, when the first report is due, not
    before the services start (a quarter of a second of every run's start)."""
    from bimbot.services.observer.report_png import write_report_files

    write_report_files(report, report_dir)


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


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("build", type=Path, help="a converted build folder (bimbot convert … -o BUILD)")
    add_run_arguments(parser)


def run(args: argparse.Namespace) -> int:
    if getattr(args, "check_stability", False):
        from bimbot.stability_cli import check_stability_command

        return check_stability_command(args, say)
    return finish(run_build(args.build, run_options(args), announce=say))


def say(line: str) -> None:
    """One line for the user on stdout, at once (the commands' output; logs go to stderr)."""
    sys.stdout.write(line + "\n")
    sys.stdout.flush()


def finish(outcome: RunOutcome) -> int:
    """Print the summary (unless it went out already) and return the exit code."""
    if not outcome.summary_announced:
        sys.stdout.write(summary_text(outcome))
    return outcome.exit_code


def _makespan(totals: dict[str, Any]) -> str:
    """``; makespan 1060.6 s``: the report's and report.png's figure (first release to last construction),
    which a user otherwise cannot tell from the run's sim time."""
    makespan = totals.get("makespan_s")
    if not makespan:
        return ""
    return f"; makespan {duration_text(makespan)} from the first release to the last construction"


def _busy(busy_s: float) -> str:
    """``77 s``; a machine's hours of formwork as ``9.0 h (32,403 s)``."""
    return f"{busy_s:.0f} s" if busy_s <= LONG_BUSY_S else duration_text(busy_s)


LONG_BUSY_S = 600.0


def _busy_outside(robot: dict[str, Any], window: tuple[float, float] | None) -> str:
    """`` (120 s of it after the last construction)``: the utilisation counts a robot's busy time within
    the makespan only; without this a robot busy 360 s beside a 268 s makespan read as a contradiction."""
    if window is None:
        return ""
    outside = robot["busy_s"] - busy_within_s(robot, window)
    if outside < 1.0:
        return ""
    return f" ({outside:.0f} s of it after the last construction, on tasks that built nothing more)"


def _caught(outcome: RunOutcome) -> str:
    """The placements the agents caught off target or unstable: the retried ones, and those on a component's
    last attempt (verdict ``failed``: not retried, the component fails with its reason)."""
    last = caught_on_last_attempt(outcome.report)
    if not last:
        return f"{outcome.misplacements} placement(s) caught off target or unstable and retried"
    return (
        f"{outcome.misplacements + last} placement(s) caught off target or unstable: {outcome.misplacements} "
        f"retried, {last} on its component's last attempt (failed, with its reason below)"
    )


def method_line(totals: dict) -> str | None:
    """``by method: cast_in_place 9/9, lifted 33/33, …`` (constructed/components), unless all are lifted."""
    by_method = totals.get("by_method") or {}
    if set(by_method) <= {"lifted"}:
        return None
    parts = [f"{method} {entry['constructed']}/{entry['components']}" for method, entry in by_method.items()]
    return "by method (constructed/components): " + ", ".join(parts)


def _seed(outcome: RunOutcome) -> str:
    settings = outcome.report.get("settings") or {}
    seed, fidelity = settings.get("seed"), settings.get("fidelity")
    said = [f"seed {seed}" if seed is not None else "", f"fidelity {fidelity}" if fidelity else ""]
    return f" ({', '.join(part for part in said if part)})" if any(said) else ""


def summary_text(outcome: RunOutcome) -> str:
    totals = outcome.report.get("totals", {})
    ending = outcome.ending
    early = []  # first: why the numbers below are what they are
    if ending is not None and ending.how != "done":
        early = [f"the run ended early: {ending.message}", *(f"  {detail}" for detail in ending.details)]
    lines = [
        *early,
        f"constructed {outcome.constructed}/{outcome.total} components in "
        f"{outcome.sim_time_s:.1f} s sim time ({outcome.wall_time_s:.1f} s wall{_makespan(totals)}), "
        f"{_caught(outcome)}, {totals.get('give_backs', 0)} give-back(s) by robots{_seed(outcome)}",
    ]
    methods = method_line(totals)
    if methods:
        lines.append(methods)
    curing = curing_line(outcome.report)
    if curing is not None:
        lines.append(curing)
    if totals.get("in_place"):
        lines.append(
            f"in place before the run (convert --in-place): {totals['in_place']} component(s), not built "
            "by the robots and not counted above"
        )
    if (outcome.report.get("settings") or {}).get("connections") is False:
        lines.append(
            "without connections (--no-connections): every component had to stand by itself, none was "
            "connected to what was built beside it"
        )
    if totals.get("max_position_error_mm") is not None:
        lines.append(
            "placement error of the constructed components at most "
            f"{totals['max_position_error_mm']:.2f} mm and {totals['max_angle_error_deg']:.2f}°"
        )
    placements = placement_line(outcome.report)
    if placements is not None:
        lines.append(placements)
    as_built = as_built_line(outcome.report)
    if as_built is not None:
        lines.append(as_built)
    robots = outcome.report.get("robots", {})
    window = makespan_window(outcome.report.get("components", []))
    for robot_id in robot_order(robots):
        robot = robots[robot_id]
        hand_offs = sum(1 for task in robot["tasks"] if task.get("kind") == "hand_off")
        lines.append(
            f"{lane_label(robot_id, robot)}: {len(robot['tasks'])} task(s)"
            + (f" ({hand_offs} hand-off(s))" if hand_offs else "")
            + f", {robot['distance_m']:.0f} m driven, busy {_busy(robot['busy_s'])}"
            + _busy_outside(robot, window)
        )
    utilisation = utilisation_line(outcome.report)
    if utilisation is not None:
        lines.append(utilisation)
    restarts = outcome.report.get("restarts", [])
    if restarts:
        lines.append(f"services that died during the run ({len(restarts)}):")
        lines += [f"  {Restart(**record).line()}" for record in restarts]
    if outcome.plan_warnings:
        lines.append(f"the planner warned about its plan ({len(outcome.plan_warnings)}):")
        lines += [f"  {warning}" for warning in outcome.plan_warnings[:MAX_PLAN_WARNINGS_SHOWN]]
        if len(outcome.plan_warnings) > MAX_PLAN_WARNINGS_SHOWN:
            lines.append(
                f"  … and {len(outcome.plan_warnings) - MAX_PLAN_WARNINGS_SHOWN} more (logs/planner.log)"
            )
    table = not_built_table(outcome.report)
    if table:
        lines.append(table.rstrip("\n"))
    if outcome.report_dir is not None:
        lines.append(f"report: {outcome.report_dir / 'report.json'} and {outcome.report_dir / 'report.png'}")
    if outcome.run_dir is not None:
        lines.append(f"logs: {RunFolder(outcome.run_dir).logs_dir}/ (one per service)")
    if outcome.rrd_path is not None:
        viewer = Path(sys.executable).with_name("rerun")  # the venv's own viewer, wherever the user stands
        lines.append(f"recording: {outcome.rrd_path} (open it with: {viewer} {outcome.rrd_path})")
    return "\n".join(lines) + "\n"
