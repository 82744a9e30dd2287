"""Everything ``bimbot run`` can check before it starts a service: the user's input, one line, exit 2.

A service that rejects its input exits 2 with one line in its log; under ``bimbot run`` that used to look
like a failed build ("0/28 constructed", exit 1) after the other services had started. So
:func:`check_run_input` runs first, in ``bimbot run``'s own process, and checks what every service would
check, with the services' own code:

* the build: a readable manifest (folder or ``manifest.json``) with components;
* the run folder: ``--run-dir``, or ``BUILD/runs/`` when none is given, can be written (a read-only build
  needs ``--run-dir`` elsewhere: the one line says so);
* each service's command line exactly as :func:`bimbot.run.commands.service_commands` builds it, parsed by
  that service's parser and checked by its option checks (physics' config, the robots' execution config, the
  planner's options, the observer's ports, the agents' tolerances);
* the planner's sequence: the ``--sequence`` file exists and is a sequence of this build's components
  (unknown GUIDs, cycles and unreadable XML are the planner's :class:`~bimbot.services.planner.sources.
  PlanError`), or the build's own ``sequence.xml``, or the support graph for ``--derive``.

Nothing here starts a process, opens the bus or leaves a file behind (the run folder's check makes and
removes an empty folder: :mod:`bimbot.shared.output_paths`). The first two need none of the services' code
(:func:`check_build_and_run_folder`): ``bimbot run`` makes them at once, before it waits for the fork
server that has that code loaded (:mod:`bimbot.forked_check`), so a wrong folder is said in a blink.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import logging
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from bimbot.run.commands import service_commands
from bimbot.shared.errors import UserError
from bimbot.shared.manifest import require_components
from bimbot.shared.output_paths import check_writable_dir
from bimbot.shared.run_folder import RUN_DIR_HINT, RunFolder, runs_dir
from bimbot.shared.service_runner import BuildInput, resolve_build

if TYPE_CHECKING:
    from bimbot.run.options import RunOptions


PLACEHOLDER_ENDPOINT = "tcp/127.0.0.1:7447"  # the real port is picked when the run starts
PLACEHOLDER_RUN = RunFolder(Path("runs") / "preflight")  # the run folder is made when the run starts


def check_run_input(build: Path, options: RunOptions) -> BuildInput:
    """Raise a :class:`UserError` (one line) for any input a service of the run would reject; the build."""
    checked = check_build_and_run_folder(build, options)
    commands = service_commands(build, PLACEHOLDER_ENDPOINT, options, PLACEHOLDER_RUN)
    # the planner's sequence first: the input a user gets wrong most
    for name, arguments in sorted(commands, key=lambda command: command[1][0] != "planner"):
        kind = arguments[0]
        args = parse_service_arguments(name, arguments)
        check = SERVICE_CHECKS.get(kind)
        if check is not None:
            check(args, checked)
    return checked


def check_build_and_run_folder(build: Path, options: RunOptions) -> BuildInput:
    """The checks that need none of the services' code: a build with components, a run folder that can be
    made (a :class:`UserError`, one line); the build."""
    checked = resolve_build(build)
    require_components(build, checked.manifest)
    check_run_folder(checked.dir, options.run_dir)
    return checked


def check_run_folder(build_dir: Path, run_dir: Path | None) -> None:
    """The run's output folder can be made: ``--run-dir``, else ``BUILD/runs/`` (a UserError: one line)."""
    if run_dir is not None:
        check_writable_dir(run_dir, "--run-dir")
    else:
        check_writable_dir(runs_dir(build_dir), "run folder", RUN_DIR_HINT)


def parse_service_arguments(name: str, arguments: list[str]) -> argparse.Namespace:
    """``arguments`` parsed by the service's own parser; a UserError with argparse's message when bad."""
    from bimbot.command_line import build_parser

    parser = build_parser(arguments)
    errors = io.StringIO()
    try:
        with contextlib.redirect_stderr(errors):
            return parser.parse_args(arguments)
    except SystemExit:
        message = errors.getvalue().strip().splitlines()
        raise UserError(f"{name}: {message[-1] if message else 'invalid arguments'}") from None


def _check_physics(args: argparse.Namespace, _build: BuildInput) -> None:
    from bimbot.services.physics.cli import sim_config

    sim_config(args)


def _check_agents(args: argparse.Namespace, _build: BuildInput) -> None:
    from bimbot.services.component_agents.cli import agent_config

    agent_config(args)


def _check_planner(args: argparse.Namespace, build: BuildInput) -> None:
    from bimbot.services.planner.cli import checked_source, planner_options
    from bimbot.services.planner.sources import load_plan

    planner_options(args)
    sources_log = logging.getLogger(load_plan.__module__)
    level = sources_log.level
    sources_log.setLevel(logging.WARNING)  # the planner says what it plans in its own log, once
    try:
        load_plan(build.manifest, build.dir, checked_source(args))  # a PlanError names what is wrong
    finally:
        sources_log.setLevel(level)


def _check_robot(args: argparse.Namespace, _build: BuildInput) -> None:
    from bimbot.services.robot.cli import executor_config

    executor_config(args)


def _check_observer(args: argparse.Namespace, _build: BuildInput) -> None:
    from bimbot.services.observer.cli import check_options

    check_options(args)


# the first word of a service's command line → its option checks
SERVICE_CHECKS: dict[str, Callable[[argparse.Namespace, BuildInput], None]] = {
    "physics": _check_physics,
    "agents": _check_agents,
    "planner": _check_planner,
    "robot": _check_robot,
    "observe": _check_observer,
}
