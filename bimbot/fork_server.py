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
(``BIMBOT_FORK_SERVER=0`` does that always).

Fork safety: the server imports modules and runs numba kernels, nothing else: no bus session, no physics
client, no thread of its own (numpy's BLAS pool re-initialises after a fork). Python's ``random`` reseeds
in a child by itself; numpy's global generator is reseeded here. ``gc.freeze()`` keeps the garbage
collector from touching (and so copying) every preloaded object in every child.
"""

from __future__ import annotations

import contextlib
import gc
import importlib
import json
import logging
import os
import selectors
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import IO, Any

import setproctitle

from bimbot.shared.service_runner import PRELOADED_ENV, process_status_mb

_log = logging.getLogger(__name__)

FORK_SERVER_ENV = "BIMBOT_FORK_SERVER"  # "0": start every service as a plain process
# what the services of a run import (their commands and apps), and the kernels they compile
PRELOAD_MODULES = (
    "bimbot.cli",
    "bimbot.services.bus_router",
    "bimbot.services.physics.cli",
    "bimbot.services.physics.app",
    "bimbot.services.robot.cli",
    "bimbot.services.robot.app",
    "bimbot.services.planner.cli",
    "bimbot.services.planner.app",
    "bimbot.services.component_agents.cli",
    "bimbot.services.component_agents.app",
)
WARM_UPS = (
    ("bimbot.services.robot.compiled_kernels", "warm_up_kernels"),
    ("bimbot.services.physics.ray_kernel", "warm_up"),
)
SPAWN_TIMEOUT_S = 120.0  # a fresh clone compiles the kernels first (numba has no cache yet)


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

    def __init__(self) -> None:
        """Start the server; it preloads while the run checks its input (its log: :meth:`attach_log`)."""
        from bimbot.supervisor import STOP_WITH_PARENT_ENV

        self._process = subprocess.Popen(
            [sys.executable, "-P", "-m", "bimbot.fork_server"],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            env={**os.environ, STOP_WITH_PARENT_ENV: str(os.getpid())},
            start_new_session=True,  # a Ctrl-C at the terminal reaches bimbot run only
        )
        self._changed = threading.Condition()
        self._pids: list[int] = []  # answers to spawn requests, in order
        self._checks: dict[str, dict[str, Any]] = {}  # answers to check requests, by token ({}: none came)
        self._exits: dict[int, int] = {}
        self._gone = False  # the server's stdout closed: it is dead, no more answers come
        self._lock = threading.Lock()  # one spawn request at a time
        self._log: IO[bytes] | None = None
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

    def check(self, request: dict[str, Any]) -> dict[str, Any] | None:
        """Have a child of the server run the input check ``request`` asks for (:mod:`bimbot.forked_check`);
        its answer, or None when none comes (the server is gone, or the child ended without answering)."""
        token = request["check"]
        with self._lock:
            if not self._send(request):
                return None
            with self._changed:
                while token not in self._checks and not self._gone:
                    self._changed.wait(timeout=0.5)  # bounded by the child: it answers or ends
                return self._checks.pop(token, None) or None

    def _send(self, request: dict[str, Any]) -> bool:
        """Write one request line (under ``_lock``); False when the server is gone."""
        if not self.usable:
            return False
        assert self._process.stdin is not None
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
        """End the server (its children are stopped by then): EOF on its stdin, SIGKILL if it lingers."""
        with contextlib.suppress(OSError):
            if self._process.stdin is not None:
                self._process.stdin.close()
        try:
            self._process.wait(timeout=timeout_s)
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


# --- the server process -------------------------------------------------------------------------------


def preload() -> None:
    """Import every service's code and load its compiled kernels (what each child would do first)."""
    for name in PRELOAD_MODULES:
        importlib.import_module(name)
    for module_name, function in WARM_UPS:
        getattr(importlib.import_module(module_name), function)()


def serve(requests: int = 0, answers: int = 1) -> int:
    """Answer spawn requests on fd ``requests`` until it closes; report each child's exit on ``answers``."""
    selector = selectors.DefaultSelector()
    selector.register(requests, selectors.EVENT_READ)
    pending = b""
    children: dict[int, tuple[int, str | None]] = {}  # pidfd → pid, and the token of a check's child
    while True:
        for key, _events in selector.select():
            if key.fd == requests:
                data = os.read(requests, 1 << 16)
                if not data:
                    return 0  # the run closed it: every child was stopped before
                pending += data
                while b"\n" in pending:
                    line, pending = pending.split(b"\n", 1)
                    request = json.loads(line)
                    token = request.get("check")
                    keep_open = (requests, answers, selector)
                    pid = _fork_check(request, keep_open) if token else _fork_child(request, keep_open)
                    pidfd = os.pidfd_open(pid)
                    children[pidfd] = (pid, token)
                    selector.register(pidfd, selectors.EVENT_READ)
                    if not token:
                        _answer(answers, {"pid": pid})
            else:
                pid, token = children.pop(key.fd)
                selector.unregister(key.fd)
                os.close(key.fd)
                _, status = os.waitpid(pid, 0)
                code = os.waitstatus_to_exitcode(status)
                _answer(answers, {"check_ended": token} if token else {"exited": pid, "code": code})


def _answer(fd: int, message: dict[str, Any]) -> None:
    os.write(fd, json.dumps(message).encode() + b"\n")


def _fork_child(request: dict[str, Any], keep_open: tuple[int, int, selectors.BaseSelector]) -> int:
    """A child that runs the service ``request`` names, as ``python -m bimbot.cli`` would."""
    preloaded_mb = _resident_mb()

    def service(requests: int, answers: int) -> int:
        _become_service(request, requests, answers, preloaded_mb)
        from bimbot.cli import main

        return main(list(request["args"]))

    return _in_child(keep_open, service)


def _fork_check(request: dict[str, Any], keep_open: tuple[int, int, selectors.BaseSelector]) -> int:
    """A child that runs ``bimbot run``'s input check and answers (:mod:`bimbot.forked_check`)."""

    def check(requests: int, answers: int) -> int:
        os.dup2(os.open(os.devnull, os.O_RDONLY), requests)  # the run's requests are the server's
        from bimbot.forked_check import answer_check

        _answer(answers, answer_check(request))
        return 0

    return _in_child(keep_open, check)


def _in_child(keep_open: tuple[int, int, selectors.BaseSelector], body: Callable[[int, int], int]) -> int:
    """Fork; the child runs ``body(requests, answers)`` and exits with its code, never returning into the
    server's loop; the server gets the child's pid."""
    pid = os.fork()
    if pid:
        return pid
    code = 1
    try:
        requests, answers, selector = keep_open
        selector.close()
        code = body(requests, answers)
    except SystemExit as stop:
        code = stop.code if isinstance(stop.code, int) else (0 if stop.code is None else 1)
        if isinstance(stop.code, str):
            sys.stderr.write(stop.code + "\n")
    except BaseException:
        import traceback

        traceback.print_exc()
        code = 1
    finally:
        with contextlib.suppress(BaseException):
            import atexit

            atexit._run_exitfuncs()  # what an interpreter does at exit (logging flushes, zenoh …)
            sys.stdout.flush()
            sys.stderr.flush()
        os._exit(code)


def _become_service(request: dict[str, Any], requests: int, answers: int, preloaded_mb: float) -> None:
    """In the child: a process of its own, as ``subprocess.Popen(start_new_session=True)`` makes one."""
    from bimbot.supervisor import STOP_WITH_PARENT_ENV

    os.setsid()
    log = os.open(request["log"], os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
    devnull = os.open(os.devnull, os.O_RDONLY)
    os.dup2(devnull, 0)
    os.dup2(log, 1)
    os.dup2(log, 2)
    for fd in {log, devnull, answers} - {0, 1, 2}:
        os.close(fd)
    if requests not in (0, 1, 2):
        os.close(requests)
    os.closerange(3, 1 << 16)  # the server's pidfds of earlier children
    os.environ.clear()
    os.environ.update(request["env"])
    os.environ[STOP_WITH_PARENT_ENV] = str(os.getppid())  # its parent is this server, not the run
    os.environ[PRELOADED_ENV] = f"{preloaded_mb:.0f}"
    os.chdir(request["cwd"])
    sys.argv = ["bimbot", *request["args"]]
    # ps, top and /proc show which service this is, as for a plain ``python -m bimbot.cli`` process
    setproctitle.setproctitle(" ".join([sys.executable, "-P", "-m", "bimbot.cli", *request["args"]]))
    np = sys.modules.get("numpy")
    if np is not None:
        np.random.seed()  # as a fresh process would start: from the OS's entropy


def _resident_mb() -> float:
    return process_status_mb("VmRSS") or 0.0


def main() -> int:
    from bimbot.cli import stop_with_parent

    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s", stream=sys.stderr)
    stop_with_parent()  # the run's death ends the server, and the server's its children
    try:  # a child's end is watched through a pidfd (Linux 5.3): without one, the run starts plain processes
        os.close(os.pidfd_open(os.getpid()))
    except (AttributeError, OSError) as error:
        sys.stderr.write(f"fork server: no pidfd here ({error}); the run starts its services as processes\n")
        return 3
    # setproctitle claims the room for its children's longer titles now, while the environment is the
    # original one; ps says what this process is for
    setproctitle.setproctitle(
        f"{sys.executable} -P -m bimbot.fork_server (starts the services of bimbot run {os.getppid()})"
    )
    started = time.perf_counter()
    # the answers go on a copy of stdout: a child's fd 1 becomes its log, and nothing buffered follows it
    answers = os.dup(1)
    os.dup2(os.open(os.devnull, os.O_WRONLY), 1)
    preload()
    logging.getLogger().handlers.clear()  # a child configures its own logging (bimbot.cli.main)
    gc.collect()
    gc.freeze()
    sys.stderr.write(
        f"fork server: {len(PRELOAD_MODULES)} service modules preloaded in "
        f"{time.perf_counter() - started:.2f} s, {_resident_mb():.0f} MB\n"
    )
    sys.stderr.flush()
    return serve(0, answers)


if __name__ == "__main__":
    sys.exit(main())
