"""The fork server starts services as ``python -m bimbot.cli`` would, only without their imports.

Each test starts a real server (``python -m bimbot.fork_server``, which preloads every service's code) and
real services from it: a bus router that must listen, a physics command that must reject its input in one
line, a service killed by a signal, and a server killed by SIGKILL whose services must not outlive it
(a killed run's: tests/run/test_stop_with_parent.py).
"""

from __future__ import annotations

import os
import signal
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest

from bimbot.fork_server import ForkedChild, ForkServer
from bimbot.supervisor import ServiceProcess, free_port, wait_until


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[ForkServer]:
    launcher = ForkServer()
    launcher.attach_log(tmp_path_factory.mktemp("fork_server") / "fork-server.log")
    yield launcher
    launcher.close()


def test_a_forked_service_runs_its_command_in_a_session_of_its_own(
    server: ForkServer, tmp_path: Path
) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    bus = ServiceProcess("bus", ["bus", "--listen", endpoint], tmp_path, launcher=server)
    try:
        assert isinstance(bus.process, ForkedChild), "the service was not forked by the server"
        assert wait_until(lambda: "listening" in bus.log(), timeout_s=30.0), bus.log()
        pid = bus.process.pid
        assert os.getpgid(pid) == pid and os.getsid(pid) == pid  # stop() signals its group
        title = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").split()
        assert title[title.index(b"bimbot.cli") + 1 :][:3] == [b"bus", b"--listen", endpoint.encode()]
        assert bus.alive()
    finally:
        code = bus.stop()
    assert code == 0, bus.log()  # SIGTERM: the router closes and exits 0
    assert "bus router stopped" in bus.log()


def test_a_forked_service_reports_a_user_error_in_one_line_and_exit_2(
    server: ForkServer, tmp_path: Path
) -> None:
    missing = tmp_path / "no_such_build"
    physics = ServiceProcess("physics", ["physics", "--build", str(missing)], tmp_path, launcher=server)
    assert isinstance(physics.process, ForkedChild)
    assert physics.wait(timeout_s=60.0) == 2
    log = physics.log()
    assert "bimbot physics: error:" in log and str(missing) in log, log
    assert "Traceback" not in log


def test_a_killed_forked_service_reports_the_signal_as_popen_does(server: ForkServer, tmp_path: Path) -> None:
    bus = ServiceProcess(
        "bus", ["bus", "--listen", f"tcp/127.0.0.1:{free_port()}"], tmp_path, launcher=server
    )
    assert wait_until(lambda: "listening" in bus.log(), timeout_s=30.0), bus.log()
    bus.kill()
    assert bus.process.returncode == -signal.SIGKILL
    assert not bus.alive()


def _plain_bus(name: str, tmp_path: Path, launcher: ForkServer) -> None:
    """A bus router asked of a server that is gone: started plainly, it listens and stops with 0."""
    bus = ServiceProcess(
        name, ["bus", "--listen", f"tcp/127.0.0.1:{free_port()}"], tmp_path, launcher=launcher
    )
    try:
        assert isinstance(bus.process, subprocess.Popen)
        assert wait_until(lambda: "listening" in bus.log(), timeout_s=30.0), bus.log()
    finally:
        assert bus.stop() == 0


def test_without_a_usable_server_a_service_starts_as_a_plain_process(tmp_path: Path) -> None:
    launcher = ForkServer()
    launcher.close()
    _plain_bus("bus", tmp_path, launcher)


def test_when_the_server_dies_its_services_stop_and_the_next_start_plainly(tmp_path: Path) -> None:
    launcher = ForkServer()
    try:
        bus = ServiceProcess(
            "bus", ["bus", "--listen", f"tcp/127.0.0.1:{free_port()}"], tmp_path, launcher=launcher
        )
        assert isinstance(bus.process, ForkedChild)
        assert wait_until(lambda: "listening" in bus.log(), timeout_s=60.0), bus.log()
        launcher._process.kill()  # as a user's kill -9 would
        assert wait_until(lambda: not bus.alive(), timeout_s=15.0), "the service outlived its fork server"
        assert bus.process.returncode is not None
        _plain_bus("bus-again", tmp_path, launcher)
    finally:
        launcher.close()
