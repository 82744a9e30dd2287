"""``bimbot bus``: the site's Zenoh router, a small Python process in Zenoh ``router`` mode.

Every other service connects to it (``--connect tcp/127.0.0.1:7447`` by default). zenohd is not
installable everywhere bimbot runs, so the router is the Python binding's own router mode. It runs until
it is interrupted (SIGINT/SIGTERM), or for ``--seconds`` when given.
"""

from __future__ import annotations

import argparse
import logging
import threading

from bimbot.shared.bus import DEFAULT_ENDPOINT, BusOptions, open_session
from bimbot.shared.service_runner import run_service

_log = logging.getLogger(__name__)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--listen",
        action="append",
        default=None,
        metavar="ENDPOINT",
        help=f"endpoint (default {DEFAULT_ENDPOINT})",
    )
    parser.add_argument("--connect", action="append", default=[], metavar="ENDPOINT", help="other routers")
    parser.add_argument(
        "--seconds", type=float, default=None, help="stop after this long (default: run until stopped)"
    )


def main(options: BusOptions, stop: threading.Event, seconds: float | None = None) -> None:
    """Route until ``stop`` is set (or ``seconds`` have passed), then close the session."""
    with open_session(options) as session:
        _log.info("bus router %s listening on %s", session.zid(), ", ".join(options.listen))
        stop.wait(seconds)
    _log.info("bus router stopped")


def run(args: argparse.Namespace) -> int:
    """Run the router until SIGINT/SIGTERM (or ``--seconds``); exit 0."""
    options = BusOptions(
        mode="router", connect=tuple(args.connect), listen=tuple(args.listen or [DEFAULT_ENDPOINT])
    )
    return run_service(main, options, seconds=args.seconds)
