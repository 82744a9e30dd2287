"""The fork server starts services as ``python -m bimbot.cli`` would, only without their imports.

Each test starts a real server (``python -m bimbot.fork_server``, which preloads every service's code) and
real services from it: a bus router that must listen, a physics command that must reject its input in one
line, a service killed by a signal, and a parent killed by SIGKILL whose services must not outlive it.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
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


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


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


def test_without_a_usable_server_a_service_starts_as_a_plain_process(tmp_path: Path) -> None:
    launcher = ForkServer()
    launcher.close()
    bus = ServiceProcess(
        "bus", ["bus", "--listen", f"tcp/127.0.0.1:{free_port()}"], tmp_path, launcher=launcher
    )
    try:
        assert isinstance(bus.process, subprocess.Popen)
        assert wait_until(lambda: "listening" in bus.log(), timeout_s=30.0), bus.log()
    finally:
        assert bus.stop() == 0


PARENT = textwrap.dedent(
    """
    import sys, time
    from pathlib import Path
    from bimbot.fork_server import ForkServer
    from bimbot.supervisor import ServiceProcess
    server = ForkServer()
    bus = ServiceProcess("bus", ["bus", "--listen", sys.argv[1]], Path(sys.argv[2]), launcher=server)
    print(bus.process.pid, flush=True)
    time.sleep(600)
    """
)


def test_forked_services_stop_when_the_run_that_started_them_is_killed(tmp_path: Path) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    parent = subprocess.Popen(
        [sys.executable, "-c", PARENT, endpoint, str(tmp_path)], stdout=subprocess.PIPE, text=True
    )
    child = 0
    try:
        assert parent.stdout is not None
        child = int(parent.stdout.readline())
        assert wait_until(lambda: "listening" in (tmp_path / "bus.log").read_text(), timeout_s=60.0)
        parent.send_signal(signal.SIGKILL)
        parent.wait(timeout=10)
        assert wait_until(lambda: not _alive(child), timeout_s=15.0), "the service outlived its run"
    finally:
        parent.kill()
        if child and _alive(child):
            os.kill(child, signal.SIGKILL)


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
        again = ServiceProcess(
            "bus-again", ["bus", "--listen", f"tcp/127.0.0.1:{free_port()}"], tmp_path, launcher=launcher
        )
        try:
            assert isinstance(again.process, subprocess.Popen)
            assert wait_until(lambda: "listening" in again.log(), timeout_s=30.0), again.log()
        finally:
            again.stop()
    finally:
        launcher.close()
