"""``bimbot bus``: the site's Zenoh router, a small Python process in Zenoh ``router`` mode.

Every other service connects to it (``--connect tcp/127.0.0.1:7447`` by default). zenohd is not
installable everywhere bimbot runs, so the router is the Python binding's own router mode. It runs until
it is interrupted (SIGINT/SIGTERM), or for ``--seconds`` when given.

``--bus-config FILE`` (env BIMBOT_ZENOH_CONFIG) loads a Zenoh config first; on a secured bus it is the
``router.json5`` of ``bimbot bus-credentials``: the password dictionary and the access control that lets
only the right service speak (:mod:`bimbot.shared.bus_access`). Every service must then join in Zenoh
``client`` mode, since the router enforces the rules on its own links only. A ``--listen`` that is not an
endpoint, or a port already in use, is one line and exit 2.
"""

from __future__ import annotations

import argparse
import json
import logging
import threading

from bimbot.shared.bus import DEFAULT_ENDPOINT, BusOptions, open_session, zenoh_config
from bimbot.shared.bus_config import add_bus_config_argument, bus_config_file, file_settings
from bimbot.shared.service_runner import run_service
from bimbot.shared.signal_event import wait_stop

_log = logging.getLogger(__name__)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--listen",
        action="append",
        default=None,
        metavar="ENDPOINT",
        help=f"endpoint (default: the config file's, else {DEFAULT_ENDPOINT})",
    )
    parser.add_argument("--connect", action="append", default=None, metavar="ENDPOINT", help="other routers")
    add_bus_config_argument(parser)
    parser.add_argument(
        "--seconds", type=float, default=None, help="stop after this long (default: run until stopped)"
    )


def router_options(args: argparse.Namespace) -> BusOptions:
    """The router's options: ``--listen/--connect``, else the config file's endpoints, else the defaults;
    checked (an InputError for a bad endpoint or config file)."""
    config_file = bus_config_file(args)
    from_file = file_settings(config_file)
    options = BusOptions(
        mode="router",
        connect=tuple(args.connect or from_file.connect or ()),
        listen=tuple(args.listen or from_file.listen or (DEFAULT_ENDPOINT,)),
        config_file=config_file,
    )
    zenoh_config(options)
    return options


def access_summary(options: BusOptions) -> str:
    """How the router lets services in, for its first log line."""
    config = zenoh_config(options)
    acl = json.loads(config.get_json("access_control"))
    dictionary = json.loads(config.get_json("transport/auth/usrpwd/dictionary_file"))
    if not acl.get("enabled"):
        return "open bus (no access control)"
    users = sorted({name for subject in acl.get("subjects", []) for name in subject.get("usernames", [])})
    return (
        f"access control on (default {acl.get('default_permission')}, {len(users)} users), "
        f"passwords from {dictionary or 'nowhere: every client is refused'}"
    )


def main(options: BusOptions, stop: threading.Event, seconds: float | None = None) -> None:
    """Route until ``stop`` is set (or ``seconds`` have passed), then close the session."""
    with open_session(options) as session:
        _log.info(
            "bus router %s listening on %s: %s",
            session.zid(),
            ", ".join(options.listen),
            access_summary(options),
        )
        wait_stop(stop, seconds)  # in slices: a signal is handled when the main thread runs
    _log.info("bus router stopped")


def run(args: argparse.Namespace) -> int:
    """Run the router until SIGINT/SIGTERM (or ``--seconds``); exit 0 (2 for a bad endpoint, a port in
    use or an unusable config file)."""
    return run_service(main, router_options(args), seconds=args.seconds)
