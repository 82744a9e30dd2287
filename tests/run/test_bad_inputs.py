"""Bad input found by a probe of the command line: each one is one clear line on stderr and exit 2.

Every case runs the real ``bimbot`` command as a process and checks: exit code 2, exactly one line on
stderr naming the problem, no traceback, and (for ``bimbot run``) no service started.

Read-only places are made honestly for root too, whom permission bits do not stop: a path under a regular
file, ``/proc`` (no new entries there even for root) and, for a read-only build, a read-only bind mount in a
mount namespace of its own (``unshare --mount``: the mount ends with the process); as another user the
permission bits do it.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
from wall_clock import bound_s

from bimbot.demo import bundled_model_path

IS_ROOT = os.geteuid() == 0
PROC = Path("/proc")  # no new entries here, even for root


def _bimbot(*args: str, prefix: tuple[str, ...] = ()) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [*prefix, sys.executable, "-P", "-m", "bimbot.cli", *args],
        check=False,
        capture_output=True,
        text=True,
        timeout=bound_s(120),
    )


def _one_line(done: subprocess.CompletedProcess[str], *needles: str) -> str:
    """The one stderr line of a command that rejected its input (exit 2), holding every needle."""
    assert done.returncode == 2, (done.returncode, done.stderr)
    assert "Traceback" not in done.stderr, done.stderr
    lines = [line for line in done.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, done.stderr
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])
    return lines[0]


@pytest.fixture
def build(bundled_build: Path, tmp_path: Path) -> Path:
    copy = tmp_path / "build"
    shutil.copytree(bundled_build, copy)
    return copy


@pytest.fixture
def a_file(tmp_path: Path) -> Path:
    path = tmp_path / "notes.txt"
    path.write_text("a regular file, not a folder\n")
    return path


def _nothing_started(build: Path) -> bool:
    """No service ran: a run makes BUILD/runs/<time>/logs/ before it starts its first one."""
    return not any((build / "runs").glob("*/logs"))


@contextmanager
def _read_only_tree(folder: Path) -> Iterator[None]:
    """``folder`` and everything in it without write permission (for a user other than root)."""
    modes = {path: path.stat().st_mode for path in [folder, *folder.rglob("*")]}
    for path, mode in modes.items():
        path.chmod(mode & ~0o222)
    try:
        yield
    finally:
        for path, mode in modes.items():
            path.chmod(mode)


def _read_only_mount_prefix(folder: Path) -> tuple[str, ...]:
    """A command prefix that runs the command with ``folder`` mounted read-only over itself, in a mount
    namespace of its own (root only); the test is skipped where that is not possible."""
    unshare = shutil.which("unshare")
    script = 'mount --bind "$1" "$1" && mount -o remount,ro,bind "$1" "$1" && shift && exec "$@"'
    prefix = (unshare or "unshare", "--mount", "sh", "-c", script, "sh", str(folder))
    if unshare is None or subprocess.run([*prefix, "true"], check=False, capture_output=True).returncode:
        pytest.skip("no read-only bind mount here (unshare --mount and mount need root)")
    probe = subprocess.run([*prefix, "touch", str(folder / "probe")], check=False, capture_output=True)
    if probe.returncode == 0:
        pytest.skip("the bind mount did not make the folder read-only")
    return prefix


# --- 1, 2: output folders and files ---------------------------------------------------------------------


def test_convert_into_a_folder_under_a_regular_file(a_file: Path) -> None:
    done = _bimbot("convert", str(bundled_model_path()), "-o", str(a_file / "out"), "--no-progress")
    _one_line(done, str(a_file), "is a file, not a folder")


@pytest.mark.skipif(not PROC.is_dir(), reason="needs /proc")
def test_convert_into_a_folder_that_cannot_be_made() -> None:
    done = _bimbot("convert", str(bundled_model_path()), "-o", str(PROC / "bimbot-out"), "--no-progress")
    _one_line(done, "--output", str(PROC / "bimbot-out"), "cannot create")


@pytest.mark.skipif(not PROC.is_dir(), reason="needs /proc")
def test_sample_into_a_read_only_folder() -> None:
    done = _bimbot("sample", "light-steel-frame", "-o", str(PROC / "bimbot-out.ifc"))
    _one_line(done, "--output", str(PROC / "bimbot-out.ifc"), "cannot create a file in /proc")


def test_sample_into_a_folder_under_a_regular_file(a_file: Path) -> None:
    done = _bimbot("sample", "light-steel-frame", "-o", str(a_file / "frame.ifc"))
    _one_line(done, str(a_file), "is a file, not a folder")


def test_sample_into_a_read_only_folder_of_ones_own(tmp_path: Path) -> None:
    folder = tmp_path / "locked"
    folder.mkdir()
    if IS_ROOT:  # permission bits do not stop root: a read-only bind mount does
        args = ("sample", "light-steel-frame", "-o", str(folder / "frame.ifc"))
        done = _bimbot(*args, prefix=_read_only_mount_prefix(folder))
    else:
        with _read_only_tree(folder):
            done = _bimbot("sample", "light-steel-frame", "-o", str(folder / "frame.ifc"))
    _one_line(done, str(folder), "cannot create a file")
    assert not (folder / "frame.ifc").exists()


# --- 3: a build that cannot hold a run folder -----------------------------------------------------------


def test_run_on_a_build_whose_runs_is_a_regular_file(build: Path) -> None:
    (build / "runs").write_text("not a folder\n")
    done = _bimbot("run", str(build), "-q")
    _one_line(done, str(build / "runs"), "is a file, not a folder", "--run-dir")


def test_run_on_a_read_only_build_says_to_give_a_run_dir(build: Path) -> None:
    if IS_ROOT:
        done = _bimbot("run", str(build), "-q", prefix=_read_only_mount_prefix(build))
    else:
        with _read_only_tree(build):
            done = _bimbot("run", str(build), "-q")
    _one_line(done, str(build), "--run-dir")
    assert _nothing_started(build)


def test_run_with_a_run_dir_under_a_regular_file(build: Path, a_file: Path) -> None:
    done = _bimbot("run", str(build), "-q", "--run-dir", str(a_file / "run"))
    _one_line(done, "--run-dir", "is a file, not a folder")
    assert _nothing_started(build)


# --- 4, 5, 6: numbers and the sequence ------------------------------------------------------------------


@pytest.mark.parametrize(
    ("options", "needle"),
    [
        (("--physics-hz", "nan"), "--physics-hz"),
        (("--control-period-s", "inf"), "--control-period-s"),
        (("--rtf", "-1"), "--rtf"),
        (("--rtf", "nan"), "--rtf"),
        (("--timeout-s", "-1"), "--timeout-s"),
        (("--sequence", "missing.xml"), "missing.xml"),
    ],
)
def test_run_rejects_an_impossible_option_before_any_service_starts(
    build: Path, options: tuple[str, ...], needle: str
) -> None:
    done = _bimbot("run", str(build), "-q", *options)
    _one_line(done, needle)
    assert _nothing_started(build)


@pytest.mark.parametrize("options", [("--physics-hz", "nan"), ("--rtf", "inf"), ("--odom-noise", "-1")])
def test_physics_rejects_a_non_finite_or_negative_number(build: Path, options: tuple[str, ...]) -> None:
    done = _bimbot("physics", "--build", str(build), *options)
    _one_line(done, options[0])


# --- from a new user's trial ---------------------------------------------------------------------------


def test_an_option_the_sub_command_does_not_know_is_that_sub_command_s_error(tmp_path: Path) -> None:
    done = _bimbot("convert", str(bundled_model_path()), "-o", str(tmp_path / "out"), "--robots", "3")
    _one_line(done, "bimbot convert: error: unrecognized arguments: --robots 3", "bimbot convert --help")
    assert not (tmp_path / "out").exists()


def test_a_shortened_option_is_not_taken_for_the_one_it_begins(build: Path) -> None:
    """``--robot 3`` is no ``--robots 3``: argparse would have started a build with three robots unasked."""
    done = _bimbot("run", str(build), "--robot", "3")
    _one_line(done, "bimbot run: error: unrecognized arguments: --robot 3")
    assert _nothing_started(build)


def test_an_option_before_any_sub_command_is_named_not_reported_as_a_missing_command() -> None:
    _one_line(_bimbot("--frobnicate"), "bimbot: error: unrecognized arguments: --frobnicate")
    _one_line(_bimbot("-v"), "the following arguments are required: COMMAND")  # a known option: as before


def test_a_build_of_no_component_is_one_line_for_run_and_fleet_check(build: Path) -> None:
    """A conversion that converts nothing (a script-made model of 30 elements with no geometry, exit 2)
    still writes its folder; ``bimbot fleet check`` on it ended in a traceback."""
    manifest = json.loads((build / "manifest.json").read_text())
    (build / "manifest.json").write_text(json.dumps({**manifest, "components": [], "in_place": []}))
    for command in (("run", str(build)), ("fleet", "check", str(build), "--summary")):
        _one_line(_bimbot(*command), str(build), "the build has no components to construct")


def test_run_on_a_folder_that_does_not_exist_says_so(tmp_path: Path) -> None:
    missing = tmp_path / "no_build_here"
    _one_line(_bimbot("run", str(missing)), str(missing), "no such folder", "bimbot convert")
