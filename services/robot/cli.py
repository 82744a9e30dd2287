"""``bimbot robot --build OUT/ --id R``: run one construction robot (tasks, navigation, localisation).

The robot takes the tasks the planner assigns to it, fetches each component from the yard and assembles it
at its BIM pose, navigating with A*, DWA and a particle filter on the site map (:mod:`.app`). It needs
``bimbot physics`` (which spawns robots ``r1``…``rN``) and answers every clock step. Runs until
SIGTERM/SIGINT, then closes its Zenoh session and exits 0; 2 when the build is unreadable or physics never
answered.

``--inject-placement-error-m X`` offsets the *first* placement attempt (x, world frame) of the components
named by ``--inject-guids`` or, without it, of a ``--inject-fraction`` of them (all when neither is given),
chosen deterministically from ``--seed``: the component then judges itself misplaced and the planner
retries it (tests, demos).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from bimbot.shared.bus import add_bus_arguments
from bimbot.shared.errors import UserError
from bimbot.shared.fidelity import add_fidelity_argument
from bimbot.shared.service_runner import resolve_build, run_service, service_bus

if TYPE_CHECKING:
    from .task_state import ExecutorConfig


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The robot options; every default (and the default named in a help text) is its config's field."""
    from .app import RobotOptions  # zenoh only for the robot command
    from .task_state import ExecutorConfig

    executor, options = ExecutorConfig(robot_id=""), RobotOptions()
    parser.add_argument(
        "--build", type=Path, required=True, metavar="OUT/", help="converted build (folder or manifest.json)"
    )
    parser.add_argument("--id", required=True, metavar="R", help="robot id as spawned by physics (r1, r2, …)")
    parser.add_argument(
        "--inject-placement-error-m",
        type=float,
        default=executor.placement_error_m,
        metavar="X",
        help=f"offset the first placement attempt by X metres (default {executor.placement_error_m:g}: none)",
    )
    parser.add_argument(
        "--inject-guids", default="", metavar="G1,G2", help="components whose first placement is offset"
    )
    parser.add_argument(
        "--inject-fraction",
        type=float,
        default=executor.inject_fraction,
        metavar="F",
        help="fraction of components whose first placement is offset (without --inject-guids; "
        f"default {executor.inject_fraction:g}: all)",
    )
    parser.add_argument(
        "--seed",
        type=int,
        default=executor.seed,
        help=f"the run's seed: this robot's particle filter draws from a stream of its own, derived from "
        f"the seed and its id; injection (default {executor.seed})",
    )
    parser.add_argument(
        "--stepped",
        action="store_true",
        help="tick every clock step in order with the inputs of a defined step (lock-step participant), "
        "so a run reproduces (bimbot run does)",
    )
    add_fidelity_argument(parser)
    parser.add_argument(
        "--info-timeout-s",
        type=float,
        default=options.info_timeout_s,
        help=f"wait this long for physics to answer (default {options.info_timeout_s:g} s)",
    )
    parser.add_argument(
        "--place-duration-s",
        type=float,
        default=executor.place_duration_s,
        help=f"sim seconds of each assembly motion (default {executor.place_duration_s:g})",
    )
    add_bus_arguments(parser)


def executor_config(args: argparse.Namespace) -> ExecutorConfig:
    """The robot's task execution config from the options; a UserError names an impossible value."""
    from .task_state import ExecutorConfig

    if args.inject_placement_error_m < 0 or not 0.0 <= args.inject_fraction <= 1.0:
        raise UserError("--inject-placement-error-m must be ≥ 0 and --inject-fraction within 0..1")
    if args.place_duration_s < 0 or args.info_timeout_s <= 0:
        raise UserError("--place-duration-s must be ≥ 0 and --info-timeout-s positive")
    return ExecutorConfig(
        robot_id=args.id,
        place_duration_s=args.place_duration_s,
        placement_error_m=args.inject_placement_error_m,
        inject_guids=frozenset(guid for guid in args.inject_guids.split(",") if guid),
        inject_fraction=args.inject_fraction,
        seed=args.seed,
    )


def run(args: argparse.Namespace) -> int:
    """Check the options and the build (folder or manifest file), then run the robot until stopped."""
    from .app import RobotOptions, main

    config = executor_config(args)
    bus = service_bus(args)
    build = resolve_build(args.build)
    options = RobotOptions(info_timeout_s=args.info_timeout_s, stepped=args.stepped, fidelity=args.fidelity)
    # a robot id physics did not spawn shows only once physics answers: an InputError (exit 2) from there
    return run_service(main, bus, build, options, config)
