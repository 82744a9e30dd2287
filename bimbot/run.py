"""``bimbot run OUT/``: build a converted model with every service as its own process on a loopback bus.

Starts ``bimbot bus`` on a free loopback port, then physics (lock-step, as fast as the robots can
follow, unless told otherwise), the component agents, the planner and N robots, and optionally the
observer (a rerun recording; with ``--live`` also the web viewer, kept up after the build); waits until
the planner reports every task settled; stops everything; prints a summary and writes the construction
report (``BUILD/report/report.json`` and ``report.png``, from what the run heard on the bus). Exit 0
when every component is constructed, 1 with the failed components named otherwise, 2 for unusable input.
Service logs go to ``OUT/logs/``.
"""

from __future__ import annotations

import argparse
import logging
import re
import shutil
import signal
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from bimbot.run_monitor import RunMonitor
from bimbot.services.observer.report_png import write_report_files
from bimbot.shared.bus import BusOptions, open_session
from bimbot.shared.errors import UserError
from bimbot.shared.manifest import Manifest, load_manifest
from bimbot.shared.messages import ComponentState
from bimbot.shared.sequence import planned_guids
from bimbot.supervisor import ServiceProcess, free_port, wait_until

_log = logging.getLogger(__name__)

DEFAULT_TIMEOUT_S = 900.0
# A run is a rehearsal at full speed: 120 Hz physics, a 5 Hz control loop (DWA, localisation, lock-step
# handshake) and a 180-beam laser (2°: a 0.2 m column at 5 m still takes a beam) build the bundled frame
# within tolerance in about half the wall time of the physics service's own defaults (240 Hz, 10 Hz, 360
# beams), measured with bench/build.py. All three are options.
FAST_PHYSICS_HZ = 120.0
FAST_CONTROL_PERIOD_S = 0.2
FAST_LASER_BEAMS = 180
ROBOT_START_TIMEOUT_S = 120.0  # physics holds its clock at 0 until the robots are up (at most this)
OBSERVER_CLOSE_TIMEOUT_S = 120.0  # closing and compacting the recording after the build
_VIEWER_LINE = re.compile(r"web viewer: (http\S+)")


@dataclass(frozen=True)
class ObserverOptions:
    """The observer in a run: always an ``.rrd``; the web viewer only when asked (``--live``)."""

    rrd_path: Path | None = None  # default BUILD/observer/<site>.rrd
    web: bool = False
    web_port: int = 9090
    grpc_port: int = 9876
    keep_serving: bool = False  # after the build, until interrupted (the viewer stays up)


@dataclass(frozen=True)
class RunOptions:
    robots: int = 1
    rtf: float = 0.0
    lock_step: bool = True
    inject_placement_error_m: float = 0.0
    observer: ObserverOptions | None = None
    planner_source: tuple[str, ...] = ()  # extra planner arguments: ("--derive",) etc.
    timeout_s: float = DEFAULT_TIMEOUT_S
    physics_hz: float = FAST_PHYSICS_HZ
    control_period_s: float = FAST_CONTROL_PERIOD_S
    laser_beams: int = FAST_LASER_BEAMS
    physics_extra: tuple[str, ...] = ()  # more physics arguments (benches, experiments)
    report_dir: Path | None = None  # default BUILD/report


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
    rrd_path: Path | None = None
    viewer_url: str | None = None
    summary_announced: bool = False  # the summary went out through ``announce`` already (--live)


def service_commands(build: Path, endpoint: str, options: RunOptions) -> list[tuple[str, list[str]]]:
    """(name, bimbot arguments) of every service, in start order."""
    bus = ["--connect", endpoint]
    physics = [
        "physics",
        "--build",
        str(build),
        "--robots",
        str(options.robots),
        "--rtf",
        repr(options.rtf),
        "--physics-hz",
        repr(options.physics_hz),
        "--control-period-s",
        repr(options.control_period_s),
        "--laser-beams",
        str(options.laser_beams),
    ]
    if options.lock_step:
        physics.append("--lock-step")
    physics += ["--wait-for-robots-s", repr(ROBOT_START_TIMEOUT_S)]
    commands = [
        ("physics", [*physics, *options.physics_extra, *bus]),
        ("agents", ["agents", "--build", str(build), "--fresh", *bus]),
        ("planner", ["planner", "--build", str(build), "--exit-when-done", *options.planner_source, *bus]),
    ]
    for number in range(1, options.robots + 1):
        robot = ["robot", "--build", str(build), "--id", f"r{number}", *bus]
        if options.inject_placement_error_m:
            robot += ["--inject-placement-error-m", repr(options.inject_placement_error_m)]
        commands.append((f"robot-r{number}", robot))
    if options.observer is not None:
        commands.append(("observer", [*observer_arguments(build, options.observer), *bus]))
    return commands


def observer_arguments(build: Path, observer: ObserverOptions) -> list[str]:
    arguments = ["observe", "--build", str(build)]
    if observer.rrd_path is not None:
        arguments += ["--rrd", str(observer.rrd_path)]
    if observer.web:
        arguments += ["--web-port", str(observer.web_port), "--grpc-port", str(observer.grpc_port)]
    else:
        arguments.append("--no-web")
    if not observer.keep_serving:
        arguments.append("--exit-when-done")
    return arguments


def run_build(build: Path, options: RunOptions, announce: Callable[[str], None] = _log.info) -> RunOutcome:
    """Run every service on ``build`` until the planner is done (or the timeout); always stops them.

    Writes the report (``report.json``, ``report.png``) whatever the outcome. ``announce`` gets the lines
    a user must see while it runs (the viewer's URL)."""
    manifest = load_manifest(build)
    log_dir = build / "logs"
    if log_dir.exists():
        shutil.rmtree(log_dir)
    report_dir = options.report_dir or build / "report"
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    started = time.perf_counter()
    router = ServiceProcess("bus", ["bus", "--listen", endpoint], log_dir)
    announce(f"bus: {endpoint} (watch it: bimbot watch --build {build} --connect {endpoint})")
    services: list[ServiceProcess] = []
    try:
        with open_session(BusOptions(connect=(endpoint,))) as session:
            monitor = RunMonitor(manifest, session, planned_guids(build))
            for name, args in service_commands(build, endpoint, options):
                services.append(ServiceProcess(name, args, log_dir))
            by_name = {service.name: service for service in services}
            observer = by_name.get("observer")
            viewer_url = _announce_viewer(observer, options.observer, announce)
            code = _wait_for_planner(by_name["planner"], [router, *services], monitor, options.timeout_s)
            monitor.drain(wait_s=0.3)  # the last state messages
            outcome = _outcome(manifest, monitor, code, time.perf_counter() - started)
            outcome.report_dir, outcome.viewer_url = report_dir, viewer_url
            outcome.report = monitor.report()
            write_report_files(outcome.report, report_dir)
            if observer is not None and options.observer is not None:
                outcome.rrd_path = options.observer.rrd_path or build / "observer" / f"{manifest.site}.rrd"
                if options.observer.keep_serving:  # the user sees the result while the viewer stays up
                    announce(summary_text(outcome).rstrip("\n"))
                    outcome.summary_announced = True
                _let_observer_finish(observer, options.observer, announce, viewer_url)
            if code is None:
                raise UserError(
                    f"the build did not finish within {options.timeout_s:.0f} s "
                    f"({outcome.constructed}/{outcome.total} constructed; logs in {log_dir})"
                )
            return outcome
    finally:
        for service in reversed(services):
            service.stop()
        router.stop()


def _outcome(manifest: Manifest, monitor: RunMonitor, planner_code: int | None, wall_s: float) -> RunOutcome:
    states = monitor.states
    failed = sorted(c.guid for c in manifest.components if states.get(c.guid) != ComponentState.CONSTRUCTED)
    return RunOutcome(
        exit_code=0 if planner_code == 0 and not failed else 1,
        constructed=len(manifest.components) - len(failed),
        total=len(manifest.components),
        failed=failed,
        misplacements=monitor.misplacements,
        sim_time_s=monitor.sim_time_s,
        wall_time_s=wall_s,
    )


def _announce_viewer(
    observer: ServiceProcess | None, options: ObserverOptions | None, announce: Callable[[str], None]
) -> str | None:
    """Wait for the observer's web viewer (when it serves one) and announce its URL."""
    if observer is None or options is None or not options.web:
        return None
    found: list[str] = []

    def served() -> bool:
        found.extend(match.group(1) for match in _VIEWER_LINE.finditer(observer.log()))
        return bool(found) or not observer.alive()

    wait_until(served, timeout_s=60.0, interval_s=0.1)
    if not found:
        tail = "\n".join(observer.log().splitlines()[-10:])
        raise UserError(f"the observer's web viewer did not start:\n{tail}")
    announce(f"web viewer: {found[0]}")
    return found[0]


def _let_observer_finish(
    observer: ServiceProcess, options: ObserverOptions, announce: Callable[[str], None], url: str | None
) -> None:
    """Without ``keep_serving``, give the observer the time to close (and compact) its recording; with it,
    keep the viewer up until Ctrl-C."""
    if not options.keep_serving:
        if not wait_until(lambda: not observer.alive(), timeout_s=OBSERVER_CLOSE_TIMEOUT_S, interval_s=0.1):
            _log.warning("the observer did not finish its recording within %.0f s", OBSERVER_CLOSE_TIMEOUT_S)
        return
    interrupted = threading.Event()
    # Ctrl-C (or a TERM) from here on only ends the wait: the services are then stopped in order, and a
    # second Ctrl-C during that cannot leave them running.
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda *_: interrupted.set())
    announce(f"the build is done; the viewer stays up at {url} (Ctrl-C to stop)")
    while observer.alive() and not interrupted.wait(0.5):
        pass
    if interrupted.is_set():
        announce("stopping the viewer")
    else:
        _log.warning("the observer stopped on its own (exit %s); see %s", observer.wait(0), observer.log_path)


def _wait_for_planner(
    planner: ServiceProcess, everyone: list[ServiceProcess], monitor: RunMonitor, timeout_s: float
) -> int | None:
    """The planner's exit code; None on timeout. A service that dies early ends the run with its log."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        monitor.drain(wait_s=0.1)
        if not planner.alive():
            return planner.wait(0)
        for service in everyone:
            if service is not planner and not service.alive() and service.name != "observer":
                tail = "\n".join(service.log().splitlines()[-15:])
                raise UserError(f"{service.name} stopped unexpectedly (exit {service.wait(0)}):\n{tail}")
    return None


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("build", type=Path, help="a converted build folder (bimbot convert … -o BUILD)")
    add_run_arguments(parser)


def add_run_arguments(parser: argparse.ArgumentParser) -> None:
    """The options ``bimbot run`` and ``bimbot demo`` share."""
    parser.add_argument("--robots", type=int, default=1, help="number of robots (default 1)")
    parser.add_argument("--rtf", type=float, default=0.0, help="real-time factor (0: as fast as possible)")
    parser.add_argument("--no-lock-step", action="store_true", help="do not wait for the robots each step")
    parser.add_argument(
        "--physics-hz",
        type=float,
        default=FAST_PHYSICS_HZ,
        help=f"physics steps per sim second ({FAST_PHYSICS_HZ:g})",
    )
    parser.add_argument(
        "--control-period-s",
        type=float,
        default=FAST_CONTROL_PERIOD_S,
        help=f"sim seconds per clock step, the robots' control period ({FAST_CONTROL_PERIOD_S:g})",
    )
    parser.add_argument(
        "--laser-beams", type=int, default=FAST_LASER_BEAMS, help=f"beams per laser scan ({FAST_LASER_BEAMS})"
    )
    parser.add_argument(
        "--inject-placement-error-m",
        type=float,
        default=0.0,
        metavar="M",
        help="robots place each component's first attempt this far off (the agents must catch it)",
    )
    source = parser.add_mutually_exclusive_group()
    source.add_argument("--derive", action="store_true", help="planner derives the sequence from supports")
    source.add_argument("--sequence", type=Path, default=None, help="planner uses this sequence XML")
    parser.add_argument("--timeout-s", type=float, default=DEFAULT_TIMEOUT_S, help="give up after this long")
    parser.add_argument(
        "--observe", action="store_true", help="also run the observer: a rerun recording (.rrd) of the build"
    )
    parser.add_argument(
        "--live",
        action="store_true",
        help="serve the rerun web viewer on 127.0.0.1 during the build and keep it up afterwards",
    )
    parser.add_argument("--web-port", type=int, default=9090, help="web viewer port with --live (9090)")
    parser.add_argument("--grpc-port", type=int, default=9876, help="viewer data port with --live (9876)")


def run_options(
    args: argparse.Namespace, rrd_path: Path | None = None, report_dir: Path | None = None
) -> RunOptions:
    """RunOptions from the shared arguments (a UserError for impossible values)."""
    if args.robots < 1:
        raise UserError("--robots must be at least 1")
    if args.physics_hz <= 0 or args.control_period_s <= 0 or args.laser_beams < 1:
        raise UserError("--physics-hz, --control-period-s and --laser-beams must be positive")
    planner_source: tuple[str, ...] = ()
    if args.derive:
        planner_source = ("--derive",)
    elif args.sequence is not None:
        planner_source = ("--sequence", str(args.sequence))
    observer = None
    if args.observe or args.live or rrd_path is not None:
        observer = ObserverOptions(
            rrd_path=rrd_path,
            web=args.live,
            web_port=args.web_port,
            grpc_port=args.grpc_port,
            keep_serving=args.live,
        )
    return RunOptions(
        robots=args.robots,
        rtf=args.rtf,
        lock_step=not args.no_lock_step,
        inject_placement_error_m=args.inject_placement_error_m,
        observer=observer,
        planner_source=planner_source,
        timeout_s=args.timeout_s,
        physics_hz=args.physics_hz,
        control_period_s=args.control_period_s,
        laser_beams=args.laser_beams,
        report_dir=report_dir,
    )


def run(args: argparse.Namespace) -> int:
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


def summary_text(outcome: RunOutcome) -> str:
    totals = outcome.report.get("totals", {})
    lines = [
        f"constructed {outcome.constructed}/{outcome.total} components in "
        f"{outcome.sim_time_s:.1f} s sim time ({outcome.wall_time_s:.1f} s wall), "
        f"{outcome.misplacements} misplacement(s) caught and retried"
    ]
    if totals.get("max_position_error_mm") is not None:
        lines.append(
            f"placement error at most {totals['max_position_error_mm']:.2f} mm and "
            f"{totals['max_angle_error_deg']:.2f}°"
        )
    for robot_id, robot in sorted(outcome.report.get("robots", {}).items()):
        lines.append(
            f"robot {robot_id}: {len(robot['tasks'])} task(s), {robot['distance_m']:.0f} m driven, "
            f"busy {robot['busy_s']:.0f} s"
        )
    if outcome.failed:
        lines.append(f"not constructed: {', '.join(outcome.failed)}")
    if outcome.report_dir is not None:
        lines.append(f"report: {outcome.report_dir / 'report.json'} and {outcome.report_dir / 'report.png'}")
    if outcome.rrd_path is not None:
        lines.append(f"recording: {outcome.rrd_path} (open it with: .venv/bin/rerun {outcome.rrd_path})")
    return "\n".join(lines) + "\n"
