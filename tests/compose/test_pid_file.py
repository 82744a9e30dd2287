"""scripts/lib/pid-file.sh: a daemon's pid file left behind is removed, a live daemon's is kept.

CI once failed here: a machine stopped under dockerd left /var/run/docker.pid, its pid was reused by
another process, and dockerd refused to start ("pid file found"). The function runs as compose-smoke.sh
runs it, in bash, against a pid file in a temporary folder and real processes.
"""

from __future__ import annotations

import shutil
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest
from wall_clock import bound_s

ROOT = Path(__file__).resolve().parents[2]
LIBRARY = ROOT / "scripts" / "lib" / "pid-file.sh"


def _remove_stale(pid_file: Path, daemon: str) -> subprocess.CompletedProcess[str]:
    script = f'source "{LIBRARY}" && remove_stale_pid_file "{pid_file}" "{daemon}"'
    return subprocess.run(
        ["bash", "-c", script], capture_output=True, text=True, timeout=bound_s(30), check=False
    )


@pytest.fixture
def sleeper(tmp_path: Path, request: pytest.FixtureRequest) -> Iterator[subprocess.Popen[bytes]]:
    """A live process whose name (/proc/PID/comm) is the test's parameter, 'sleep' unless given."""
    name = getattr(request, "param", "sleep")
    executable = tmp_path / name
    shutil.copy(shutil.which("sleep") or "/bin/sleep", executable)
    process = subprocess.Popen([str(executable), f"{bound_s(60):.0f}"])  # alive for the whole test
    yield process
    process.kill()
    process.wait(timeout=bound_s(10))


def test_a_pid_file_whose_pid_is_another_process_is_removed(
    tmp_path: Path, sleeper: subprocess.Popen[bytes]
) -> None:
    pid_file = tmp_path / "docker.pid"
    pid_file.write_text(str(sleeper.pid))
    result = _remove_stale(pid_file, "dockerd")
    assert result.returncode == 0, result.stderr
    assert not pid_file.exists()
    assert f"stale, left by a dockerd that no longer runs (pid {sleeper.pid})" in result.stderr


def test_a_pid_file_whose_process_is_gone_is_removed(tmp_path: Path) -> None:
    gone = subprocess.Popen(["true"])
    gone.wait(timeout=bound_s(10))
    pid_file = tmp_path / "docker.pid"
    pid_file.write_text(f"{gone.pid}\n")
    assert _remove_stale(pid_file, "dockerd").returncode == 0
    assert not pid_file.exists()


@pytest.mark.parametrize("sleeper", ["dockerd"], indirect=True)
def test_the_pid_file_of_a_running_daemon_is_kept(tmp_path: Path, sleeper: subprocess.Popen[bytes]) -> None:
    pid_file = tmp_path / "docker.pid"
    pid_file.write_text(str(sleeper.pid))
    result = _remove_stale(pid_file, "dockerd")
    assert result.returncode == 0, result.stderr
    assert pid_file.read_text() == str(sleeper.pid), "a running daemon's pid file is left alone"
    assert result.stderr == ""


def test_no_pid_file_is_nothing_to_do(tmp_path: Path) -> None:
    result = _remove_stale(tmp_path / "docker.pid", "dockerd")
    assert (result.returncode, result.stderr) == (0, "")
