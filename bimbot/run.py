"""``bimbot run OUT/``: build a converted model with every service as its own process on a loopback bus.

Starts ``bimbot bus`` on a free loopback port, then physics (lock-step, as fast as the robots can
follow, unless told otherwise), the component agents, the planner and N robots, and optionally the
observer; waits until the planner reports every task settled; stops everything; prints a summary and
writes the construction report. Exit 0 when every component is constructed, 1 with the failed components
named otherwise, 2 for unusable input. Service logs go to ``OUT/logs/``.
"""

from __future__ import annotations

import argparse
import logging
import shutil
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import zenoh

from bimbot.supervisor import ServiceProcess, free_port
from shared.bus import BusOptions, InvalidPayloads, decode, open_session
from shared.errors import UserError
from shared.manifest import Manifest, read_manifest
from shared.messages import (
    CLOCK_KEY,
    COMPONENT_STATE_KEY,
    PROGRESS_KEY,
    ClockMsg,
    ComponentState,
    ComponentStateMsg,
    ProgressMsg,
    key,
)

_log = logging.getLogger(__name__)

DEFAULT_TIMEOUT_S = 900.0
# A run is a rehearsal at full speed: 120 Hz physics and a 5 Hz control loop (DWA, localisation, lock-step
# handshake) build the bundled frame within tolerance in about half the wall time of the physics
# service's own defaults (240 Hz, 10 Hz), measured with bench/build.py. Both are options.
FAST_PHYSICS_HZ = 120.0
FAST_CONTROL_PERIOD_S = 0.2


@dataclass(frozen=True)
class RunOptions:
    robots: int = 1
    rtf: float = 0.0
    lock_step: bool = True
    inject_placement_error_m: float = 0.0
    observe: bool = False
    planner_source: tuple[str, ...] = ()  # extra planner arguments: ("--derive",) etc.
    timeout_s: float = DEFAULT_TIMEOUT_S
    web_port: int = 9090
    physics_hz: float = FAST_PHYSICS_HZ
    control_period_s: float = FAST_CONTROL_PERIOD_S
    physics_extra: tuple[str, ...] = ()  # more physics arguments (benches: --laser-beams …)


@dataclass
class RunOutcome:
    exit_code: int
    constructed: int
    total: int
    failed: list[str] = field(default_factory=list)
    misplacements: int = 0
    sim_time_s: float = 0.0
    wall_time_s: float = 0.0


class _Monitor:
    """Listens to component states, progress and the clock while the build runs (callbacks only record)."""

    def __init__(self, manifest: Manifest, session: zenoh.Session) -> None:
        self._lock = threading.Lock()
        self.states: dict[str, ComponentState] = {}
        self.misplacements = 0
        self.sim_time_s = 0.0
        self.progress: ProgressMsg | None = None
        site = manifest.site
        self._invalid = InvalidPayloads()
        self._subscribers = [
            session.declare_subscriber(key(COMPONENT_STATE_KEY, site=site, key="*"), self._on_state),
            session.declare_subscriber(key(PROGRESS_KEY, site=site), self._on_progress),
            session.declare_subscriber(key(CLOCK_KEY, site=site), self._on_clock),
        ]

    def snapshot(self) -> tuple[dict[str, ComponentState], int, float]:
        """(latest state per GUID, misplacements seen, latest sim time)."""
        with self._lock:
            return dict(self.states), self.misplacements, self.sim_time_s

    def _on_state(self, sample: zenoh.Sample) -> None:
        message = decode(ComponentStateMsg, str(sample.key_expr), sample.payload.to_bytes(), self._invalid)
        if message is not None:
            with self._lock:
                self.states[message.guid] = message.state
                if message.state == ComponentState.MISPLACED and message.previous is not None:
                    self.misplacements += 1

    def _on_progress(self, sample: zenoh.Sample) -> None:
        message = decode(ProgressMsg, str(sample.key_expr), sample.payload.to_bytes(), self._invalid)
        if message is not None:
            with self._lock:
                self.progress = message

    def _on_clock(self, sample: zenoh.Sample) -> None:
        message = decode(ClockMsg, str(sample.key_expr), sample.payload.to_bytes(), self._invalid)
        if message is not None:
            with self._lock:
                self.sim_time_s = max(self.sim_time_s, message.sim_time_s)


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
    ]
    if options.lock_step:
        physics.append("--lock-step")
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
    if options.observe:
        observe = ["observe", "--build", str(build), "--web-port", str(options.web_port), "--exit-when-done"]
        commands.append(("observer", [*observe, *bus]))
    return commands


def run_build(build: Path, options: RunOptions) -> RunOutcome:
    """Run every service on ``build`` until the planner is done (or the timeout); always stops them."""
    manifest = read_manifest(build)
    log_dir = build / "logs"
    if log_dir.exists():
        shutil.rmtree(log_dir)
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    started = time.perf_counter()
    router = ServiceProcess("bus", ["bus", "--listen", endpoint], log_dir)
    services: list[ServiceProcess] = []
    try:
        with open_session(BusOptions(connect=(endpoint,))) as session:
            monitor = _Monitor(manifest, session)
            for name, args in service_commands(build, endpoint, options):
                services.append(ServiceProcess(name, args, log_dir))
            planner = next(service for service in services if service.name == "planner")
            code = _wait_for_planner(planner, [router, *services], options.timeout_s)
            if code is None:
                raise UserError(
                    f"the build did not finish within {options.timeout_s:.0f} s (logs in {log_dir})"
                )
            time.sleep(0.2)  # let the last state messages arrive
            states, misplacements, sim_time_s = monitor.snapshot()
            outcome = RunOutcome(
                exit_code=0,
                constructed=sum(state == ComponentState.CONSTRUCTED for state in states.values()),
                total=len(manifest.components),
                misplacements=misplacements,
                sim_time_s=sim_time_s,
                wall_time_s=time.perf_counter() - started,
            )
            outcome.failed = sorted(
                c.guid for c in manifest.components if states.get(c.guid) != ComponentState.CONSTRUCTED
            )
            outcome.exit_code = 0 if code == 0 and not outcome.failed else 1
            return outcome
    finally:
        for service in reversed(services):
            service.stop()
        router.stop()


def _wait_for_planner(
    planner: ServiceProcess, everyone: list[ServiceProcess], timeout_s: float
) -> int | None:
    """The planner's exit code; None on timeout. A service that dies early ends the run with its log."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if not planner.alive():
            return planner.wait(0)
        for service in everyone:
            if service is not planner and not service.alive() and service.name != "observer":
                tail = "\n".join(service.log().splitlines()[-15:])
                raise UserError(f"{service.name} stopped unexpectedly (exit {service.wait(0)}):\n{tail}")
        time.sleep(0.1)
    return None


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("build", type=Path, help="a converted build folder (bimbot convert … -o BUILD)")
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
        "--inject-placement-error-m",
        type=float,
        default=0.0,
        metavar="M",
        help="robots place each component's first attempt this far off (the agents must catch it)",
    )
    parser.add_argument("--observe", action="store_true", help="also run the observer (rerun web viewer)")
    source = parser.add_mutually_exclusive_group()
    source.add_argument("--derive", action="store_true", help="planner derives the sequence from supports")
    source.add_argument("--sequence", type=Path, default=None, help="planner uses this sequence XML")
    parser.add_argument("--timeout-s", type=float, default=DEFAULT_TIMEOUT_S, help="give up after this long")


def run(args: argparse.Namespace) -> int:
    if args.robots < 1:
        raise UserError("--robots must be at least 1")
    planner_source: tuple[str, ...] = ()
    if args.derive:
        planner_source = ("--derive",)
    elif args.sequence is not None:
        planner_source = ("--sequence", str(args.sequence))
    options = RunOptions(
        robots=args.robots,
        rtf=args.rtf,
        lock_step=not args.no_lock_step,
        inject_placement_error_m=args.inject_placement_error_m,
        observe=args.observe,
        planner_source=planner_source,
        timeout_s=args.timeout_s,
        physics_hz=args.physics_hz,
        control_period_s=args.control_period_s,
    )
    try:
        outcome = run_build(args.build, options)
    except (FileNotFoundError, ValueError) as error:
        raise UserError(f"{args.build}: not a converted build ({error})") from None
    sys.stdout.write(summary_text(outcome))
    return outcome.exit_code


def summary_text(outcome: RunOutcome) -> str:
    lines = [
        f"constructed {outcome.constructed}/{outcome.total} components in "
        f"{outcome.sim_time_s:.1f} s sim time ({outcome.wall_time_s:.1f} s wall), "
        f"{outcome.misplacements} misplacement(s) caught and retried"
    ]
    if outcome.failed:
        lines.append(f"not constructed: {', '.join(outcome.failed)}")
    return "\n".join(lines) + "\n"
