"""``bimbot agents --build OUT/ [--shard i/n]``: run the smart-component agents of a converted build.

One process runs every agent of its shard (components split by GUID, see :func:`.host.shard_of`). State
survives restarts through the shard's journal in the run folder (``RUN/state/agents-<i>of<n>.jsonl``, see
:mod:`.journal` and :mod:`bimbot.shared.run_folder`; ``--run-dir``, default ``OUT/runs/latest``);
``--fresh`` clears it. Runs until SIGTERM/SIGINT, then closes its Zenoh session and exits 0.
"""

from __future__ import annotations

import argparse
import logging
from dataclasses import replace
from pathlib import Path

from bimbot.shared.bus import add_bus_arguments
from bimbot.shared.errors import UserError
from bimbot.shared.run_folder import open_run_folder
from bimbot.shared.service_runner import resolve_build, run_service, service_bus, writable_dir

from . import app
from .agent import AgentConfig
from .host import parse_shard, shard_manifest

_log = logging.getLogger(__name__)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    defaults = AgentConfig()
    parser.add_argument(
        "--build", type=Path, required=True, metavar="OUT/", help="converted build (folder or manifest.json)"
    )
    parser.add_argument(
        "--shard", default="1/1", metavar="I/N", help="run shard I of N, split by GUID (default 1/1)"
    )
    parser.add_argument(
        "--run-dir",
        type=Path,
        default=None,
        metavar="DIR",
        help="the run's folder; the journal goes to DIR/state/ (default OUT/runs/latest, made when missing)",
    )
    parser.add_argument(
        "--max-attempts",
        type=int,
        default=defaults.max_attempts,
        help=f"placements before a component is failed (default {defaults.max_attempts})",
    )
    parser.add_argument(
        "--verify-timeout-s",
        type=float,
        default=defaults.verify_timeout_s,
        help=f"wall seconds to wait for a pose after a placement (default {defaults.verify_timeout_s:g})",
    )
    parser.add_argument(
        "--fresh", action="store_true", help="clear this shard's journal and start every agent anew"
    )
    parser.add_argument(
        "--stepped",
        action="store_true",
        help="take part in physics' lock-step (physics --step-with agents-<i>of<n>): events and poses "
        "taken at clock steps in a defined order, so a run reproduces (bimbot run does)",
    )
    add_bus_arguments(parser)


def agent_config(args: argparse.Namespace) -> AgentConfig:
    """The agents' config from the options; a UserError names an impossible value."""
    try:
        return AgentConfig(
            max_attempts=args.max_attempts,
            verify_timeout_s=args.verify_timeout_s,
        )
    except ValueError as error:
        raise UserError(str(error)) from error


def run(args: argparse.Namespace) -> int:
    """Check the options, the build and the journal folder, then run this shard's agents until stopped."""
    try:
        shard, n_shards = parse_shard(args.shard)
    except ValueError as error:
        raise UserError(str(error)) from error
    options = service_bus(args)
    config = agent_config(args)
    build = resolve_build(args.build)
    state_dir = open_run_folder(build.dir, args.run_dir).state_dir
    writable_dir(state_dir, "--run-dir")
    total = len(build.manifest.components)
    manifest = shard_manifest(build.manifest, shard, n_shards)  # the other shards' components are freed here
    _log.info(
        "shard %d/%d: %d of the build's %d components", shard, n_shards, len(manifest.components), total
    )
    if not manifest.components:
        _log.warning("shard %d/%d owns none of the %d components", shard, n_shards, total)
    return run_service(
        app.main,
        options,
        replace(build, manifest=manifest),  # this shard's components only
        config,
        shard=(shard, n_shards),
        state_dir=state_dir,
        fresh=args.fresh,
        stepped=args.stepped,
    )
