"""The fork server's own process (``python -m bimbot.fork_server_process``): preload, then fork on request.

:mod:`bimbot.fork_server` is the run's side (start it, ask for children, learn how they ended) and says
why it exists and what the protocol is. This module is what runs in the server: it imports every service's
code and loads the compiled kernels once (:func:`preload`), then answers one JSON request per line on its
stdin (:func:`serve`): a service to start becomes a forked child that runs ``bimbot.cli.main`` as a plain
``python -m bimbot.cli`` process would; an input check becomes a child that answers and exits
(:mod:`bimbot.forked_check`). Each child's end is watched through a pidfd and reported.
"""

from __future__ import annotations

import contextlib
import gc
import importlib
import json
import logging
import os
import selectors
import sys
import time
from collections.abc import Callable
from typing import Any

import setproctitle

from bimbot.shared.service_runner import PRELOADED_ENV, process_status_mb

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
    from bimbot.child_process import STOP_WITH_PARENT_ENV

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


def _to_devnull(fd: int) -> None:
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, fd)
    os.close(devnull)


def _resident_mb() -> float:
    return process_status_mb("VmRSS") or 0.0


def prepare() -> float | None:
    """Load what every child needs (:func:`preload`); the seconds it took, None when this kernel has no
    pidfd to watch a child's end with (the run then starts plain processes)."""
    try:  # a child's end is watched through a pidfd (Linux 5.3): without one, the run starts plain processes
        os.close(os.pidfd_open(os.getpid()))
    except (AttributeError, OSError) as error:
        sys.stderr.write(f"fork server: no pidfd here ({error}); the run starts its services as processes\n")
        return None
    started = time.perf_counter()
    stdout = os.dup(1)  # nothing printed while importing reaches the answers (fd 1 of a run's server)
    _to_devnull(1)
    try:
        preload()
    finally:
        os.dup2(stdout, 1)
        os.close(stdout)
    logging.getLogger().handlers.clear()  # a child configures its own logging (bimbot.cli.main)
    gc.collect()
    gc.freeze()
    return time.perf_counter() - started


def serve_run(run_pid: int, said: str) -> int:
    """Serve one run on fds 0 (its requests), 1 (the answers) and 2 (its log), having said ``said``."""
    # setproctitle claims the room for its children's longer titles now, while the environment is the
    # original one; ps says what this process is for
    setproctitle.setproctitle(
        f"{sys.executable} -P -m bimbot.fork_server_process (starts the services of bimbot run {run_pid})"
    )
    # the answers go on a copy of stdout: a child's fd 1 becomes its log, and nothing buffered follows it
    answers = os.dup(1)
    _to_devnull(1)
    sys.stderr.write(said + "\n")
    sys.stderr.flush()
    return serve(0, answers)


def main() -> int:
    from bimbot.child_process import stop_with_parent

    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s", stream=sys.stderr)
    stop_with_parent()  # the run's death ends the server, and the server's its children
    took_s = prepare()
    if took_s is None:
        return 3
    modules = len(PRELOAD_MODULES)
    said = f"fork server: {modules} service modules preloaded in {took_s:.2f} s, {_resident_mb():.0f} MB"
    return serve_run(os.getppid(), said)


if __name__ == "__main__":
    sys.exit(main())
