"""Start services by forking a process that has imported them already: a run's services start in a blink.

Each service of ``bimbot run`` is a Python process, and most of its start-up is imports (numpy, scipy,
numba, pybullet, pydantic, zenoh: 0.4–0.6 s of CPU for physics, a robot or the planner) and loading its
compiled kernels. Five to seven processes doing that at once on two cores held the site's clock for 1.5 s
before the first step of every run, and for longer with more robots. So ``bimbot run`` starts one *fork
server* first: a process that imports every service's code and loads the kernels once (overlapping the
run's own checks), then forks a child per service. A forked child runs ``bimbot <command> …`` exactly as a
``python -m bimbot.cli`` process would (:func:`bimbot.cli.main`, its own session and process group, its
output in its log file, stopped with its parent), having imported nothing itself.

Protocol, one JSON object per line: the run writes ``{"args", "log", "env", "cwd"}`` to the server's stdin
and reads ``{"pid"}`` back; when a child exits the server writes ``{"exited": pid, "code": c}`` (``-N``:
killed by signal N, as :class:`subprocess.Popen` reports it). :class:`ForkedChild` is the run's handle on
such a child with ``Popen``'s ``pid``/``poll``/``wait``/``kill``/``send_signal``. A server that cannot start
or dies is no error: :mod:`bimbot.supervisor` then starts services as plain processes
(``BIMBOT_FORK_SERVER=0`` does that always). With ``BIMBOT_WARM_FORK_SERVER=SOCKET`` the run takes a
session of a warm server shared by many runs instead of starting its own (:mod:`bimbot.warm_fork_server`):
the same protocol, without the preload. A request ``{"check", "payload", …}`` asks for ``bimbot run``'s
input check in a child instead (:mod:`bimbot.forked_check`). This module is the run's side; the server's
own process is :mod:`bimbot.fork_server_process`.

Fork safety: the server imports modules and runs numba kernels, nothing else: no bus session, no physics
client, no thread of its own (numpy's BLAS pool re-initialises after a fork). Python's ``random`` reseeds
in a child by itself; numpy's global generator is reseeded in each child. ``gc.freeze()`` keeps the garbage
collector from touching (and so copying) every preloaded object in every child.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import IO, Any

_log = logging.getLogger(__name__)

FORK_SERVER_ENV = "BIMBOT_FORK_SERVER"  # "0": start every service as a plain process
SPAWN_TIMEOUT_S = 120.0  # a fresh clone compiles the kernels first (numba has no cache yet)
SLOW_START_S = 10.0  # a check not answered by then: the user is told why the run has not started yet
CHECK_TIMEOUT_S = SPAWN_TIMEOUT_S  # the same preload, then a check of under a second


class ForkedChild:
    """A service forked by the server: the parts of :class:`subprocess.Popen` the supervisor uses."""

    def __init__(self, server: ForkServer, pid: int) -> None:
        self._server = server
        self.pid = pid
        self.returncode: int | None = None

    def poll(self) -> int | None:
        if self.returncode is None:
            self.returncode = self._server.exit_code(self.pid)
        return self.returncode

    def wait(self, timeout: float | None = None) -> int:
        code = self._server.wait_exit(self.pid, timeout)
        if code is None:
            raise subprocess.TimeoutExpired(f"forked service {self.pid}", timeout or 0.0)
        self.returncode = code
        return code

    def send_signal(self, signum: int) -> None:
        if self.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                os.kill(self.pid, signum)

    def kill(self) -> None:
        self.send_signal(signal.SIGKILL)


class ForkServer:
    """The run's side of a fork server: start it, ask it for children, learn how they ended."""

    def __init__(self, say: Callable[[str], None] = _log.info) -> None:
        """Start the server; it preloads while the run checks its input (its log: :meth:`attach_log`).
        ``say`` gets the one line a user waiting on a slow first start must see (the run's stdout)."""
        self._say = say
        from bimbot.child_process import HASH_SEED, STOP_WITH_PARENT_ENV
        from bimbot.warm_fork_server import WarmSession, connect

        # a session of a warm server the environment names (loaded already), else a server of its own
        self._process: WarmSession | subprocess.Popen[bytes] = connect() or subprocess.Popen(
            [sys.executable, "-P", "-m", "bimbot.fork_server_process"],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            env={**HASH_SEED, **os.environ, STOP_WITH_PARENT_ENV: str(os.getpid())},  # children hash alike
            start_new_session=True,  # a Ctrl-C at the terminal reaches bimbot run only
        )
        self._changed = threading.Condition()
        self._pids: list[int] = []  # answers to spawn requests, in order
        self._checks: dict[str, dict[str, Any]] = {}  # answers to check requests, by token ({}: none came)
        self._exits: dict[int, int] = {}
        self._gone = False  # the server's stdout closed: it is dead, no more answers come
        self._lock = threading.Lock()  # one spawn request at a time
        self._log: IO[bytes] | None = None
        self._asked = False  # a request was sent: the server has preloaded, or answers once it has
        self._said: list[bytes] = []  # its stderr before the run's log folder exists
        self._threads = [
            threading.Thread(target=target, name=f"fork-server-{name}", daemon=True)
            for name, target in (("answers", self._read), ("log", self._copy_log))
        ]
        for thread in self._threads:
            thread.start()

    def attach_log(self, path: Path) -> None:
        """Write what the server said so far, and says from now on, to ``path``."""
        with self._changed:
            self._log = path.open("ab")
            self._log.writelines(self._said)
            self._log.flush()
            self._said.clear()

    @property
    def usable(self) -> bool:
        return not self._gone and self._process.poll() is None

    def spawn(self, args: Sequence[str], log_path: Path, env: Mapping[str, str]) -> ForkedChild | None:
        """Fork ``bimbot <args>`` logging to ``log_path``; None when the server is gone (start it plainly)."""
        request = {"args": list(args), "log": str(log_path), "env": dict(env), "cwd": os.getcwd()}
        with self._lock:
            if not self._send(request):
                return None
            deadline = time.monotonic() + SPAWN_TIMEOUT_S
            with self._changed:
                while not self._pids and not self._gone and time.monotonic() < deadline:
                    self._changed.wait(timeout=0.5)
                if not self._pids:
                    _log.warning("the fork server did not answer: services start as plain processes")
                    self._gone = True
                    return None
                return ForkedChild(self, self._pids.pop(0))

    def check(self, request: dict[str, Any], timeout_s: float | None = None) -> dict[str, Any] | None:
        """Have a child of the server run the input check ``request`` asks for (:mod:`bimbot.forked_check`);
        its answer, or None when none comes: the server is gone, the child ended without answering, or
        nothing came in ``timeout_s`` (:data:`CHECK_TIMEOUT_S`; a child hung, say on a lock a fork copied
        held): the run then checks in its own process."""
        token = request["check"]
        timeout_s = CHECK_TIMEOUT_S if timeout_s is None else timeout_s
        with self._lock:
            if not self._send(request):
                return None
            asked = time.monotonic()
            deadline, said = asked + timeout_s, False
            with self._changed:
                while token not in self._checks and not self._gone:
                    now = time.monotonic()
                    left = deadline - now
                    if left <= 0:
                        _log.info(  # nothing is wrong: the run does the same check itself meanwhile
                            "the services' libraries are still loading after %.0f s (a busy machine): the "
                            "run checks its input itself meanwhile",
                            timeout_s,
                        )
                        return None
                    if not said and now - asked >= SLOW_START_S:
                        said = True  # a first start after setup compiles the kernels (numba): minutes
                        self._say(
                            "loading the simulation libraries (1-2 min on the first start after setup; "
                            "longer than usual on a busy machine)"
                        )
                    self._changed.wait(timeout=min(left, 0.5))
                return self._checks.pop(token, None) or None

    def _send(self, request: dict[str, Any]) -> bool:
        """Write one request line (under ``_lock``); False when the server is gone."""
        if not self.usable:
            return False
        assert self._process.stdin is not None
        self._asked = True
        try:
            self._process.stdin.write(json.dumps(request).encode() + b"\n")
            self._process.stdin.flush()
        except (BrokenPipeError, OSError):
            return False
        return True

    def exit_code(self, pid: int) -> int | None:
        """How the child ended (None: still running)."""
        with self._changed:
            if pid not in self._exits and self._gone and not _exists(pid):
                # its server died, so the kernel sent it SIGTERM (PR_SET_PDEATHSIG); no code reached us
                self._exits[pid] = -signal.SIGTERM
            return self._exits.get(pid)

    def wait_exit(self, pid: int, timeout: float | None) -> int | None:
        deadline = None if timeout is None else time.monotonic() + timeout
        with self._changed:
            while pid not in self._exits:
                left = None if deadline is None else deadline - time.monotonic()
                if left is not None and left <= 0:
                    return None
                if self.exit_code(pid) is not None:
                    break
                self._changed.wait(timeout=0.2 if left is None else min(left, 0.2))
            return self._exits[pid]

    def close(self, timeout_s: float = 5.0) -> None:
        """End the server (its children are stopped by then): EOF on its stdin, SIGKILL if it lingers. A
        server never asked for anything (the run stopped at a bad input it checked itself) is only
        preloading: it is killed at once rather than waited for until it reads its stdin."""
        with contextlib.suppress(OSError):
            if self._process.stdin is not None:
                self._process.stdin.close()
        try:
            self._process.wait(timeout=timeout_s if self._asked else 0.0)
        except subprocess.TimeoutExpired:
            self._process.kill()
            self._process.wait(timeout=5)
        for thread in self._threads:
            thread.join(timeout=1.0)
        with self._changed:
            if self._log is not None:
                self._log.close()
                self._log = None

    def _read(self) -> None:
        assert self._process.stdout is not None
        for line in self._process.stdout:
            try:
                message = json.loads(line)
            except ValueError:
                continue
            with self._changed:
                if "pid" in message:
                    self._pids.append(int(message["pid"]))
                elif "checked" in message:
                    self._checks[str(message["checked"])] = message
                elif "check_ended" in message:  # after its answer, if it gave one
                    self._checks.setdefault(str(message["check_ended"]), {})
                elif "exited" in message:
                    self._exits[int(message["exited"])] = int(message["code"])
                self._changed.notify_all()
        with self._changed:
            self._gone = True
            self._changed.notify_all()

    def _copy_log(self) -> None:
        assert self._process.stderr is not None
        for line in self._process.stderr:
            with self._changed:
                if self._log is None:
                    self._said.append(line)
                else:
                    self._log.write(line)
                    self._log.flush()


def _exists(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def enabled(environ: Mapping[str, str] = os.environ) -> bool:
    return environ.get(FORK_SERVER_ENV, "1") != "0"
