"""Start bimbot services as child processes on one machine, watch them, and stop them cleanly.

Used by ``bimbot run``/``bimbot demo`` and by the integration tests. Each child is ``python -m bimbot.cli
<command> …`` with its output in its own log file, so a failure can be shown with what the service said;
under ``bimbot run`` it is forked by the run's fork server instead (:mod:`bimbot.fork_server`: the same
command, without importing everything again), and started plainly when there is none.

Each child leads a process group of its own (``start_new_session``): a service's own children (the
observer's ``rerun --serve-web``) are in that group, so stopping signals the whole group and nothing is
left behind; and a Ctrl-C at the terminal reaches only ``bimbot run``, which then stops its services in
order and still writes its report, instead of every service dying at once.
"""

from __future__ import annotations

import contextlib
import logging
import os
import random
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

from bimbot.child_process import HASH_SEED, STOP_WITH_PARENT_ENV

if TYPE_CHECKING:
    from bimbot.fork_server import ForkedChild, ForkServer

_log = logging.getLogger(__name__)


EPHEMERAL_RANGE_FILE = Path("/proc/sys/net/ipv4/ip_local_port_range")
FREE_PORT_SPAN = 8000  # free_port picks among this many ports just below the kernel's ephemeral range
_port_choice = random.Random()  # seeded from the OS, whatever a caller does with the global generator


def free_port() -> int:
    """A TCP port on 127.0.0.1 that was free a moment ago, from below the kernel's ephemeral range.

    A port the kernel hands out (``bind(0)``) is one it may hand out again at once, to another process's
    outgoing connection or ``listen tcp/…:0``, before the service that was given it listens: an observer
    in the suite found its port taken ("Address already in use"). Ports below that range are only ever
    taken on purpose. Falls back to the kernel's choice when none of a few random tries is free."""
    low = _ephemeral_low()
    first = max(1024, low - FREE_PORT_SPAN)
    for _ in range(50 if low > first else 0):
        port = _port_choice.randrange(first, low)
        with socket.socket() as sock:
            try:
                sock.bind(("127.0.0.1", port))
            except OSError:
                continue
            return int(sock.getsockname()[1])
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def _ephemeral_low() -> int:
    """The first port of the kernel's ephemeral range (32768 where it cannot be read)."""
    try:
        return int(EPHEMERAL_RANGE_FILE.read_text().split()[0])
    except (OSError, ValueError, IndexError):
        return 32768


class ServiceProcess:
    """One ``bimbot <command>`` child process logging to ``<log_dir>/<name>.log``."""

    def __init__(
        self,
        name: str,
        args: Sequence[str],
        log_dir: Path,
        env: dict[str, str] | None = None,
        restart_args: Sequence[str] | None = None,
        *,
        launcher: ForkServer | None = None,
    ) -> None:
        """``restart_args``: the command line of a restart (default ``args``; the agents drop
        ``--fresh`` so they resume from their journal); ``launcher``: fork it from this server when it
        still runs."""
        self.name = name
        self._launcher = launcher
        self.args = list(args)
        self.restart_args = list(args if restart_args is None else restart_args)
        self._env = env
        log_dir.mkdir(parents=True, exist_ok=True)
        self.log_path = log_dir / f"{name}.log"
        self._log = self.log_path.open("ab")
        self.process = self._start(self.args)
        self._asked_to_stop: object | None = None  # the process SIGTERM went to (one is enough)

    def _start(self, args: Sequence[str]) -> subprocess.Popen[bytes] | ForkedChild:
        env = {**HASH_SEED, **os.environ, **(self._env or {})}
        process: subprocess.Popen[bytes] | ForkedChild | None = None
        if self._launcher is not None:
            self._log.flush()
            process = self._launcher.spawn(args, self.log_path, env)
        if process is None:
            process = subprocess.Popen(
                [sys.executable, "-P", "-m", "bimbot.cli", *args],
                stdout=self._log,
                stderr=subprocess.STDOUT,
                # the child stops when this process dies, even by SIGKILL (child_process.stop_with_parent)
                env={**env, STOP_WITH_PARENT_ENV: str(os.getpid())},
                start_new_session=True,  # its own process group: stop() reaches its children too
            )
        self.pgid = process.pid  # the group it leads
        _log.debug("started %s (pid %d): bimbot %s", self.name, process.pid, " ".join(args))
        return process

    def restart(self) -> None:
        """Start the service again (it exited): what is left of its group is killed first, and its log
        goes on in the same file after a line that says so."""
        if self.process.poll() is None:
            raise RuntimeError(f"{self.name} is still running")
        self._signal_group(signal.SIGKILL)
        if self._log.closed:
            self._log = self.log_path.open("ab")
        self._log.write(
            f"--- bimbot run: {self.name} exited ({self.process.returncode}); restarted ---\n".encode()
        )
        self._log.flush()
        self.process = self._start(self.restart_args)

    def log(self) -> str:
        if not self._log.closed:
            self._log.flush()
        return self.log_path.read_text(errors="replace")

    def alive(self) -> bool:
        return self.process.poll() is None

    def wait(self, timeout_s: float | None) -> int:
        return self.process.wait(timeout=timeout_s)

    def kill(self) -> None:
        """SIGKILL to the service and its group: no chance to clean up, as when a host dies."""
        self.process.kill()
        self.process.wait(timeout=10)
        self._signal_group(signal.SIGKILL)

    def terminate(self) -> None:
        """SIGTERM to the service's process group (it and its children), without waiting; once: a service
        restores the default handler as it finishes, and a second SIGTERM then would kill it mid-exit."""
        if self.process.poll() is None and self._asked_to_stop is not self.process:
            self._signal_group(signal.SIGTERM)
            self._asked_to_stop = self.process

    def stop(self, timeout_s: float = 10.0) -> int | None:
        """SIGTERM to the group, then SIGKILL after ``timeout_s``; the service's exit code. Whatever of
        its group is still there once the service has exited (an orphaned grandchild) is killed."""
        if self.process.poll() is None:
            self.terminate()
            try:
                self.process.wait(timeout=timeout_s)
            except subprocess.TimeoutExpired:
                _log.warning("%s did not stop within %.0f s; killed", self.name, timeout_s)
                self.process.kill()
                self.process.wait(timeout=5)
        self._signal_group(signal.SIGKILL)  # leftovers of the group, if any
        if not self._log.closed:
            self._log.close()
        return self.process.returncode

    def _signal_group(self, signum: int) -> None:
        with contextlib.suppress(ProcessLookupError, PermissionError):  # the group is gone already
            os.killpg(self.pgid, signum)


def stop_all(services: Sequence[ServiceProcess], timeout_s: float = 10.0) -> None:
    """Stop ``services`` together: SIGTERM to every group at once (last started first), then wait for
    each within one shared ``timeout_s`` (SIGKILL for the late ones). A few seconds for a whole run,
    where stopping one after another would add up every service's shutdown."""
    for service in reversed(services):
        service.terminate()
    deadline = time.monotonic() + timeout_s
    for service in reversed(services):
        service.stop(timeout_s=max(deadline - time.monotonic(), 0.1))


@contextmanager
def running(name: str, args: Sequence[str], log_dir: Path) -> Iterator[subprocess.Popen[bytes]]:
    """``bimbot <args>`` for the length of a ``with`` block (tests): its Popen, logging to
    ``<log_dir>/<name>.log``; stopped at the end (TERM, then KILL) if still running."""
    service = ServiceProcess(name, args, log_dir)
    assert isinstance(service.process, subprocess.Popen)  # no launcher: a plain process
    try:
        yield service.process
    finally:
        service.stop()
