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
import signal
import threading
from pathlib import Path

from bimbot.shared.bus import add_bus_arguments, bus_options, zenoh_config
from bimbot.shared.errors import UserError


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--build", type=Path, required=True, metavar="OUT/", help="converted build folder")
    parser.add_argument("--id", required=True, metavar="R", help="robot id as spawned by physics (r1, r2, …)")
    parser.add_argument(
        "--inject-placement-error-m",
        type=float,
        default=0.0,
        metavar="X",
        help="offset the first placement attempt by X metres (default 0: none)",
    )
    parser.add_argument(
        "--inject-guids", default="", metavar="G1,G2", help="components whose first placement is offset"
    )
    parser.add_argument(
        "--inject-fraction",
        type=float,
        default=0.0,
        metavar="F",
        help="fraction of components whose first placement is offset (without --inject-guids; default all)",
    )
    parser.add_argument("--seed", type=int, default=0, help="particle filter and injection seed (default 0)")
    parser.add_argument(
        "--info-timeout-s", type=float, default=120.0, help="wait this long for physics to answer (s)"
    )
    parser.add_argument(
        "--place-duration-s", type=float, default=2.0, help="sim seconds of each assembly motion (default 2)"
    )
    add_bus_arguments(parser)


def run(args: argparse.Namespace) -> int:
    from .app import RobotOptions, main
    from .executor import ExecutorConfig

    if args.inject_placement_error_m < 0 or not 0.0 <= args.inject_fraction <= 1.0:
        raise UserError("--inject-placement-error-m must be ≥ 0 and --inject-fraction within 0..1")
    if args.place_duration_s < 0 or args.info_timeout_s <= 0:
        raise UserError("--place-duration-s must be ≥ 0 and --info-timeout-s positive")
    try:
        config = zenoh_config(bus_options(args))
    except ValueError as error:
        raise UserError(str(error)) from None
    executor_config = ExecutorConfig(
        robot_id=args.id,
        place_duration_s=args.place_duration_s,
        placement_error_m=args.inject_placement_error_m,
        inject_guids=frozenset(guid for guid in args.inject_guids.split(",") if guid),
        inject_fraction=args.inject_fraction,
        seed=args.seed,
    )
    options = RobotOptions(info_timeout_s=args.info_timeout_s)
    stop = threading.Event()
    previous = {
        signum: signal.signal(signum, lambda *_: stop.set()) for signum in (signal.SIGINT, signal.SIGTERM)
    }
    try:
        return main(options, args.build, config, executor_config, stop)
    except ValueError as error:  # e.g. a robot id physics did not spawn
        raise UserError(str(error)) from None
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
