"""One runner for every service's command: the stop event, bus options, the build path and the call of main.

Every ``bimbot <service>`` command (``bus``, ``physics``, ``agents``, ``planner``, ``robot``, ``observe``,
``watch``) does the same four things, once, here:

* :func:`stop_on_signals`: SIGINT and SIGTERM set a :class:`threading.Event` that the service's loop
  watches (it then closes its Zenoh session and returns), and the previous handlers come back afterwards;
* :func:`service_bus`: the ``--mode/--connect/--listen/--bus-config`` options (and their environment
  fallbacks), a bad value, endpoint or config file being a :class:`~bimbot.shared.errors.UserError` (one
  line, exit 2);
* :func:`resolve_build`: ``--build`` may name the build folder or its ``manifest.json``; both give the folder
  and the parsed manifest (a missing or broken manifest is a UserError);
* :func:`run_service`: calls the service's ``app.main(…, stop=…)`` with the stop event installed and returns
  its exit code. Every ``app.main`` takes the event as its parameter ``stop``.

User input is checked in the command before :func:`run_service`; what goes wrong inside is a bug and keeps
its traceback (see :func:`bimbot.cli.main`).
"""

from __future__ import annotations

import argparse
import logging
import os
import resource
import sys
import threading
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from bimbot.shared.bus import BusOptions, bus_options, zenoh_config
from bimbot.shared.errors import UserError
from bimbot.shared.manifest import Manifest, load_manifest
from bimbot.shared.output_paths import check_writable_dir
from bimbot.shared.signal_event import STOP_SIGNALS, stop_handlers

PRELOADED_ENV = "BIMBOT_PRELOADED_MB"  # set by bimbot.fork_server in a child: its server's resident MB

_log = logging.getLogger(__name__)


@contextmanager
def stop_on_signals(signums: Sequence[int] = STOP_SIGNALS) -> Iterator[threading.Event]:
    """An event that ``signums`` set (instead of killing the process) for the length of the ``with`` block.

    The handlers only have the event set (by a thread: :mod:`bimbot.shared.signal_event`), so the service
    ends its loop itself and closes its session (an unclosed Zenoh session hangs at exit). The previous
    handlers are restored on the way out. Outside the main thread (where Python allows no handlers) the
    event is only set by whoever holds it.
    """
    stop = threading.Event()
    with stop_handlers(stop, signums):  # a handler must not take the event's lock (shared/signal_event.py)
        yield stop


def service_bus(args: argparse.Namespace) -> BusOptions:
    """The bus options of a command (arguments, then environment, then the ``--bus-config`` file, then
    defaults); a UserError when bad, a bad config file or endpoint included (checked here, before the
    service starts)."""
    try:
        options = bus_options(args)
    except ValueError as error:
        raise UserError(str(error)) from None
    zenoh_config(options)  # raises InputError (a UserError) for an unusable file or endpoint
    return options


@dataclass(frozen=True)
class BuildInput:
    """A converted build as a command was given it: its folder and its manifest."""

    dir: Path
    manifest: Manifest


def resolve_build(path: Path) -> BuildInput:
    """``--build``: the build folder or its manifest file → (folder, manifest); a UserError when unusable."""
    path = Path(path)
    manifest = load_manifest(path)
    return BuildInput(path if path.is_dir() else path.parent, manifest)


def run_service(main: Callable[..., int | None], /, *args: object, **kwargs: object) -> int:
    """``main(*args, stop=<event>, **kwargs)`` with SIGINT/SIGTERM setting the event; its exit code. Its
    peak memory and CPU time are logged as it ends (``bench/build.py`` reads them per service: on two cores
    shared by a dozen services, where the CPU goes is where the wall time goes)."""
    with stop_on_signals() as stop:
        code = int(main(*args, stop=stop, **kwargs) or 0)
        # a service that ran (a user error stays one line); a forked one shares what its fork server
        # loaded. Logged while a late SIGTERM still only sets the event.
        shared = os.environ.get(PRELOADED_ENV)
        note = f" (forked from a {shared} MB fork server: what they share counts in both)" if shared else ""
        times = os.times()
        _log.info("peak memory %.0f MB%s; CPU %.1f s", peak_rss_mb(), note, times.user + times.system)
    return code


def process_status_mb(field: str) -> float | None:
    """A memory figure of this process from Linux's ``/proc/self/status`` (``VmHWM``, ``VmRSS``) in MB;
    None where there is none."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith(f"{field}:"):
                return float(line.split()[1]) / 1024.0
    except OSError:
        pass
    return None


def peak_rss_mb() -> float:
    """This process's peak resident memory (MB): Linux's ``VmHWM`` (``ru_maxrss`` keeps the peak of the
    process it was forked from across the exec, so every service reported its parent's), else ``ru_maxrss``
    (kB on Linux, bytes on macOS)."""
    peak_mb = process_status_mb("VmHWM")
    if peak_mb is not None:
        return peak_mb
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / (1024.0 * 1024.0) if sys.platform == "darwin" else peak / 1024.0


def writable_dir(path: Path, what: str) -> Path:
    """``path`` created when missing and writable (journals, recordings, reports), checked before a service
    starts; a UserError naming ``what`` (the option) otherwise (:func:`~bimbot.shared.output_paths.
    check_writable_dir` first, so a parent that is a file or a read-only mount is named as such)."""
    check_writable_dir(path, what)
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise UserError(f"{what} {path}: cannot create the folder ({error.strerror or error})") from None
    if not os.access(path, os.W_OK | os.X_OK):
        raise UserError(f"{what} {path}: the folder is not writable")
    return path
