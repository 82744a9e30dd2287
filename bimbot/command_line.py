"""``bimbot``'s command line: the sub-commands, the parser, and how a bad option is said.

Every sub-command module exposes ``add_arguments(parser)`` and ``run(args) -> int``; only the chosen one is
imported (by name, when the parser is built), so ``bimbot --help`` stays fast. Apart from
:mod:`bimbot.cli`, which runs what is parsed, so that a check of a command line (``bimbot run``'s
preflight) parses it as the command would without importing the process that runs it.
"""

from __future__ import annotations

import argparse
import importlib
import re
from typing import Any, NoReturn

from bimbot import __version__

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

EXIT_USER_ERROR = 2  # bad input: one line


class OneLineErrorParser(argparse.ArgumentParser):
    """argparse, with a bad option reported as one line and exit 2: ``bimbot run: error: argument --rtf: -1
    must be zero or a positive number (see bimbot run --help)``. argparse's own ``error`` prints the whole
    usage first, a screenful for a service's options that buried the one line that matters; ``--help``
    still prints it all. Sub-command parsers are of this class too (argparse makes them of the parent's)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        # no abbreviations: ``--robot 3`` was taken for ``--robots 3`` and a 3-minute build began unasked
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

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
