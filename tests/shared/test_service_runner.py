"""The one service runner: SIGTERM sets the stop event and the old handlers come back; bus options and the
build path become one-line user errors; a bug in a command is a traceback and exit 1, not "bad input"."""

from __future__ import annotations

import argparse
import json
import logging
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from pydantic import BaseModel
from wall_clock import bound_s

import bimbot.cli
import bimbot.command_line
from bimbot.shared.errors import UserError
from bimbot.shared.service_runner import resolve_build, service_bus, writable_dir


def test_sigterm_to_its_own_process_sets_the_stop_event_and_the_old_handlers_come_back() -> None:
    script = textwrap.dedent(
        """
        import os, signal
        from bimbot.shared.service_runner import run_service

        def mine(signum, frame):
            pass

        signal.signal(signal.SIGTERM, mine)
        before_int = signal.getsignal(signal.SIGINT)

        def main(value, stop):
            assert signal.getsignal(signal.SIGTERM) is not mine
            os.kill(os.getpid(), signal.SIGTERM)
            assert stop.wait(5.0), "SIGTERM did not set the stop event"
            return value

        code = run_service(main, 7)
        assert code == 7, code
        assert signal.getsignal(signal.SIGTERM) is mine
        assert signal.getsignal(signal.SIGINT) is before_int
        print("ok")
        """
    )
    done = subprocess.run(
        [sys.executable, "-c", script], check=False, capture_output=True, text=True, timeout=bound_s(60)
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "ok"


def test_a_bad_bus_mode_from_the_environment_is_a_user_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("BIMBOT_ZENOH_MODE", "broadcast")
    with pytest.raises(UserError, match="BIMBOT_ZENOH_MODE"):
        service_bus(argparse.Namespace(mode=None, connect=None, listen=None))


def test_build_may_be_the_folder_or_its_manifest_file(bundled_build: Path) -> None:
    by_folder = resolve_build(bundled_build)
    by_file = resolve_build(bundled_build / "manifest.json")
    assert by_folder.dir == by_file.dir == bundled_build
    assert by_folder.manifest == by_file.manifest


def test_a_missing_build_is_one_line(tmp_path: Path) -> None:
    with pytest.raises(UserError, match="nowhere: no such folder"):
        resolve_build(tmp_path / "nowhere")
    (tmp_path / "empty").mkdir()
    with pytest.raises(UserError, match="no manifest"):
        resolve_build(tmp_path / "empty")


def test_a_run_folder_given_for_a_build_is_named_as_one_with_the_build_it_ran(tmp_path: Path) -> None:
    """A trial user gave ``bimbot run`` the run folder and read "no manifest"."""
    run = tmp_path / "house" / "runs" / "20261202-1"
    (run / "report").mkdir(parents=True)
    (run / "report" / "report.json").write_text("{}")
    build = tmp_path / "house"
    message = f"{run}: a run folder (what bimbot run wrote), not a build; give the build it ran: {build}"
    with pytest.raises(UserError) as raised:
        resolve_build(run)
    assert str(raised.value) == message
    elsewhere = tmp_path / "mine"
    elsewhere.mkdir()
    (elsewhere / "ENDED").write_text("done\n")
    with pytest.raises(UserError, match=r"mine: a run folder .* \(the folder bimbot convert -o wrote\)$"):
        resolve_build(elsewhere)


def test_an_unwritable_output_folder_is_a_user_error(tmp_path: Path) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    with pytest.raises(UserError, match="--rrd"):
        writable_dir(blocker / "observer", "--rrd")


class _Strict(BaseModel):
    count: int


def _raise_validation_error(_args: argparse.Namespace) -> int:
    _Strict.model_validate(json.loads('{"count": "many"}'))  # a bug: pydantic's ValidationError
    return 0


def _add_nothing(_parser: argparse.ArgumentParser) -> None:
    pass


def test_a_validation_error_inside_a_command_is_a_traceback_and_exit_1_not_exit_2(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    module = type(sys)("fake_buggy_service")
    module.add_arguments = _add_nothing  # type: ignore[attr-defined]
    module.run = _raise_validation_error  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "fake_buggy_service", module)
    monkeypatch.setitem(bimbot.command_line.SUBCOMMANDS, "buggy", ("fake_buggy_service", "raises a bug"))
    with caplog.at_level(logging.ERROR):
        assert bimbot.cli.main(["buggy"]) == bimbot.cli.EXIT_BUG == 1
    [record] = [r for r in caplog.records if r.exc_info]
    assert bimbot.cli.BUG_MARK in record.getMessage()
    assert record.exc_info[0].__name__ == "ValidationError"


def test_a_user_error_inside_a_command_stays_one_line_and_exit_2(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    def bad_input(_args: argparse.Namespace) -> int:
        raise UserError("--sequence nope.xml: no such file")

    module = type(sys)("fake_picky_service")
    module.add_arguments = _add_nothing  # type: ignore[attr-defined]
    module.run = bad_input  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "fake_picky_service", module)
    monkeypatch.setitem(bimbot.command_line.SUBCOMMANDS, "picky", ("fake_picky_service", "rejects its input"))
    with caplog.at_level(logging.ERROR):
        assert bimbot.cli.main(["picky"]) == 2
    assert not any(r.exc_info for r in caplog.records)


def test_a_reader_that_went_away_ends_a_command_quietly_not_as_a_bug() -> None:
    """``bimbot runs | head -1``: the pipe's reader is gone before the command writes; exit 141 as a shell
    says for SIGPIPE, and no traceback labelled a bug."""
    read_end, write_end = os.pipe()
    os.close(read_end)
    try:
        done = subprocess.run(
            [sys.executable, "-m", "bimbot.cli", "fleet", "show"],
            stdout=write_end,
            stderr=subprocess.PIPE,
            text=True,
            timeout=120,
            check=False,
        )
    finally:
        os.close(write_end)
    assert done.returncode == bimbot.cli.EXIT_BROKEN_PIPE == 141, done.stderr
    assert "Traceback" not in done.stderr and bimbot.cli.BUG_MARK not in done.stderr, done.stderr


def test_a_service_logs_its_peak_memory_and_cpu_time_as_it_ends(caplog: pytest.LogCaptureFixture) -> None:
    """``bench/build.py`` reads both per service: where two cores' time goes in a build of a dozen."""
    import time

    from bimbot.shared.service_runner import run_service

    def busy(stop: object) -> int:
        until = time.process_time() + 0.2
        while time.process_time() < until:
            pass
        return 0

    with caplog.at_level(logging.INFO, logger="bimbot.shared.service_runner"):
        assert run_service(busy) == 0
    (line,) = [r.getMessage() for r in caplog.records if "peak memory" in r.getMessage()]
    cpu_s = float(line.rsplit("CPU ", 1)[1].removesuffix(" s"))
    assert cpu_s >= 0.2
