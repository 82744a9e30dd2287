"""The ``bimbot`` console script: one sub-command per service, each a thin adapter living beside its service.

Every sub-command module exposes ``add_arguments(parser)`` and ``run(args) -> int``; only the chosen one is
imported, so ``bimbot --help`` stays fast. A :class:`bimbot.shared.errors.UserError` ends in one clear
line (``bimbot run: error: …``, as a bad option's) and exit code 2, never a traceback. Any other
exception is a bug: its traceback is logged to stderr (a service's log file under ``bimbot run``, which
shows its tail) and the exit code is 1. Commands check the user's input before they start their work, so
a bug is never reported as bad input.
"""

from __future__ import annotations

import argparse
import ctypes
import importlib
import logging
import os
import re
import signal
import sys
from typing import NoReturn

from bimbot import __version__
from bimbot.shared.errors import UserError
from bimbot.supervisor import STOP_WITH_PARENT_ENV

# sub-command → (module with add_arguments/run, one-line help)
SUBCOMMANDS: dict[str, tuple[str, str]] = {
    "sample": (
        "bimbot.data.sample_cli",
        "write a generated sample IFC model (the bundled light steel frame)",
    ),
    "convert": (
        "bimbot.services.converter.cli",
        "convert an IFC model into an SDF robot world (OUT/ folder)",
    ),
    "demo": ("bimbot.demo", "run the demo on the bundled light steel frame (writes out/demo/)"),
    "bus": ("bimbot.services.bus_router", "run the site's Zenoh router (every service connects to it)"),
    "bus-credentials": (
        "bimbot.bus_credentials_cli",
        "write a secured bus's passwords and configs (RUN_DIR/bus/): only the right service can speak",
    ),
    "agents": ("bimbot.services.component_agents.cli", "run the smart-component agents of a converted build"),
    "planner": (
        "bimbot.services.planner.cli",
        "release construction tasks in sequence order and assign them to robots",
    ),
    "physics": (
        "bimbot.services.physics.cli",
        "simulate the site in PyBullet: clock, robots, sensors, attach and place",
    ),
    "robot": ("bimbot.services.robot.cli", "run one construction robot: tasks, navigation, localisation"),
    "methods": (
        "bimbot.methods_cli",
        "print the construction-method rules (a preset) as a methods file, or check one",
    ),
    "fleet": (
        "bimbot.fleet_cli",
        "what a robot fleet can build (feasibility table, no build), or show the default fleet file",
    ),
    "run": ("bimbot.run.main", "build a converted model with every service as a process on a loopback bus"),
    "study": (
        "bimbot.study.cli",
        "compare scenarios: many runs over fleets, sequences and seeds (on Dask); CSV, table and plot",
    ),
    "runs": ("bimbot.runs_cli", "list the runs of a build (BUILD/runs/), or make a new run folder"),
    "compare": (
        "bimbot.compare_cli",
        "runs side by side by construction method",
    ),
    "observe": (
        "bimbot.services.observer.cli",
        "log the live twin to rerun: web viewer on 127.0.0.1 and an .rrd recording",
    ),
    "watch": ("bimbot.services.observer.watch", "live table of component states in the terminal"),
    "export": (
        "bimbot.export.cli",
        "a run for builders' tools: 4D IFC, MS Project and P6 XML, a USD stage, a component as URDF/SDF",
    ),
}

#: The long-running services: their log (a file under ``bimbot run``) is their output, INFO by default.
#: Every other command prints its result on stdout and logs warnings only, unless ``-v``.
SERVICE_COMMANDS = frozenset({"bus", "agents", "planner", "physics", "robot", "observe"})

_log = logging.getLogger("bimbot")
PR_SET_PDEATHSIG = 1  # prctl(2): the signal the kernel sends when the parent dies

EXIT_USER_ERROR = 2  # bad input: one line
EXIT_BUG = 1  # an unexpected exception: its traceback is in the log
BUG_MARK = "failed with an unexpected error"  # in the log line above the traceback (bimbot run looks for it)


def log_verbosity(command: str, verbose: int, quiet: bool) -> int:
    """The verbosity :func:`configure_logging` takes for ``command``: -1 (warnings) with ``-q``; for a
    service 0 (INFO) plus each ``-v``; for any other command (convert, run, compare …) -1 plus each ``-v``:
    a user reads its summary on stdout, not the INFO lines of its steps (``-v`` shows them)."""
    if quiet:
        return -1
    return verbose if command in SERVICE_COMMANDS else verbose - 1


def configure_logging(verbosity: int) -> None:
    """Configure the root logger once, from ``main`` only (libraries just call ``getLogger``)."""
    level = logging.WARNING if verbosity < 0 else logging.INFO if verbosity == 0 else logging.DEBUG
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s", stream=sys.stderr)
    if level > logging.DEBUG:
        # transitions logs every state entry and exit at INFO: thousands of lines a second in the agents,
        # most of a robot's log; the services log their own transitions where they matter
        logging.getLogger("transitions").setLevel(logging.WARNING)


class OneLineErrorParser(argparse.ArgumentParser):
    """argparse, with a bad option reported as one line and exit 2: ``bimbot run: error: argument --rtf: -1
    must be zero or a positive number (see bimbot run --help)``. argparse's own ``error`` prints the whole
    usage first, a screenful for a service's options that buried the one line that matters; ``--help``
    still prints it all. Sub-command parsers are of this class too (argparse makes them of the parent's)."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_USER_ERROR, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser(argv: list[str]) -> argparse.ArgumentParser:
    """The parser, with full arguments for the sub-command named by the first non-option word of ``argv``."""
    chosen = next((word for word in argv if not word.startswith("-")), None)
    parser = OneLineErrorParser(
        prog="bimbot", description="bimbot: IFC building model → robot construction simulation"
    )
    parser.add_argument(
        "-v",
        "--verbose",
        action="count",
        default=0,
        help="more log output: -v a command's INFO lines, -vv debug (a service logs INFO unasked)",
    )
    parser.add_argument("-q", "--quiet", action="store_true", help="warnings and errors only")
    parser.add_argument("--version", action="version", version=f"bimbot {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, (module_name, help_text) in SUBCOMMANDS.items():
        sub_parser = sub.add_parser(name, help=help_text, description=help_text)
        sub_parser.set_defaults(_module=module_name)
        if name == chosen:
            importlib.import_module(module_name).add_arguments(sub_parser)
            sub_parser.set_defaults(_parser=sub_parser)  # its own errors name it (``main``)
    return parser


def stop_with_parent() -> None:
    """A service started by :mod:`bimbot.supervisor` gets SIGTERM when the process that started it dies,
    even by SIGKILL (a killed ``bimbot run`` or test), so no service runs on alone forever. Linux's
    ``prctl(PR_SET_PDEATHSIG)``, set here rather than between fork and exec because the starting process
    has Zenoh's threads; a parent that died before this line is caught by the pid check."""
    parent = os.environ.pop(STOP_WITH_PARENT_ENV, None)
    if parent is None or not sys.platform.startswith("linux"):
        return
    try:
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGTERM)
    except (OSError, AttributeError):
        return
    if os.getppid() != int(parent):
        raise SystemExit(f"the process that started this service ({parent}) is gone")


#: What ``bimbot`` itself takes before a sub-command (``-vv`` counts twice).
TOP_LEVEL_OPTION = re.compile(r"^(-h|--help|-v+|--verbose|-q|--quiet|--version)$")


def parse_arguments(argv: list[str]) -> argparse.Namespace:
    """``argv`` parsed; an option the sub-command does not know is that sub-command's error (``bimbot
    convert: error: unrecognized arguments: --robots 3``), not the top-level parser's. Without a
    sub-command, an option ``bimbot`` does not know is named as such (argparse would only say a command
    is missing)."""
    parser = build_parser(argv)
    if not any(not word.startswith("-") for word in argv):
        unknown = [word for word in argv if not TOP_LEVEL_OPTION.match(word)]
        if unknown:
            parser.error(f"unrecognized arguments: {' '.join(unknown)}")
    args, extras = parser.parse_known_args(argv)
    if extras:
        getattr(args, "_parser", parser).error(f"unrecognized arguments: {' '.join(extras)}")
    return args


def main(argv: list[str] | None = None) -> int:
    """Parse ``argv``, run the chosen sub-command and map how it ended to the exit code."""
    argv = sys.argv[1:] if argv is None else argv
    stop_with_parent()
    args = parse_arguments(argv)
    configure_logging(log_verbosity(args.command, args.verbose, args.quiet))
    module = importlib.import_module(args._module)
    try:
        return int(module.run(args) or 0)
    except UserError as error:  # the same one-line form as a bad option's (OneLineErrorParser)
        sys.stderr.write(f"bimbot {args.command}: error: {error}\n")
        return EXIT_USER_ERROR
    except KeyboardInterrupt:
        _log.error("interrupted")
        return 130
    except Exception:  # a bug: keep the traceback for the log, not the "bad input" exit code
        _log.exception("bimbot %s %s (a bug; traceback follows)", args.command, BUG_MARK)
        return EXIT_BUG


if __name__ == "__main__":
    sys.exit(main())
