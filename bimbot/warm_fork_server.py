"""A warm fork server shared by many runs: each run's services start without loading their code first.

A run's own fork server (:mod:`bimbot.fork_server`) loads every service's code before the first service
starts: 2-5 s of each run's start-up on two cores. Whoever starts many runs on one machine (a study, the
test suite) starts one warm server instead, ``python -P -m bimbot.warm_fork_server SOCKET``, and names it
in the runs' environment (``BIMBOT_WARM_FORK_SERVER=SOCKET``). The warm server loads the code once, then
listens on the Unix socket. A run connects, hands over three pipes (its requests, the answers, the
server's log) and gets a *session*: a fork of the warm server, loaded already, that serves that run
exactly as the run's own fork server would (:func:`bimbot.fork_server_process.serve_run`: the same
protocol, the same children). :class:`WarmSession` is the run's handle on it, in place of the ``Popen``
of its own server.

A warm server serves only runs of its own installation (the same ``bimbot`` package and Python) and the
same hash seed; a run it refuses, or that cannot reach it, starts its own fork server, as without one. The
server ends when its stdin closes (its starter is gone), on SIGTERM, or with its parent; a session ends
when its run closes its requests, as a run's own server does.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import select
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import IO, Any

_log = logging.getLogger(__name__)

WARM_FORK_SERVER_ENV = "BIMBOT_WARM_FORK_SERVER"  # the warm server's socket path
CONNECT_TIMEOUT_S = 10.0  # a warm server answers a connection at once; one that does not is not used
STOP_TIMEOUT_S = 5.0  # a warm server ends within a second of its stdin closing (it looks every second)


def identity(environ: Mapping[str, str], *, server: bool = False) -> dict[str, str]:
    """What a run and a warm server must share: the code the server loaded (the package, the Python and
    its module path) and the hash seed the run's services would have (:data:`bimbot.child_process.HASH_SEED`;
    a value the user set wins)."""
    import bimbot
    from bimbot.child_process import HASH_SEED

    # the server's own seed is the one it started with (none set: a random one, which no run shares)
    seed = environ.get("PYTHONHASHSEED", "random") if server else {**HASH_SEED, **environ}["PYTHONHASHSEED"]
    return {
        "package": str(Path(bimbot.__file__).resolve().parent),
        "python": sys.executable,
        "hash_seed": seed,
        "python_path": environ.get("PYTHONPATH", ""),  # what the server's imports found
    }


# --- the run's side ------------------------------------------------------------------------------------


class WarmSession:
    """A run's session of a warm fork server: the parts of ``Popen`` :class:`bimbot.fork_server.ForkServer`
    uses. The session is the warm server's child, not the run's: its end is seen through a pidfd, and its
    exit code is not known (0 once it has ended)."""

    def __init__(self, pid: int, stdin: IO[bytes], stdout: IO[bytes], stderr: IO[bytes]) -> None:
        self.pid = pid
        self.stdin: IO[bytes] | None = stdin
        self.stdout: IO[bytes] | None = stdout
        self.stderr: IO[bytes] | None = stderr
        self._pidfd = os.pidfd_open(pid)

    def poll(self) -> int | None:
        return 0 if self._ended(0.0) else None

    def wait(self, timeout: float | None = None) -> int:
        if not self._ended(timeout):
            raise subprocess.TimeoutExpired(f"fork server session {self.pid}", timeout or 0.0)
        return 0

    def kill(self) -> None:
        with contextlib.suppress(ProcessLookupError):
            os.kill(self.pid, signal.SIGKILL)

    def _ended(self, timeout: float | None) -> bool:
        readable, _, _ = select.select([self._pidfd], [], [], timeout)
        return bool(readable)


def connect(environ: Mapping[str, str] = os.environ) -> WarmSession | None:
    """A session of the warm server ``environ`` names; None when it names none, cannot be reached, or
    refuses this run (the run then starts its own fork server)."""
    path = environ.get(WARM_FORK_SERVER_ENV)
    if not path:
        return None
    pipes = [os.pipe() for _ in range(3)]  # requests, answers, the server's log
    theirs = [pipes[0][0], pipes[1][1], pipes[2][1]]
    ours = [pipes[0][1], pipes[1][0], pipes[2][0]]
    reply: dict[str, Any] = {}
    try:
        with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as connection:
            connection.settimeout(CONNECT_TIMEOUT_S)
            connection.connect(path)
            header = {"identity": identity(environ), "run_pid": os.getpid()}
            socket.send_fds(connection, [json.dumps(header).encode()], theirs)
            with connection.makefile("rb") as answers:
                reply = json.loads(answers.readline() or b"{}")
    except (OSError, ValueError) as error:
        _log.info("the warm fork server at %s cannot be used (%s): the run starts its own", path, error)
    finally:
        for fd in theirs:
            os.close(fd)
    if "pid" not in reply:
        if reply:
            _log.info("the warm fork server at %s refused this run: %s", path, reply.get("refused"))
        for fd in ours:
            os.close(fd)
        return None
    requests, answers_in, log_in = ours
    return WarmSession(
        int(reply["pid"]), os.fdopen(requests, "wb"), os.fdopen(answers_in, "rb"), os.fdopen(log_in, "rb")
    )


@contextlib.contextmanager
def running() -> Iterator[Path]:
    """A warm server for the runs this process starts (set :data:`WARM_FORK_SERVER_ENV` to the path this
    yields), stopped at the end. It is not waited for: a run that comes before it listens starts its own
    fork server. Its log is ``warm.log`` beside the socket."""
    from bimbot.child_process import HASH_SEED, STOP_WITH_PARENT_ENV

    folder = Path(tempfile.mkdtemp(prefix="bimbot-warm-"))
    path = folder / "fork.sock"
    with (folder / "warm.log").open("wb") as log:
        process = subprocess.Popen(
            [sys.executable, "-P", "-m", "bimbot.warm_fork_server", str(path)],
            stdin=subprocess.PIPE,
            stdout=subprocess.DEVNULL,
            stderr=log,
            env={**HASH_SEED, **os.environ, STOP_WITH_PARENT_ENV: str(os.getpid())},
            start_new_session=True,
        )
    try:
        yield path
    finally:
        assert process.stdin is not None
        process.stdin.close()
        try:
            process.wait(timeout=STOP_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait(timeout=STOP_TIMEOUT_S)
        shutil.rmtree(folder, ignore_errors=True)


@contextlib.contextmanager
def for_the_runs_of_this_process(wait_s: float = 0.0) -> Iterator[Path]:
    """:func:`running`, named in this process's environment (which the runs it starts inherit) until the
    end; a warm server the environment names already is kept, and none is started. ``wait_s``: how long to
    wait for it to listen (0: not at all), so that the first run, too, takes a session of it."""
    named = os.environ.get(WARM_FORK_SERVER_ENV)
    if named:
        yield Path(named)
        return
    from bimbot.polling import wait_until

    with running() as path:
        if wait_s > 0:
            wait_until(path.exists, timeout_s=wait_s, interval_s=0.05)
        os.environ[WARM_FORK_SERVER_ENV] = str(path)
        try:
            yield path
        finally:
            os.environ.pop(WARM_FORK_SERVER_ENV, None)


# --- the warm server's side ----------------------------------------------------------------------------


def _open_session(connection: socket.socket, listener: socket.socket, said: str) -> None:
    """Read a run's request on ``connection`` and fork its session (or refuse it, saying why)."""
    from bimbot import fork_server_process

    fds: list[int] = []
    try:
        message, fds, _, _ = socket.recv_fds(connection, 1 << 16, 3)
        request = json.loads(message)
        mine = identity(os.environ, server=True)
        if len(fds) != 3:
            refused = f"{len(fds)} pipe(s) handed over, not 3"
        elif request.get("identity") != mine:
            refused = f"another installation or hash seed ({request.get('identity')} is not {mine})"
        else:
            refused = ""
        if refused:
            connection.sendall(json.dumps({"refused": refused}).encode() + b"\n")
            return
        pid = os.fork()
        if pid == 0:  # the session: never returns into the server's loop
            code = 1
            try:
                listener.close()
                connection.close()
                signal.signal(signal.SIGTERM, signal.SIG_DFL)
                signal.signal(signal.SIGCHLD, signal.SIG_DFL)  # the session waits for its own children
                os.setsid()  # as the run starts its own server: a Ctrl-C at the terminal reaches the run only
                for target, fd in enumerate(fds):
                    os.dup2(fd, target)
                    os.close(fd)
                code = fork_server_process.serve_run(int(request["run_pid"]), said)
            except BaseException:  # a session ends here, whatever happened
                import traceback

                traceback.print_exc()
            finally:
                os._exit(code)
        connection.sendall(json.dumps({"pid": pid}).encode() + b"\n")
    except (OSError, ValueError) as error:
        _log.warning("warm fork server: a run's request could not be served: %s", error)
    finally:
        for fd in fds:
            with contextlib.suppress(OSError):
                os.close(fd)
        connection.close()


def _reap() -> None:
    """Collect the sessions that ended (the warm server's children)."""
    with contextlib.suppress(ChildProcessError):
        while os.waitpid(-1, os.WNOHANG)[0]:
            pass


def serve(path: Path) -> int:
    """Load the services' code, then fork a session for every run that connects to ``path``, until stdin
    closes or SIGTERM comes."""
    import setproctitle

    from bimbot import fork_server_process
    from bimbot.child_process import stop_with_parent

    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s", stream=sys.stderr)
    stop_with_parent()
    setproctitle.setproctitle(f"{sys.executable} -P -m bimbot.warm_fork_server {path}")
    took_s = fork_server_process.prepare()
    if took_s is None:
        return 3
    modules = len(fork_server_process.PRELOAD_MODULES)
    said = (
        f"fork server: a session of the warm fork server at {path}, its {modules} service modules "
        f"preloaded in {took_s:.2f} s once, for every run that names it"
    )
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(0))
    signal.signal(signal.SIGCHLD, lambda *_: _reap())  # an ended session is collected at once
    with contextlib.suppress(FileNotFoundError):
        path.unlink()
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        listener.bind(str(path))
        listener.listen(16)
        sys.stderr.write(f"warm fork server at {path}: {modules} modules preloaded in {took_s:.2f} s\n")
        sys.stderr.flush()
        while True:
            readable, _, _ = select.select([listener, sys.stdin.fileno()], [], [], 1.0)
            _reap()
            if sys.stdin.fileno() in readable and not os.read(sys.stdin.fileno(), 4096):
                return 0  # its starter closed stdin (or is gone)
            if listener in readable:
                connection, _ = listener.accept()
                _open_session(connection, listener, said)
    finally:
        listener.close()
        with contextlib.suppress(FileNotFoundError):
            path.unlink()


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: python -P -m bimbot.warm_fork_server SOCKET")
    if "PYTHONHASHSEED" not in os.environ:  # hash as a run's services do: the seed is fixed at start-up
        from bimbot.child_process import HASH_SEED

        command = [sys.executable, "-P", "-m", "bimbot.warm_fork_server", sys.argv[1]]
        os.execve(sys.executable, command, {**HASH_SEED, **os.environ})
    sys.exit(serve(Path(sys.argv[1])))
