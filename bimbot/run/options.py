"""The options of ``bimbot run`` and ``bimbot demo``, each declared once, and :class:`RunOptions`.

:data:`SERVICE_OPTIONS` is every option a service takes from the run: its declaration (type, default,
help), the services that get it and where :class:`RunOptions` keeps it. The run's parser
(:func:`add_run_arguments`), :func:`run_options` and the children's command lines
(:func:`service_flags`, used by :mod:`bimbot.run.commands`) are all built from it; the physics profile's
options and the tolerances are physics' and shared's own declarations
(:data:`~bimbot.services.physics.profiles.PROFILE_OPTIONS`, :data:`~bimbot.shared.tolerance_options.
TOLERANCE_OPTIONS`). :data:`RUN_OPTIONS` are the run's own.

Kept apart from :mod:`bimbot.run.build` (which runs a build with them) so both commands and the benches share
one set of defaults: the named physics profile of a run (:mod:`bimbot.services.physics.profiles`; single
values override it), the run folder, the time limit, the stall watchdog's bounds, how often the report is
written while a run goes on, and ``-q``.
"""

from __future__ import annotations

import argparse
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from bimbot.run.restarts import RestartPolicy
from bimbot.run.watchdog import DEFAULT_CLOCK_STALL_WALL_S, DEFAULT_STALL_AFTER_S
from bimbot.services.component_agents.agent import AgentConfig
from bimbot.services.observer import VIEWER_GRPC_PORT, VIEWER_WEB_PORT
from bimbot.services.physics.profiles import PROFILE_OPTIONS, RUN_PROFILE, profile_option
from bimbot.shared.errors import UserError
from bimbot.shared.fidelity import DEFAULT_FIDELITY, FIDELITY_OPTION
from bimbot.shared.option_types import (
    OptionSpec,
    non_negative_float,
    non_negative_int,
    positive_float,
    positive_int,
)
from bimbot.shared.seeds import DEFAULT_SEED
from bimbot.shared.tolerance_options import TOLERANCE_OPTIONS, tolerances_from
from bimbot.shared.verification import Tolerances

DEFAULT_TIMEOUT_S = 900.0  # a run's wall-clock bound, at least…
TIMEOUT_PER_COMPONENT_S = (
    60.0  # …plus this per component: a real building's run is not cut off while it builds
)


def default_timeout_s(components: int) -> float:
    """The wall-clock bound of a run without ``--timeout-s``: 900 s plus 60 s per component (the stall
    watchdogs end a run that stopped changing long before)."""
    return DEFAULT_TIMEOUT_S + TIMEOUT_PER_COMPONENT_S * components


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
    total_station_mm: float | None = None  # a positioning sensor on site (None: the profile's; 0: none)
    connections: bool = True  # components set down at their target are connected to what is built
    inject_placement_error_m: float = 0.0
    observer: ObserverOptions | None = None
    planner_source: tuple[str, ...] = ()  # extra planner arguments: ("--derive",) etc.
    timeout_s: float | None = None  # None: default_timeout_s of the build's components
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
    fidelity: str = DEFAULT_FIDELITY  # "plan": kinematic robots, a clock that jumps by events
    routers: int = 1  # 2: a site across two hosts, rehearsed here (bimbot.run.commands.service_commands)
    # machine types that stay off site: ``bimbot run`` fills it with those the build gives no work
    # (bimbot.shared.idle_machines); physics gets it as --off-site
    off_site: tuple[str, ...] = ()
    # crane types the site erects more of than the fleet file's count, for the building's footprint
    # (bimbot.shared.crane_count: an entry's up_to); ``bimbot run`` fills it, physics gets it as --cranes
    cranes: tuple[tuple[str, int], ...] = ()


@dataclass(frozen=True)
class ServiceOption:
    """An option of the run that goes on to services: its one declaration, the services that get it, and
    where :class:`RunOptions` keeps its value (``kept``: a field, or a path into one; None: the option
    travels as given, in ``RunOptions.planner_source``)."""

    spec: OptionSpec
    services: tuple[str, ...]
    kept: str | None
    shown: Callable[[Any], Any] | None = None  # the kept value in the flag's unit (radians → degrees, …)
    always: bool = False  # passed at its default too
    group: str | None = None  # at most one option of a group (the planner's sequence source)

    def value(self, options: RunOptions) -> Any:
        value: Any = options
        for name in (self.kept or "").split("."):
            value = getattr(value, name)
        return self.shown(value) if self.shown is not None and value is not None else value

    def flags(self, options: RunOptions) -> list[str]:
        """The words that pass the option on: none when it is kept as given or left at the run's default."""
        if self.kept is None:
            return []
        value = self.value(options)
        if not self.always and value == self.value(RunOptions()):
            return []
        return self.spec.flags(value)


_SOURCE = "source"
PLANNER_ONLY = "planner"

#: Every option of ``bimbot run`` that a service takes, declared once: the run's parser and every child's
#: command line are built from it (:func:`add_run_arguments`, :func:`service_flags`); that each service's
#: own parser takes what it is given is ``tests/run/test_run_options.py``'s.
SERVICE_OPTIONS: tuple[ServiceOption, ...] = (
    ServiceOption(
        OptionSpec(
            "--fleet",
            type=Path,
            metavar="FLEET.toml",
            help="the robot types on site and how many of each (default: bimbot's mixed fleet: a Husky, a "
            "heavy carrier, a tower crane, a concrete pump, a block-laying robot, a trailer line pump "
            "and a piling rig; "
            "see `bimbot fleet show`)",
        ),
        ("physics",),
        "fleet",
        shown=Path.resolve,
    ),
    ServiceOption(
        OptionSpec(
            "--robots",
            type=positive_int,
            metavar="N",
            help="N robots of the fleet's default type (its `default_type`: the carrier in bimbot's fleet) "
            "instead of its ground robots; the machines that stand fixed (its cranes, pumps, block layers) "
            "stay, a pump or a block layer only when the build has work for it",
        ),
        ("physics",),
        "robots",
    ),
    ServiceOption(profile_option(RUN_PROFILE), ("physics",), "profile", always=True),
    *(ServiceOption(spec, ("physics",), spec.dest) for spec in PROFILE_OPTIONS),
    ServiceOption(TOLERANCE_OPTIONS[0], ("physics",), "tolerances.position_m"),  # physics serves them all
    ServiceOption(TOLERANCE_OPTIONS[1], ("physics",), "tolerances.angle_rad", shown=math.degrees),
    ServiceOption(TOLERANCE_OPTIONS[2], ("physics",), "tolerances.drift_m"),
    ServiceOption(
        OptionSpec(
            "--seed",
            type=non_negative_int,
            default=DEFAULT_SEED,
            metavar="N",
            help="seed of every random draw (odometry and placement noise in physics, each robot's "
            f"localisation); the same build, fleet, sequence and seed give the same outcome ({DEFAULT_SEED})",
        ),
        ("physics", "robot"),
        "seed",
        always=True,
    ),
    ServiceOption(FIDELITY_OPTION, ("physics", "robot"), "fidelity"),
    ServiceOption(
        OptionSpec(
            "--inject-placement-error-m",
            type=non_negative_float,
            default=0.0,
            metavar="M",
            help="robots place each component's first attempt this far off (the agents must catch it)",
        ),
        ("robot",),
        "inject_placement_error_m",
    ),
    ServiceOption(
        OptionSpec(
            "--max-attempts",
            type=positive_int,
            metavar="N",
            help="placements a component gets before it fails "
            f"(default {AgentConfig.max_attempts}, the agents')",
        ),
        ("agents",),
        "max_attempts",
    ),
    ServiceOption(
        OptionSpec("--derive", kind="switch", help="planner derives the sequence from supports"),
        ("planner",),
        None,
        group=_SOURCE,
    ),
    ServiceOption(
        OptionSpec(
            "--sequence",
            type=Path,
            help="planner uses this sequence XML, or an MS Project XML, P6 XML or P6 XER schedule",
        ),
        ("planner",),
        None,
        group=_SOURCE,
    ),
    ServiceOption(
        OptionSpec(
            "--from-ifc",
            const="",
            metavar="FILE.ifc",
            help="planner reads the 4D schedule of an IFC file (default: the model the build was converted "
            "from)",
        ),
        ("planner",),
        None,
        group=_SOURCE,
    ),
    ServiceOption(
        OptionSpec(
            "--strict",
            kind="switch",
            help="a sequence step that cuts off later work is an error (exit 2), not a warning",
        ),
        ("planner",),
        None,
    ),
)

#: The options of the run itself (no service takes them).
RUN_OPTIONS: tuple[OptionSpec, ...] = (
    OptionSpec(
        "--run-dir",
        type=Path,
        metavar="DIR",
        help="this run's output folder: journal, logs, report, recording (default BUILD/runs/<time>/, "
        "linked as BUILD/runs/latest)",
    ),
    OptionSpec(
        "--check-stability",
        kind="switch",
        help="no build: replay the sequence in physics without robots (every component at its BIM pose, "
        "released onto what is under it) and report the first step whose partial structure does not stand",
    ),
    OptionSpec(
        "--timeout-s",
        type=positive_float,
        help=f"end the run after this many wall seconds, with its report (default {DEFAULT_TIMEOUT_S:g} s "
        f"plus {TIMEOUT_PER_COMPONENT_S:g} s per component; a run whose site stops changing ends sooner, "
        "see --stall-after-s and --stall-wall-s)",
    ),
    OptionSpec(
        "--stall-after-s",
        type=non_negative_float,
        default=DEFAULT_STALL_AFTER_S,
        help="end the run when nothing on the site changed for this many sim seconds "
        f"({DEFAULT_STALL_AFTER_S:g}; 0: never)",
    ),
    OptionSpec(
        "--stall-wall-s",
        type=non_negative_float,
        default=DEFAULT_CLOCK_STALL_WALL_S,
        help="end the run when the sim clock stood still this many wall seconds, a guard against a hung "
        "service; physics also holds the clock at the start this long for the planner to prepare its plan. "
        "Raise it on a slow or busy machine or a very large build, whose start can take longer "
        f"({DEFAULT_CLOCK_STALL_WALL_S:g}; 0: never, physics then waits its own 300 s)",
    ),
    OptionSpec(
        "--report-every-s",
        type=non_negative_float,
        default=DEFAULT_REPORT_EVERY_S,
        help="also write the report this often (wall seconds) while it runs "
        f"({DEFAULT_REPORT_EVERY_S:g}; 0: never)",
    ),
    OptionSpec(
        "--max-restarts",
        type=non_negative_int,
        default=RestartPolicy.max_restarts,
        metavar="N",
        help="restart each service that dies up to N times (per service), with backoff, and go on "
        f"({RestartPolicy.max_restarts}; 0: a dead service ends the run)",
    ),
    OptionSpec(
        "--quiet",
        short="-q",
        dest="run_quiet",
        kind="switch",
        help="no live progress and no info logs, only the summary",
    ),
    OptionSpec(
        "--observe", kind="switch", help="also run the observer: a rerun recording (.rrd) of the build"
    ),
    OptionSpec(
        "--secure",
        kind="switch",
        help="a secured bus: each service joins with its own credentials and the router lets only the "
        "right service speak (Zenoh access control; files in RUN/bus/)",
    ),
    OptionSpec(
        "--routers",
        type=int,
        choices=(1, 2),
        default=1,
        help="2: a site across two hosts, rehearsed on this one: two routers linked router to router; "
        "physics, the planner and half the agents behind the first, the robots and the other half behind "
        "the second, every service a Zenoh client of its own router (default 1)",
    ),
    OptionSpec(
        "--live",
        kind="switch",
        help="serve the rerun web viewer on 127.0.0.1 during the build and keep it up afterwards",
    ),
    OptionSpec(
        "--web-port",
        type=int,
        default=ObserverOptions.web_port,
        help=f"web viewer port with --live ({ObserverOptions.web_port})",
    ),
    OptionSpec(
        "--grpc-port",
        type=int,
        default=ObserverOptions.grpc_port,
        help=f"viewer data port with --live ({ObserverOptions.grpc_port})",
    ),
)


def add_run_arguments(parser: argparse.ArgumentParser) -> None:
    """The options ``bimbot run`` and ``bimbot demo`` share: :data:`SERVICE_OPTIONS`, :data:`RUN_OPTIONS`."""
    groups: dict[str, argparse._MutuallyExclusiveGroup] = {}
    for option in SERVICE_OPTIONS:
        if option.group is None:
            option.spec.declare(parser)
        else:
            if option.group not in groups:
                groups[option.group] = parser.add_mutually_exclusive_group()
            option.spec.declare(groups[option.group])
    for spec in RUN_OPTIONS:
        spec.declare(parser)


def service_flags(service: str, options: RunOptions) -> list[str]:
    """The options ``service`` gets from the run, in :data:`SERVICE_OPTIONS`' order; the planner's
    sequence source and ``--strict`` as the user gave them (``RunOptions.planner_source``)."""
    words = [
        word for option in SERVICE_OPTIONS if service in option.services for word in option.flags(options)
    ]
    return [*words, *options.planner_source] if service == PLANNER_ONLY else words


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
    if (args.timeout_s is not None and args.timeout_s <= 0) or min(
        args.stall_after_s, args.stall_wall_s, args.report_every_s
    ) < 0:
        raise UserError("--timeout-s must be positive; --stall-after-s, --stall-wall-s, --report-every-s ≥ 0")
    if getattr(args, "routers", 1) > 1 and getattr(args, "secure", False):
        raise UserError("--routers 2 runs on an open bus: --secure is for one router")
    kept = {
        option.kept: getattr(args, option.spec.dest)
        for option in SERVICE_OPTIONS
        if option.kept is not None and "." not in option.kept
    }
    planner_source = tuple(
        word
        for option in SERVICE_OPTIONS
        if option.kept is None
        for word in option.spec.flags(getattr(args, option.spec.dest, None))
    )
    observer = None
    if observe or args.observe or args.live:
        observer = ObserverOptions(
            web=args.live,
            web_port=args.web_port,
            grpc_port=args.grpc_port,
            keep_serving=args.live,
        )
    return RunOptions(
        **kept,
        tolerances=tolerances_from(args),
        observer=observer,
        planner_source=planner_source,
        timeout_s=args.timeout_s,
        run_dir=args.run_dir,
        stall_after_s=args.stall_after_s,
        clock_stall_wall_s=args.stall_wall_s,
        report_every_s=args.report_every_s,
        max_restarts=args.max_restarts,
        show_progress=not quiet(args),
        secure=getattr(args, "secure", False),
        routers=getattr(args, "routers", 1),
    )


def quiet(args: argparse.Namespace) -> bool:
    """``bimbot -q run …`` or ``bimbot run … -q``; the latter also lowers the log level to warnings."""
    if getattr(args, "run_quiet", False):
        logging.getLogger().setLevel(logging.WARNING)
        return True
    return bool(getattr(args, "quiet", False))
