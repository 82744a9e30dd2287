"""The options of ``bimbot run`` and ``bimbot demo``: defaults, the shared arguments, and :class:`RunOptions`.

Kept apart from :mod:`bimbot.run` (which runs a build with them) so both commands and the benches share
one set of defaults: the named physics profile of a run (:mod:`bimbot.services.physics.profiles`; single
values override it), the run folder, the time limit, the stall watchdog's bounds, how often the report is
written while a run goes on, and ``-q``.
"""

from __future__ import annotations

import argparse
import logging
from dataclasses import dataclass, field
from pathlib import Path

from bimbot.run_restarts import RestartPolicy
from bimbot.run_watchdog import DEFAULT_CLOCK_STALL_WALL_S, DEFAULT_STALL_AFTER_S
from bimbot.services.component_agents.agent import AgentConfig
from bimbot.services.observer import VIEWER_GRPC_PORT, VIEWER_WEB_PORT
from bimbot.services.physics.profiles import RUN_PROFILE, add_profile_arguments
from bimbot.shared.errors import UserError
from bimbot.shared.fidelity import DEFAULT_FIDELITY, add_fidelity_argument
from bimbot.shared.option_types import non_negative_float, non_negative_int, positive_float, positive_int
from bimbot.shared.seeds import DEFAULT_SEED
from bimbot.shared.tolerance_options import add_tolerance_arguments, tolerances_from
from bimbot.shared.verification import Tolerances

DEFAULT_TIMEOUT_S = 900.0
DEFAULT_REPORT_EVERY_S = 30.0  # wall seconds between two reports written while the run goes on


@dataclass(frozen=True)
class ObserverOptions:
    """The observer in a run: always an ``.rrd``; the web viewer only when asked (``--live``)."""

    web: bool = False
    web_port: int = VIEWER_WEB_PORT
    grpc_port: int = VIEWER_GRPC_PORT
    keep_serving: bool = False  # after the build, until interrupted (the viewer stays up)


@dataclass(frozen=True)
class RunOptions:
    robots: int | None = None  # None: the fleet's robots; N: N of its default type and its fixed machines
    fleet: Path | None = None  # a fleet file (TOML); None: the embedded default fleet
    profile: str = RUN_PROFILE  # a named physics profile (services/physics/profiles.py)
    rtf: float | None = None  # None: the profile's; likewise the next three
    lock_step: bool | None = None
    physics_hz: float | None = None
    control_period_s: float | None = None
    laser_beams: int | None = None
    command_latency_steps: int | None = None
    total_station_mm: float | None = None  # a positioning sensor on site (None: none)
    connections: bool = True  # components set down at their target are connected to what is built
    inject_placement_error_m: float = 0.0
    observer: ObserverOptions | None = None
    planner_source: tuple[str, ...] = ()  # extra planner arguments: ("--derive",) etc.
    timeout_s: float = DEFAULT_TIMEOUT_S
    physics_extra: tuple[str, ...] = ()  # more physics arguments (benches, experiments)
    run_dir: Path | None = None  # default: a new folder under BUILD/runs/ (bimbot.shared.run_folder)
    stall_after_s: float = DEFAULT_STALL_AFTER_S  # sim seconds without a change on the site (0: never)
    clock_stall_wall_s: float = DEFAULT_CLOCK_STALL_WALL_S  # wall seconds without the clock advancing
    report_every_s: float = DEFAULT_REPORT_EVERY_S  # wall seconds; 0: only at the end
    max_restarts: int = RestartPolicy.max_restarts  # per service: a service that dies is started again
    show_progress: bool = False  # live progress on stdout (the CLI: unless -q)
    secure: bool = False  # a secured bus: per-service credentials, the router's access control (RUN/bus/)
    max_attempts: int | None = None  # placements a component gets before it fails (None: the agents')
    tolerances: Tolerances = field(default_factory=Tolerances)  # in force on site: physics serves them
    seed: int = DEFAULT_SEED  # every random draw of the run (physics, each robot's own stream)
    routers: int = 1  # 2: a site across two hosts, rehearsed here (bimbot.run_commands.service_commands)
    fidelity: str = DEFAULT_FIDELITY  # "plan": kinematic robots, a clock that jumps by events


def add_run_arguments(parser: argparse.ArgumentParser) -> None:
    """The options ``bimbot run`` and ``bimbot demo`` share."""
    parser.add_argument(
        "--fleet",
        type=Path,
        default=None,
        metavar="FLEET.toml",
        help="the robot types on site and how many of each (default: bimbot's mixed fleet: a Husky, a heavy "
        "carrier, a tower crane, a concrete pump and a block-laying robot; see `bimbot fleet show`)",
    )
    parser.add_argument(
        "--robots",
        type=positive_int,
        default=None,
        help="N robots of the fleet's default type instead of its ground robots; the machines that stand "
        "fixed (its cranes, pumps, block layers) stay",
    )
    parser.add_argument(
        "--run-dir",
        type=Path,
        default=None,
        metavar="DIR",
        help="this run's output folder: journal, logs, report, recording (default BUILD/runs/<time>/, "
        "linked as BUILD/runs/latest)",
    )
    add_profile_arguments(parser, RUN_PROFILE)
    add_fidelity_argument(parser)
    add_tolerance_arguments(parser)
    parser.add_argument(
        "--seed",
        type=non_negative_int,
        default=DEFAULT_SEED,
        metavar="N",
        help="seed of every random draw (odometry and placement noise in physics, each robot's "
        f"localisation); the same build, fleet, sequence and seed give the same outcome ({DEFAULT_SEED})",
    )
    parser.add_argument(
        "--inject-placement-error-m",
        type=non_negative_float,
        default=0.0,
        metavar="M",
        help="robots place each component's first attempt this far off (the agents must catch it)",
    )
    source = parser.add_mutually_exclusive_group()
    source.add_argument("--derive", action="store_true", help="planner derives the sequence from supports")
    source.add_argument(
        "--sequence",
        type=Path,
        default=None,
        help="planner uses this sequence XML, or an MS Project XML, P6 XML or P6 XER schedule",
    )
    source.add_argument(
        "--from-ifc",
        nargs="?",
        const="",
        default=None,
        metavar="FILE.ifc",
        help="planner reads the 4D schedule of an IFC file (default: the model the build was converted from)",
    )
    parser.add_argument(
        "--strict",
        action="store_true",
        help="a sequence step that cuts off later work is an error (exit 2), not a warning",
    )
    parser.add_argument(
        "--max-attempts",
        type=positive_int,
        default=None,
        metavar="N",
        help=f"placements a component gets before it fails (default {AgentConfig.max_attempts}, the agents')",
    )
    parser.add_argument(
        "--check-stability",
        action="store_true",
        help="no build: replay the sequence in physics without robots (every component at its BIM pose, "
        "released onto what is under it) and report the first step whose partial structure does not stand",
    )
    parser.add_argument(
        "--timeout-s",
        type=positive_float,
        default=DEFAULT_TIMEOUT_S,
        help=f"end the run after this many wall seconds, with its report ({DEFAULT_TIMEOUT_S:g})",
    )
    parser.add_argument(
        "--stall-after-s",
        type=non_negative_float,
        default=DEFAULT_STALL_AFTER_S,
        help="end the run when nothing on the site changed for this many sim seconds "
        f"({DEFAULT_STALL_AFTER_S:g}; 0: never)",
    )
    parser.add_argument(
        "--stall-wall-s",
        type=non_negative_float,
        default=DEFAULT_CLOCK_STALL_WALL_S,
        help="end the run when the sim clock stood still this many wall seconds "
        f"({DEFAULT_CLOCK_STALL_WALL_S:g})",
    )
    parser.add_argument(
        "--report-every-s",
        type=non_negative_float,
        default=DEFAULT_REPORT_EVERY_S,
        help="also write the report this often (wall seconds) while it runs "
        f"({DEFAULT_REPORT_EVERY_S:g}; 0: never)",
    )
    parser.add_argument(
        "--max-restarts",
        type=non_negative_int,
        default=RestartPolicy.max_restarts,
        metavar="N",
        help="restart each service that dies up to N times (per service), with backoff, and go on "
        f"({RestartPolicy.max_restarts}; 0: a dead service ends the run)",
    )
    parser.add_argument(
        "-q",
        "--quiet",
        dest="run_quiet",
        action="store_true",
        help="no live progress and no info logs, only the summary",
    )
    parser.add_argument(
        "--observe", action="store_true", help="also run the observer: a rerun recording (.rrd) of the build"
    )
    parser.add_argument(
        "--secure",
        action="store_true",
        help="a secured bus: each service joins with its own credentials and the router lets only the "
        "right service speak (Zenoh access control; files in RUN/bus/)",
    )
    parser.add_argument(
        "--routers",
        type=int,
        choices=(1, 2),
        default=1,
        help="2: a site across two hosts, rehearsed on this one: two routers linked router to router; "
        "physics, the planner and half the agents behind the first, the robots and the other half behind "
        "the second, every service a Zenoh client of its own router (default 1)",
    )
    parser.add_argument(
        "--live",
        action="store_true",
        help="serve the rerun web viewer on 127.0.0.1 during the build and keep it up afterwards",
    )
    parser.add_argument(
        "--web-port",
        type=int,
        default=ObserverOptions.web_port,
        help=f"web viewer port with --live ({ObserverOptions.web_port})",
    )
    parser.add_argument(
        "--grpc-port",
        type=int,
        default=ObserverOptions.grpc_port,
        help=f"viewer data port with --live ({ObserverOptions.grpc_port})",
    )


def run_options(args: argparse.Namespace, *, observe: bool = False) -> RunOptions:
    """RunOptions from the shared arguments (a UserError for impossible values)."""
    if args.robots is not None and args.robots < 1:
        raise UserError("--robots must be at least 1")
    if any(value is not None and value <= 0 for value in (args.physics_hz, args.control_period_s)) or (
        args.laser_beams is not None and args.laser_beams < 1
    ):
        raise UserError("--physics-hz, --control-period-s and --laser-beams must be positive")
    if args.rtf is not None and args.rtf < 0:
        raise UserError("--rtf must be >= 0")
    if args.timeout_s <= 0 or min(args.stall_after_s, args.stall_wall_s, args.report_every_s) < 0:
        raise UserError("--timeout-s must be positive; --stall-after-s, --stall-wall-s, --report-every-s ≥ 0")
    if getattr(args, "routers", 1) > 1 and getattr(args, "secure", False):
        raise UserError("--routers 2 runs on an open bus: --secure is for one router")
    planner_source: tuple[str, ...] = ()
    if args.derive:
        planner_source = ("--derive",)
    elif args.sequence is not None:
        planner_source = ("--sequence", str(args.sequence))
    elif getattr(args, "from_ifc", None) is not None:
        planner_source = ("--from-ifc", args.from_ifc) if args.from_ifc else ("--from-ifc",)
    if args.strict:
        planner_source = (*planner_source, "--strict")
    observer = None
    if observe or args.observe or args.live:
        observer = ObserverOptions(
            web=args.live,
            web_port=args.web_port,
            grpc_port=args.grpc_port,
            keep_serving=args.live,
        )
    return RunOptions(
        robots=args.robots,
        fleet=args.fleet,
        profile=args.profile,
        rtf=args.rtf,
        lock_step=args.lock_step,
        inject_placement_error_m=args.inject_placement_error_m,
        observer=observer,
        planner_source=planner_source,
        timeout_s=args.timeout_s,
        physics_hz=args.physics_hz,
        control_period_s=args.control_period_s,
        laser_beams=args.laser_beams,
        command_latency_steps=args.command_latency_steps,
        total_station_mm=args.total_station_mm,
        connections=args.connections,
        run_dir=args.run_dir,
        stall_after_s=args.stall_after_s,
        clock_stall_wall_s=args.stall_wall_s,
        report_every_s=args.report_every_s,
        max_restarts=args.max_restarts,
        show_progress=not quiet(args),
        secure=getattr(args, "secure", False),
        max_attempts=getattr(args, "max_attempts", None),
        tolerances=tolerances_from(args),
        seed=getattr(args, "seed", DEFAULT_SEED),
        routers=getattr(args, "routers", 1),
        fidelity=getattr(args, "fidelity", DEFAULT_FIDELITY),
    )


def quiet(args: argparse.Namespace) -> bool:
    """``bimbot -q run …`` or ``bimbot run … -q``; the latter also lowers the log level to warnings."""
    if getattr(args, "run_quiet", False):
        logging.getLogger().setLevel(logging.WARNING)
        return True
    return bool(getattr(args, "quiet", False))
