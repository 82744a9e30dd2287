"""A warm fork server shared by runs: a run that names it takes a session of it, loaded already.

Each test starts a real warm server (``python -m bimbot.warm_fork_server``) and real services from a
session of it: the session must be the warm server's child (not a server the run started), its services
must run as the run's own server's do, the run's close must end the session (so a killed run's services
do not outlive it), and a run of another hash seed, or one that names no listening server, must start its
own fork server instead.
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from processes import alive
from wall_clock import bound_s

from bimbot.fork_server import ForkedChild, ForkServer
from bimbot.polling import wait_until
from bimbot.supervisor import ServiceProcess, free_port
from bimbot.warm_fork_server import WARM_FORK_SERVER_ENV, WarmSession, for_the_runs_of_this_process, running


@pytest.fixture(scope="module")
def warm() -> Iterator[Path]:
    """A warm server of this test module's own, listening (waited for: its load takes seconds)."""
    with running() as path:
        assert wait_until(path.exists, timeout_s=bound_s(120.0)), "the warm server never listened"
        yield path


def _parent_pid(pid: int) -> int:
    return int(Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[1])


def _warm_pid(path: Path) -> int:
    """The pid of the process listening on ``path`` (its title names it)."""
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                title = (entry / "cmdline").read_bytes().replace(b"\0", b" ")
            except OSError:
                continue
            if b"bimbot.warm_fork_server" in title and str(path).encode() in title:
                return int(entry.name)
    raise AssertionError(f"no warm fork server for {path}")


def _bus(folder: Path, launcher: ForkServer) -> ServiceProcess:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    return ServiceProcess("bus", ["bus", "--listen", endpoint], folder, launcher=launcher)


def _launcher(warm: Path | str, monkeypatch: pytest.MonkeyPatch, log: Path) -> ForkServer:
    monkeypatch.setenv(WARM_FORK_SERVER_ENV, str(warm))
    launcher = ForkServer()
    launcher.attach_log(log)
    return launcher


def test_a_run_takes_a_session_of_the_warm_server_and_its_services_run_from_it(
    warm: Path, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    launcher = _launcher(warm, monkeypatch, tmp_path / "fork-server.log")
    try:
        session = launcher._process
        assert isinstance(session, WarmSession), "the run started a server of its own"
        assert _parent_pid(session.pid) == _warm_pid(warm)
        endpoint = f"tcp/127.0.0.1:{free_port()}"
        bus = ServiceProcess("bus", ["bus", "--listen", endpoint], tmp_path, launcher=launcher)
        try:
            assert isinstance(bus.process, ForkedChild)
            assert _parent_pid(bus.process.pid) == session.pid  # forked by the run's session
            assert wait_until(lambda: "listening" in bus.log(), timeout_s=bound_s(30.0)), bus.log()
        finally:
            assert bus.stop() == 0, bus.log()
        physics_args = ["physics", "--build", str(tmp_path / "none")]
        physics = ServiceProcess("physics", physics_args, tmp_path, launcher=launcher)
        assert physics.wait(timeout_s=bound_s(60.0)) == 2  # a user error: one line, exit 2, as ever
        assert "bimbot physics: error:" in physics.log() and "Traceback" not in physics.log()
    finally:
        launcher.close()
    assert session.poll() == 0, "the session ends with its run"
    assert "a session of the warm fork server" in (tmp_path / "fork-server.log").read_text()


def test_the_warm_server_serves_one_run_after_another(
    warm: Path, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    sessions = []
    for index in range(2):
        launcher = _launcher(warm, monkeypatch, tmp_path / f"fork-server-{index}.log")
        try:
            assert isinstance(launcher._process, WarmSession)
            sessions.append(launcher._process.pid)
        finally:
            launcher.close()
    assert sessions[0] != sessions[1]


def test_a_closed_run_ends_its_session_and_the_session_s_services(
    warm: Path, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """The run's end (here its requests closed without stopping a service first, as a killed run's are)
    ends its session, and the kernel stops the session's services with it."""
    launcher = _launcher(warm, monkeypatch, tmp_path / "fork-server.log")
    bus = _bus(tmp_path, launcher)
    assert wait_until(lambda: "listening" in bus.log(), timeout_s=bound_s(30.0)), bus.log()
    pid = bus.process.pid
    launcher.close()
    assert wait_until(lambda: not alive(pid), timeout_s=bound_s(30.0))


def test_a_run_of_another_hash_seed_is_refused_and_starts_its_own_server(
    warm: Path, monkeypatch: pytest.MonkeyPatch, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    monkeypatch.setenv("PYTHONHASHSEED", "7")  # its services would hash otherwise than the server's
    caplog.set_level("INFO", logger="bimbot.warm_fork_server")
    launcher = _launcher(warm, monkeypatch, tmp_path / "fork-server.log")
    try:
        assert isinstance(launcher._process, subprocess.Popen), "a session served another hash seed"
        assert "refused this run" in caplog.text and "hash seed" in caplog.text
    finally:
        launcher.close()


def test_a_run_that_names_no_listening_server_starts_its_own(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level("INFO", logger="bimbot.warm_fork_server")
    launcher = _launcher(tmp_path / "no.sock", monkeypatch, tmp_path / "fork-server.log")
    try:
        assert isinstance(launcher._process, subprocess.Popen)
        assert "cannot be used" in caplog.text
        bus = _bus(tmp_path, launcher)
        try:
            assert isinstance(bus.process, ForkedChild)  # from the run's own server
            assert wait_until(lambda: "listening" in bus.log(), timeout_s=bound_s(30.0)), bus.log()
        finally:
            assert bus.stop() == 0
    finally:
        launcher.close()
    assert os.environ.get(WARM_FORK_SERVER_ENV) == str(tmp_path / "no.sock")  # monkeypatch undoes it


def test_a_process_names_its_warm_server_for_its_runs_and_keeps_one_named_already(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.delenv(WARM_FORK_SERVER_ENV, raising=False)
    with for_the_runs_of_this_process() as path:
        assert os.environ[WARM_FORK_SERVER_ENV] == str(path)
        assert wait_until(path.exists, timeout_s=bound_s(120.0)), "the warm server never listened"
        with for_the_runs_of_this_process() as inner:
            assert inner == path  # named already: kept, no second server
    assert WARM_FORK_SERVER_ENV not in os.environ
    assert not path.exists()  # stopped, its socket gone


def test_a_study_on_its_embedded_cluster_starts_its_runs_from_a_warm_server(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from bimbot.study.cluster import dask_client

    monkeypatch.delenv(WARM_FORK_SERVER_ENV, raising=False)
    with dask_client(None, 1):
        assert os.environ.get(WARM_FORK_SERVER_ENV), "the study's runs name no warm server"
    assert WARM_FORK_SERVER_ENV not in os.environ


def test_a_warm_server_started_by_hand_hashes_as_a_run_s_services_do(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """Started without PYTHONHASHSEED (as the README shows), it takes the seed a run's services have (a
    server with a random one serves no run), so the services forked from it hash alike run after run."""
    path = tmp_path / "fork.sock"
    environment = {k: v for k, v in os.environ.items() if k != "PYTHONHASHSEED"}
    server = subprocess.Popen(
        [sys.executable, "-P", "-m", "bimbot.warm_fork_server", str(path)],
        stdin=subprocess.PIPE,
        env=environment,
        start_new_session=True,
    )
    try:
        assert wait_until(path.exists, timeout_s=bound_s(120.0)), "the warm server never listened"
        monkeypatch.delenv("PYTHONHASHSEED", raising=False)
        launcher = _launcher(path, monkeypatch, tmp_path / "fork-server.log")
        try:
            assert isinstance(launcher._process, WarmSession), "refused: the server hashes otherwise"
        finally:
            launcher.close()
    finally:
        assert server.stdin is not None
        server.stdin.close()
        server.wait(timeout=bound_s(30.0))
