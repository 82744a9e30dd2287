"""``bimbot planner --build OUT/ [--sequence FILE.xml | --from-ifc [FILE.ifc] | --derive]``.

Releases the build's construction tasks in sequence order and assigns them to robots over the bus (see
:mod:`bimbot.services.planner.app`). The sequence comes from the build's ``sequence.xml`` unless one
option names another source: a user XML (``docs/sequence-format.md``), the 4D schedule of an IFC file
(default: the model the build was converted from), or the support graph. Exit codes: 0 (done or stopped),
1 (``--exit-when-done`` and some components failed or were blocked), 2 (unreadable build or sequence: one
line).
"""

from __future__ import annotations

import argparse
import signal
import threading
from pathlib import Path

from bimbot.shared.bus import add_bus_arguments, bus_options, zenoh_config
from bimbot.shared.errors import UserError

from .app import PlannerOptions, main
from .scheduler import PlannerLimits
from .sources import PlanSource, SourceKind


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--build", type=Path, required=True, metavar="OUT", help="converted build folder")
    source = parser.add_mutually_exclusive_group()
    source.add_argument("--sequence", type=Path, metavar="FILE.xml", help="a construction sequence XML file")
    source.add_argument(
        "--from-ifc",
        nargs="?",
        const="",
        default=None,
        metavar="FILE.ifc",
        help="the 4D schedule of an IFC file (default: the model the build was converted from)",
    )
    source.add_argument("--derive", action="store_true", help="derive the sequence from the support graph")
    parser.add_argument(
        "--exit-when-done",
        action="store_true",
        help="exit when every task is done, failed or blocked (0: all constructed, 1: otherwise)",
    )
    parser.add_argument(
        "--agents-timeout-s", type=float, default=30.0, help="wait this long for every component agent (s)"
    )
    parser.add_argument(
        "--resend-s", type=float, default=2.0, help="re-send unobserved events and assignments after (s)"
    )
    parser.add_argument(
        "--site-info-timeout-s",
        type=float,
        default=PlannerOptions.site_info_timeout_s,
        help="wait this long for physics' site info (robot types; without it nothing is checked) (s)",
    )
    parser.add_argument(
        "--strict", action="store_true", help="a sequence step that cuts off later work is an error (exit 2)"
    )
    parser.add_argument(
        "--max-give-backs",
        type=int,
        default=PlannerLimits.max_give_backs,
        help="fail a component given back this often by robots (with the last reason)",
    )
    parser.add_argument(
        "--task-timeout-s",
        type=float,
        default=PlannerLimits.task_timeout_s,
        help="take a task back when its component has not changed state for this long (sim s)",
    )
    add_bus_arguments(parser)


def plan_source(args: argparse.Namespace) -> PlanSource:
    if args.sequence is not None:
        return PlanSource(SourceKind.SEQUENCE, args.sequence)
    if args.from_ifc is not None:
        return PlanSource(SourceKind.IFC, Path(args.from_ifc) if args.from_ifc else None)
    if args.derive:
        return PlanSource(SourceKind.DERIVE)
    return PlanSource(SourceKind.BUILD)


def run(args: argparse.Namespace) -> int:
    if args.agents_timeout_s < 0:
        raise UserError("--agents-timeout-s must not be negative")
    if args.resend_s <= 0:
        raise UserError("--resend-s must be positive")
    if args.site_info_timeout_s < 0:
        raise UserError("--site-info-timeout-s must not be negative")
    if args.max_give_backs < 1:
        raise UserError("--max-give-backs must be at least 1")
    if args.task_timeout_s <= 0:
        raise UserError("--task-timeout-s must be positive")
    try:
        config = zenoh_config(bus_options(args))
    except ValueError as error:
        raise UserError(str(error)) from None
    options = PlannerOptions(
        exit_when_done=args.exit_when_done,
        agents_timeout_s=args.agents_timeout_s,
        resend_s=args.resend_s,
        site_info_timeout_s=args.site_info_timeout_s,
        strict=args.strict,
        limits=PlannerLimits(max_give_backs=args.max_give_backs, task_timeout_s=args.task_timeout_s),
    )
    stop = threading.Event()
    previous = {
        signum: signal.signal(signum, lambda *_: stop.set()) for signum in (signal.SIGINT, signal.SIGTERM)
    }
    try:
        return main(options, args.build, plan_source(args), config, stop)
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
