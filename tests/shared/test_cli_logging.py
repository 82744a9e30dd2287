"""The log levels: a command (convert, run, compare …) logs warnings unless ``-v``, a service INFO; the
transitions library's INFO line for every state entry and exit (most of a robot's log, thousands of lines a
second in the agents) is left out unless ``-v`` asks for debug."""

from __future__ import annotations

import logging
import subprocess
import sys
from pathlib import Path

import pytest
from wall_clock import bound_s

from bimbot.cli import NAMED_FORMAT, PLAIN_FORMAT, configure_logging, log_format, log_verbosity
from bimbot.data.light_steel_frame import build_light_steel_frame


@pytest.mark.parametrize(("verbosity", "shown"), [(-1, False), (0, False), (1, True)])
def test_state_machine_chatter_is_left_out_of_the_logs_unless_debugging(verbosity: int, shown: bool) -> None:
    chatter = logging.getLogger("transitions.core")
    logging.getLogger("transitions").setLevel(logging.NOTSET)
    root = logging.getLogger()
    level = root.level
    try:
        configure_logging(verbosity)
        root.setLevel(logging.DEBUG if verbosity > 0 else logging.INFO)  # basicConfig acts only once
        assert chatter.isEnabledFor(logging.INFO) is shown
        assert chatter.isEnabledFor(logging.WARNING)
    finally:
        root.setLevel(level)
        logging.getLogger("transitions").setLevel(logging.NOTSET)


@pytest.mark.parametrize(
    ("command", "verbose", "quiet", "level"),
    [
        ("convert", 0, False, logging.WARNING),  # a command: its summary on stdout, no INFO lines
        ("convert", 1, False, logging.INFO),
        ("convert", 2, False, logging.DEBUG),
        ("run", 0, False, logging.WARNING),
        ("compare", 0, False, logging.WARNING),
        ("physics", 0, False, logging.INFO),  # a service: its log is its output (a file under bimbot run)
        ("robot", 1, False, logging.DEBUG),
        ("physics", 0, True, logging.WARNING),
    ],
)
def test_commands_log_warnings_unless_verbose_and_services_log_info(
    command: str, verbose: int, quiet: bool, level: int
) -> None:
    verbosity = log_verbosity(command, verbose, quiet)
    assert (logging.WARNING if verbosity < 0 else logging.INFO if verbosity == 0 else logging.DEBUG) == level


def test_convert_prints_its_summary_and_no_info_lines_unless_verbose(tmp_path: Path) -> None:
    model = tmp_path / "frame.ifc"
    build_light_steel_frame(3, 3).write(str(model))  # the bundled frame: a line per framed joint at INFO

    def convert(*options: str) -> subprocess.CompletedProcess[str]:
        command = [sys.executable, "-P", "-m", "bimbot.cli", *options, "convert", str(model)]
        command += ["-o", str(tmp_path / "out"), "--no-progress"]
        return subprocess.run(command, capture_output=True, text=True, check=False, timeout=bound_s(300))

    plain = convert()
    assert plain.returncode == 0, plain.stderr
    assert plain.stdout.startswith("converted 28 component(s)")
    assert "INFO" not in plain.stderr, plain.stderr
    verbose = convert("-v")
    assert verbose.stdout.startswith("converted 28 component(s)")
    assert "INFO bimbot.services.converter" in verbose.stderr


def test_a_command_s_warnings_read_as_plain_lines_and_a_service_s_name_their_module(tmp_path: Path) -> None:
    """``WARNING bimbot.services.converter.cli: IfcWall …`` put a module path before what a user reads."""
    assert log_format("convert", log_verbosity("convert", 0, False)) == PLAIN_FORMAT
    assert log_format("convert", log_verbosity("convert", 1, False)) == NAMED_FORMAT  # -v: to debug
    assert log_format("physics", log_verbosity("physics", 0, True)) == NAMED_FORMAT
    source = Path(__file__).parents[1] / "converter" / "broken" / "duplicate_guids.ifc"
    command = [sys.executable, "-P", "-m", "bimbot.cli", "convert", str(source), "-o", str(tmp_path / "out")]
    done = subprocess.run(
        [*command, "--no-progress"], capture_output=True, text=True, check=False, timeout=bound_s(300)
    )
    assert done.returncode == 0, done.stderr
    assert "WARNING: IfcWall 'Wall 1' (1nnj1oeev0ShCcNmCt8M94): no material" in done.stderr, done.stderr
