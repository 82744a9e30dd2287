"""The fork server starts services as ``python -m bimbot.cli`` would, only without their imports.

Each test starts a real server (``python -m bimbot.fork_server_process``, which preloads every service's code)
and real services from it: a bus router that must listen, a physics command that must reject its input in one
line, a service killed by a signal, and a server killed by SIGKILL whose services must not outlive it (a
killed run's: tests/run/test_stop_with_parent.py). The run's input check, done by a child of the server
(:mod:`bimbot.forked_check`), must answer as the check in the run's own process does, and leave the run's
process without the services' code.
"""

from __future__ import annotations

import logging
import os
import signal
import subprocess
import sys
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest
from wall_clock import bound_s

import bimbot.fork_server
from bimbot.fork_server import ForkedChild, ForkServer
from bimbot.forked_check import apply_answer, check_request
from bimbot.polling import wait_until
from bimbot.run.build import _check_input
from bimbot.run.options import RunOptions
from bimbot.run.preflight import check_run_input
from bimbot.shared.errors import UserError
from bimbot.supervisor import ServiceProcess, free_port
from bimbot.warm_fork_server import WARM_FORK_SERVER_ENV


@pytest.fixture(scope="module", autouse=True)
def own_server() -> Iterator[None]:
    """The run's own fork server, not a session of the suite's warm one (tests/conftest.py)."""
    named = os.environ.pop(WARM_FORK_SERVER_ENV, None)
    yield
    if named is not None:
        os.environ[WARM_FORK_SERVER_ENV] = named


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
        assert wait_until(lambda: "listening" in bus.log(), timeout_s=bound_s(30.0)), bus.log()
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
    assert physics.wait(timeout_s=bound_s(60.0)) == 2
    log = physics.log()
    assert "bimbot physics: error:" in log and str(missing) in log, log
    assert "Traceback" not in log


def test_a_killed_forked_service_reports_the_signal_as_popen_does(server: ForkServer, tmp_path: Path) -> None:
    bus = ServiceProcess(
        "bus", ["bus", "--listen", f"tcp/127.0.0.1:{free_port()}"], tmp_path, launcher=server
    )
    assert wait_until(lambda: "listening" in bus.log(), timeout_s=bound_s(30.0)), bus.log()
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
        assert wait_until(lambda: "listening" in bus.log(), timeout_s=bound_s(30.0)), bus.log()
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
        assert wait_until(lambda: "listening" in bus.log(), timeout_s=bound_s(60.0)), bus.log()
        launcher._process.kill()  # as a user's kill -9 would
        assert wait_until(lambda: not bus.alive(), timeout_s=bound_s(15.0)), (
            "the service outlived its fork server"
        )
        assert bus.process.returncode is not None
        _plain_bus("bus-again", tmp_path, launcher)
    finally:
        launcher.close()


def _local_answer(build: Path, options: RunOptions) -> str:
    try:
        check_run_input(build, options)
    except UserError as error:
        return str(error)
    return "ok"


def _forked_answer(server: ForkServer, build: Path, options: RunOptions) -> str:
    answer = server.check(check_request(build, options))
    assert answer is not None and "failed" not in answer, answer
    try:
        assert apply_answer(answer)
    except UserError as error:
        return str(error)
    return "ok"


def test_the_run_s_input_check_answers_in_a_child_of_the_server_as_it_does_in_the_run(
    server: ForkServer, bundled_build: Path, tmp_path: Path
) -> None:
    broken = tmp_path / "broken.xml"
    broken.write_text("this is not XML")
    cases = [
        RunOptions(robots=1),
        RunOptions(planner_source=("--derive",)),
        RunOptions(planner_source=("--sequence", str(broken))),
        RunOptions(planner_source=("--sequence", str(tmp_path / "missing.xml"))),
        RunOptions(physics_hz=120.0, control_period_s=0.0125),
        RunOptions(inject_placement_error_m=-1.0),
    ]
    answers = [
        (_forked_answer(server, bundled_build, each), _local_answer(bundled_build, each)) for each in cases
    ]
    assert [forked for forked, _ in answers] == [local for _, local in answers]
    assert [forked == "ok" for forked, _ in answers] == [True, True, False, False, False, False]
    assert str(broken) in answers[2][0]
    assert server.check(check_request(tmp_path / "no_such_build", RunOptions())) is not None


def test_a_check_the_server_never_answers_is_given_up_and_the_run_checks_itself(
    bundled_build: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """A server that takes the request and never answers (stopped here; a child hung on a lock would do the
    same) must not hold the run: after the bound the run checks in its own process, which answers."""
    monkeypatch.setattr(bimbot.fork_server, "CHECK_TIMEOUT_S", 1.0)
    caplog.set_level(logging.INFO, logger="bimbot.fork_server")  # said, not warned: nothing is wrong
    launcher = ForkServer()
    pid = launcher._process.pid
    try:
        os.kill(pid, signal.SIGSTOP)
        said: list[str] = []

        def check() -> None:  # an option only the services' code rejects: the server is asked
            try:
                options = RunOptions(inject_placement_error_m=-1.0, run_dir=tmp_path / "run")
                _check_input(bundled_build, options, launcher)
            except UserError as error:
                said.append(str(error))

        checking = threading.Thread(target=check, daemon=True)  # a wait without bound fails, not hangs
        checking.start()
        checking.join(timeout=bound_s(30.0))
        assert not checking.is_alive(), "the run still waits for the stopped server's answer"
        assert len(said) == 1 and "inject-placement-error" in said[0]
        assert "still loading after 1 s (a busy machine): the run checks its input" in caplog.text
    finally:
        os.kill(pid, signal.SIGCONT)
        launcher.close()


def test_a_wrong_build_folder_is_said_at_once_and_the_server_is_not_waited_for(tmp_path: Path) -> None:
    """The build and the run folder need none of the services' code: the run checks them itself before it
    asks the server (which answers only once it has loaded that code), and a server it never asked is
    ended at once, not waited for until it reads its stdin (stopped here: preloading for ever)."""
    launcher = ForkServer()
    os.kill(launcher._process.pid, signal.SIGSTOP)
    said: list[str] = []

    def check_and_close() -> None:
        try:
            _check_input(tmp_path / "no_such_build", RunOptions(), launcher)
        except UserError as error:
            said.append(str(error))
        finally:
            launcher.close(timeout_s=600.0)

    checking = threading.Thread(target=check_and_close, daemon=True)
    checking.start()
    checking.join(timeout=bound_s(10.0))
    if checking.is_alive():  # the run waits for the stopped server: let it go, then fail
        os.kill(launcher._process.pid, signal.SIGKILL)
    assert not checking.is_alive(), "the run waited for the server before saying the folder is wrong"
    assert len(said) == 1 and "no_such_build" in said[0]


CHECK_IN_RUN = """
import sys
from pathlib import Path
from bimbot.fork_server import ForkServer
from bimbot.run.build import _check_input
from bimbot.run.options import RunOptions
launcher = ForkServer()
try:
    _check_input(Path(sys.argv[1]), RunOptions(robots=1), launcher)
finally:
    launcher.close()
print(sorted(name for name in sys.modules if name.startswith("bimbot.services.")))
"""


def test_with_a_server_the_run_s_process_never_imports_the_services_code(bundled_build: Path) -> None:
    done = subprocess.run(
        [sys.executable, "-c", CHECK_IN_RUN, str(bundled_build)],
        check=True,
        capture_output=True,
        text=True,
        timeout=bound_s(120),
    )
    imported = done.stdout.strip()
    for heavy in ("physics.app", "physics.simulation", "planner.app", "robot.app"):
        assert f"bimbot.services.{heavy}'" not in imported, imported
