"""Start bimbot services as child processes on one machine, watch them, and stop them cleanly.

Used by ``bimbot run``/``bimbot demo`` and by the integration tests. Each child is ``python -m bimbot.cli
<command> …`` with its output in its own log file, so a failure can be shown with what the service said.
"""

from __future__ import annotations

import logging
import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

_log = logging.getLogger(__name__)


def free_port() -> int:
    """A TCP port on 127.0.0.1 that was free a moment ago."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


class ServiceProcess:
    """One ``bimbot <command>`` child process logging to ``<log_dir>/<name>.log``."""

    def __init__(
        self, name: str, args: Sequence[str], log_dir: Path, env: dict[str, str] | None = None
    ) -> None:
        self.name = name
        log_dir.mkdir(parents=True, exist_ok=True)
        self.log_path = log_dir / f"{name}.log"
        self._log = self.log_path.open("ab")
        self.process = subprocess.Popen(
            [sys.executable, "-P", "-m", "bimbot.cli", *args],
            stdout=self._log,
            stderr=subprocess.STDOUT,
            env={**os.environ, **(env or {})},
        )
        _log.debug("started %s (pid %d): bimbot %s", name, self.process.pid, " ".join(args))

    def log(self) -> str:
        if not self._log.closed:
            self._log.flush()
        return self.log_path.read_text(errors="replace")

    def alive(self) -> bool:
        return self.process.poll() is None

    def wait(self, timeout_s: float | None) -> int:
        return self.process.wait(timeout=timeout_s)

    def kill(self) -> None:
        """SIGKILL: no chance to clean up, as when a host dies."""
        self.process.kill()
        self.process.wait(timeout=10)

    def stop(self, timeout_s: float = 10.0) -> int | None:
        """SIGTERM, then SIGKILL after ``timeout_s``; the exit code."""
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(timeout=timeout_s)
            except subprocess.TimeoutExpired:
                _log.warning("%s did not stop within %.0f s; killed", self.name, timeout_s)
                self.process.kill()
                self.process.wait(timeout=5)
        if not self._log.closed:
            self._log.close()
        return self.process.returncode


@contextmanager
def running(name: str, args: Sequence[str], log_dir: Path) -> Iterator[subprocess.Popen[bytes]]:
    """``bimbot <args>`` for the length of a ``with`` block (tests): its Popen, logging to
    ``<log_dir>/<name>.log``; stopped at the end (TERM, then KILL) if still running."""
    service = ServiceProcess(name, args, log_dir)
    try:
        yield service.process
    finally:
        service.stop()


def wait_until(condition: Callable[[], bool], timeout_s: float, interval_s: float = 0.05) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(interval_s)
    return False
