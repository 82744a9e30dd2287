"""``bimbot planner --build OUT/ [--sequence FILE.xml | --from-ifc [FILE.ifc] | --derive]``.

Releases the build's construction tasks in sequence order and assigns them to robots over the bus (see
:mod:`bimbot.services.planner.app`). The sequence comes from the build's ``sequence.xml`` unless one
option names another source: a user XML (``docs/sequence-format.md``), the 4D schedule of an IFC file
(default: the model the build was converted from), or the support graph. Exit codes: 0 (done or stopped),
1 (``--exit-when-done`` and some components failed or were blocked; or a bug, with its traceback), 2
(unreadable build or sequence, impossible option: one line). ``--build`` may name the folder or its
``manifest.json``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from bimbot.shared.bus import add_bus_arguments
from bimbot.shared.errors import UserError
from bimbot.shared.option_types import non_negative_float
from bimbot.shared.service_runner import resolve_build, run_service, service_bus

from .app import PlannerOptions, main
from .scheduler import PlannerLimits
from .sources import PlanSource, SourceKind


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The planner options; every default (and the default named in a help text) is its config's field."""
    options, limits = PlannerOptions(), PlannerLimits()
    parser.add_argument(
        "--build", type=Path, required=True, metavar="OUT", help="converted build (folder or manifest.json)"
    )
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
        "--agents-timeout-s",
        type=float,
        default=options.agents_timeout_s,
        help=f"wait this long for every component agent (default {options.agents_timeout_s:g} s)",
    )
    parser.add_argument(
        "--resend-s",
        type=float,
        default=options.resend_s,
        help=f"re-send unobserved events and assignments after (default {options.resend_s:g} s)",
    )
    parser.add_argument(
        "--site-info-timeout-s",
        type=float,
        default=options.site_info_timeout_s,
        help="wait this long for physics' site info (robot types; without it nothing is checked) "
        f"(default {options.site_info_timeout_s:g} s)",
    )
    parser.add_argument(
        "--strict", action="store_true", help="a sequence step that cuts off later work is an error (exit 2)"
    )
    parser.add_argument(
        "--max-give-backs",
        type=int,
        default=limits.max_give_backs,
        help=f"fail a component given back this often by robots, with the last reason "
        f"(default {limits.max_give_backs})",
    )
    parser.add_argument(
        "--task-timeout-s",
        type=float,
        default=limits.task_timeout_s,
        help="take a task back when its component has not changed state for this long "
        f"(default {limits.task_timeout_s:g} sim s)",
    )
    parser.add_argument(
        "--stepped",
        action="store_true",
        help="take part in physics' lock-step (physics --step-with planner): decide at clock steps from "
        "the inputs of a defined step, so a run reproduces (bimbot run does)",
    )
    parser.add_argument(
        "--lost-grace-s",
        type=non_negative_float,
        default=limits.lost_grace_wall_s,
        help="wall seconds a robot whose liveliness went keeps its task (a link or router down for a "
        "while; back with it, it goes on) before it is given back "
        f"(default {limits.lost_grace_wall_s:g}: at once)",
    )
    parser.add_argument(
        "--no-skip",
        action="store_true",
        help="never ask physics to skip its clock over a quiet site (curing, timed work in place)",
    )
    add_bus_arguments(parser)


def plan_source(args: argparse.Namespace) -> PlanSource:
    """Which sequence the options name (the build's own ``sequence.xml`` when none does)."""
    if args.sequence is not None:
        return PlanSource(SourceKind.SEQUENCE, args.sequence)
    if args.from_ifc is not None:
        return PlanSource(SourceKind.IFC, Path(args.from_ifc) if args.from_ifc else None)
    if args.derive:
        return PlanSource(SourceKind.DERIVE)
    return PlanSource(SourceKind.BUILD)


def checked_source(args: argparse.Namespace) -> PlanSource:
    """:func:`plan_source`, with a UserError when the file it names does not exist."""
    source = plan_source(args)
    if source.path is not None and not source.path.is_file():
        flag = "--sequence" if source.kind is SourceKind.SEQUENCE else "--from-ifc"
        raise UserError(f"{flag} {source.path}: no such file")
    return source


def planner_options(args: argparse.Namespace) -> PlannerOptions:
    """The options as :class:`PlannerOptions`; a UserError names the first impossible value."""
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
    return PlannerOptions(
        exit_when_done=args.exit_when_done,
        agents_timeout_s=args.agents_timeout_s,
        resend_s=args.resend_s,
        site_info_timeout_s=args.site_info_timeout_s,
        strict=args.strict,
        skip_quiet=not args.no_skip,
        stepped=args.stepped,
        limits=PlannerLimits(
            max_give_backs=args.max_give_backs,
            task_timeout_s=args.task_timeout_s,
            lost_grace_wall_s=args.lost_grace_s,
        ),
    )


def run(args: argparse.Namespace) -> int:
    """Check the options, the build (folder or manifest file) and the sequence, then plan until done."""
    options = planner_options(args)
    bus = service_bus(args)
    source = checked_source(args)
    build = resolve_build(args.build)
    return run_service(main, bus, build, options, source)
