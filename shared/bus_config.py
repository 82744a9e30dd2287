"""How a service joins the bus: its options, its Zenoh configuration, and opening the session.

Defaults (embedded, no router needed beyond ``bimbot bus``): mode ``peer``, connect to the site's bus
endpoint on loopback (``tcp/127.0.0.1:7447``), listen on a free loopback port so peers can reach each
other directly, multicast scouting off (nothing leaves the machine). In ``docker compose`` every service
connects to the ``bus`` service, a small Python process in Zenoh ``router`` mode (``bimbot bus``).

Options, with environment variables as fallbacks (so compose files stay short)::

    --mode    peer|client|router     BIMBOT_ZENOH_MODE      (default peer)
    --connect ENDPOINT (repeatable)  BIMBOT_ZENOH_CONNECT   (comma-separated; default tcp/127.0.0.1:7447)
    --listen  ENDPOINT (repeatable)  BIMBOT_ZENOH_LISTEN    (comma-separated; default tcp/127.0.0.1:0)
    --bus-config FILE                BIMBOT_ZENOH_CONFIG    (a Zenoh JSON5 config file; default none)
    --site    SITE                   BIMBOT_SITE            (default: from the manifest)

``--bus-config`` is loaded first (``zenoh.Config.from_file``), as zenoh's own examples do, and bimbot's
options go on top: mode, endpoints and multicast scouting off. The file's ``mode`` and ``connect``/``listen``
endpoints stand in for the defaults when no option or environment variable gives them; everything else in
it (credentials, access control, TLS, timeouts) is kept. On a secured bus it is the per-service file that
``bimbot bus-credentials`` writes (:mod:`bimbot.shared.bus_credentials`): the service's user and password
and ``mode: "client"``. A session with credentials gives up joining after :data:`SECURE_JOIN_TIMEOUT_S`
(unless the file sets ``connect/timeout_ms``) with one line naming the user: a wrong password looks to a
client exactly like a router that is not there, and waiting forever for either helps nobody.

Opening a session that cannot be opened (a router's port in use, a bad endpoint, credentials refused) is
the user's setup, not a bug: an :class:`~bimbot.shared.errors.InputError`, one line and exit 2.
"""

from __future__ import annotations

import argparse
import json
import os
import re
from dataclasses import dataclass
from pathlib import Path

import zenoh

from .errors import InputError

DEFAULT_ENDPOINT = "tcp/127.0.0.1:7447"
DEFAULT_LISTEN = "tcp/127.0.0.1:0"
MODES = ("peer", "client", "router")
SECURE_JOIN_TIMEOUT_S = 30.0  # a session with credentials gives up joining after this long (wall s)
# Zenoh retries an endpoint that refused after 1 s at first: a session opened while its router is still
# starting (bimbot run opens its monitor right after starting the router) waited 1.0 s for a router that
# was listening after 0.25 s. Retry fast at first, then back off to Zenoh's usual pace.
CONNECT_RETRY = {"period_init_ms": 50, "period_max_ms": 4000, "period_increase_factor": 2}
# Zenoh spends ``scouting/delay`` (500 ms) of every session's opening looking for peers to connect to before
# it returns, multicast scouting on or off. A bimbot session finds its peers through the router it connects
# to (gossip), whenever they come, so it waits for none: each service, the router and bimbot run's own
# session opened 0.5 s later than they could, before every run's first step and in every test.
SCOUTING_DELAY_MS = 0
_RUST_LOCATION = re.compile(r"\s+at /\S+\.rs:\d+\.?")


@dataclass(frozen=True)
class BusOptions:
    """How a service joins the bus: Zenoh mode, endpoints, and an optional Zenoh config file under them."""

    mode: str = "peer"
    connect: tuple[str, ...] = (DEFAULT_ENDPOINT,)
    listen: tuple[str, ...] = (DEFAULT_LISTEN,)
    config_file: Path | None = None  # a Zenoh JSON5 config loaded first (--bus-config); None: defaults


@dataclass(frozen=True)
class FileSettings:
    """What a ``--bus-config`` file says about the options bimbot sets itself (None: it says nothing)."""

    mode: str | None = None
    connect: tuple[str, ...] | None = None
    listen: tuple[str, ...] | None = None


def _env_list(name: str) -> list[str] | None:
    value = os.environ.get(name)
    return [item.strip() for item in value.split(",") if item.strip()] if value else None


def add_bus_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``--mode/--connect/--listen/--bus-config`` (with BIMBOT_ZENOH_* environment fallbacks)."""
    group = parser.add_argument_group("bus (Zenoh)")
    group.add_argument(
        "--mode", choices=MODES, default=None, help="Zenoh mode (env BIMBOT_ZENOH_MODE; default peer)"
    )
    group.add_argument(
        "--connect", action="append", default=None, metavar="ENDPOINT", help="endpoint to connect to"
    )
    group.add_argument(
        "--listen", action="append", default=None, metavar="ENDPOINT", help="endpoint to listen on"
    )
    add_bus_config_argument(group)


def add_bus_config_argument(parser: argparse._ActionsContainer) -> None:
    """``--bus-config FILE`` (env BIMBOT_ZENOH_CONFIG): a Zenoh config file under bimbot's bus options."""
    parser.add_argument(
        "--bus-config",
        type=Path,
        default=None,
        metavar="FILE",
        help="a Zenoh JSON5 config file, bimbot's bus options applied on top (env BIMBOT_ZENOH_CONFIG); "
        "on a secured bus this service's file from bimbot bus-credentials",
    )


def bus_config_file(args: argparse.Namespace) -> Path | None:
    """``--bus-config``, else BIMBOT_ZENOH_CONFIG, else None."""
    given = getattr(args, "bus_config", None) or os.environ.get("BIMBOT_ZENOH_CONFIG")
    return Path(given) if given else None


def load_config_file(path: Path) -> zenoh.Config:
    """The Zenoh config in ``path``; an :class:`InputError` naming the file when it cannot be used."""
    if not path.is_file():
        raise InputError(f"--bus-config {path}: no such file")
    try:
        return zenoh.Config.from_file(str(path))
    except zenoh.ZError as error:
        raise InputError(f"--bus-config {path}: not a usable Zenoh config: {zenoh_reason(error)}") from None


def file_settings(path: Path | None) -> FileSettings:
    """The mode and endpoints ``path`` sets (per-mode endpoint tables and Zenoh's defaults count as unset)."""
    if path is None:
        return FileSettings()
    config = load_config_file(path)
    mode, connect, listen = (
        json.loads(config.get_json(key)) for key in ("mode", "connect/endpoints", "listen/endpoints")
    )
    return FileSettings(
        mode=str(mode) if mode is not None else None,
        connect=tuple(connect) if isinstance(connect, list) and connect else None,
        listen=tuple(listen) if isinstance(listen, list) else None,
    )


def bus_options(args: argparse.Namespace) -> BusOptions:
    """Options from parsed arguments, then the environment, then the ``--bus-config`` file, then the
    defaults. A ValueError (or :class:`InputError`) for a bad mode or an unusable file."""
    config_file = bus_config_file(args)
    from_file = file_settings(config_file)
    mode = args.mode or os.environ.get("BIMBOT_ZENOH_MODE") or from_file.mode or "peer"
    if mode not in MODES:
        raise ValueError(f"BIMBOT_ZENOH_MODE={mode!r}: expected one of {', '.join(MODES)}")
    connect = args.connect or _env_list("BIMBOT_ZENOH_CONNECT") or from_file.connect
    listen = args.listen or _env_list("BIMBOT_ZENOH_LISTEN") or from_file.listen
    if connect is None:
        connect = [] if mode == "router" else [DEFAULT_ENDPOINT]
    if listen is None:
        listen = [DEFAULT_ENDPOINT] if mode == "router" else ([] if mode == "client" else [DEFAULT_LISTEN])
    return BusOptions(mode=mode, connect=tuple(connect), listen=tuple(listen), config_file=config_file)


def zenoh_reason(error: Exception) -> str:
    """Zenoh's error text without the Rust source locations it appends (`` at /…/x.rs:61.``)."""
    text = _RUST_LOCATION.sub("", str(error))
    return " ".join(text.split()).rstrip(". ") or type(error).__name__


def _insert_endpoints(config: zenoh.Config, option: str, endpoints: tuple[str, ...]) -> None:
    """Set ``<option>/endpoints``; an InputError naming the first endpoint Zenoh cannot parse."""
    try:
        config.insert_json5(f"{option}/endpoints", json.dumps(list(endpoints)))
    except zenoh.ZError:
        for endpoint in endpoints:
            try:
                zenoh.Config().insert_json5(f"{option}/endpoints", json.dumps([endpoint]))
            except zenoh.ZError:
                raise InputError(
                    f"--{option} {endpoint!r}: not a Zenoh endpoint (<protocol>/<address>, e.g. "
                    f"{DEFAULT_ENDPOINT})"
                ) from None
        raise


def bus_user(config: zenoh.Config) -> str | None:
    """The user a config authenticates as (``transport/auth/usrpwd/user``), None without credentials."""
    user = json.loads(config.get_json("transport/auth/usrpwd/user"))
    return str(user) if user is not None else None


# Zenoh drops a message (congestion control "drop", every put's default) when its link's queue stays full
# for 1 ms. On a loaded machine a sender's or the router's queue was full that long while its reader was
# not scheduled: a task or an event then came only with its resend, 2 s later, and a lock-step run took it
# at another step than its twin run (the same seed built differently). A queue that stays full for 1 s is
# a reader that is gone, not a busy one.
DROP_WAIT_KEY = "transport/link/tx/queue/congestion_control/drop/wait_before_drop"
ZENOH_DROP_WAIT_US = 1_000
DROP_WAIT_US = 1_000_000
# A router gives up a query it routes after ``queries_default_timeout`` (10 s), whatever the querier's own
# timeout: a placement physics answers after its settling and connection (20 s of sim time) was refused
# "no reply" by the run's router on a loaded machine. The querier's timeout is the bound that counts.
ROUTED_QUERY_TIMEOUT_MS = 900_000


def zenoh_config(options: BusOptions) -> zenoh.Config:
    """A Zenoh config for ``options``: the config file (if any), then explicit endpoints, multicast
    scouting off, no scouting delay unless the file sets one. Raises :class:`InputError` for an unusable
    file or endpoint."""
    config = load_config_file(options.config_file) if options.config_file else zenoh.Config()
    config.insert_json5("mode", json.dumps(options.mode))
    _insert_endpoints(config, "connect", options.connect)
    _insert_endpoints(config, "listen", options.listen)
    config.insert_json5("scouting/multicast/enabled", "false")
    if json.loads(config.get_json("scouting/delay")) is None:
        config.insert_json5("scouting/delay", str(SCOUTING_DELAY_MS))
    if options.mode != "router" and json.loads(config.get_json("connect/timeout_ms")) is None:
        if bus_user(config) is not None:
            # Secured: a refused password looks like an absent router; give up after a bound, not never.
            config.insert_json5("connect/timeout_ms", str(int(SECURE_JOIN_TIMEOUT_S * 1000)))
            config.insert_json5("connect/exit_on_failure", "true")
        else:
            # Keep retrying the bus endpoint at start-up instead of failing while the router is starting.
            config.insert_json5("connect/timeout_ms", "-1" if options.connect else "0")
            config.insert_json5("connect/exit_on_failure", "false")
    if options.mode != "router" and options.connect and json.loads(config.get_json("connect/retry")) is None:
        config.insert_json5("connect/retry", json.dumps(CONNECT_RETRY))
    if json.loads(config.get_json(DROP_WAIT_KEY)) == ZENOH_DROP_WAIT_US:  # not set by the file
        config.insert_json5(DROP_WAIT_KEY, str(DROP_WAIT_US))
    if json.loads(config.get_json("queries_default_timeout")) is None:
        config.insert_json5("queries_default_timeout", str(ROUTED_QUERY_TIMEOUT_MS))
    return config


def open_session(options: BusOptions) -> zenoh.Session:
    """Open a session; use it as a context manager (an unclosed session with callbacks hangs at exit).

    A session that cannot be opened is the user's setup, not a bug: an :class:`InputError` in one line (a
    router's port in use, credentials refused or no router within the bound, a bad endpoint)."""
    config = zenoh_config(options)
    try:
        return zenoh.open(config)
    except zenoh.ZError as error:
        raise InputError(_open_failure(options, config, error)) from None


def _open_failure(options: BusOptions, config: zenoh.Config, error: zenoh.ZError) -> str:
    reason = zenoh_reason(error)
    if "Address already in use" in reason:
        return (
            f"cannot listen on {', '.join(options.listen)}: the address is in use (another bus on that port? "
            "give another with --listen)"
        )
    if options.mode == "router" or "listener" in reason:
        return f"cannot listen on {', '.join(options.listen)}: {reason}"
    user = bus_user(config)
    if user is not None and options.connect:
        timeout_ms = json.loads(config.get_json("connect/timeout_ms"))
        within = (
            f" within {timeout_ms / 1000:g} s"
            if isinstance(timeout_ms, int | float) and timeout_ms > 0
            else ""
        )
        return (
            f"could not join the bus at {', '.join(options.connect)} as user {user!r}{within}: no router "
            f"answers there, or it refused this user's password (--bus-config {options.config_file})"
        )
    return (
        f"could not join the bus ({options.mode}, connect {', '.join(options.connect) or 'none'}): {reason}"
    )
