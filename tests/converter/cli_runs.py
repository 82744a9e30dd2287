"""``bimbot`` for the converter's command-line tests, two ways: as a real process (``bimbot_process``) or by
calling ``bimbot.cli.main`` in the test's own process (``bimbot_in_process``). Both answer with the exit
code, stdout and stderr.

A real ``python -m bimbot.cli`` spends seconds importing before it converts anything. A test whose subject
is what the command does (its summary, an option, the exit code ``main`` maps an outcome to) calls ``main``
here. What only a real process shows — its exit status, a user error as one line on a stderr that nothing
else writes to (no import noise, no traceback) — keeps a real process for each kind of user error.

In this process the stderr is what reached file descriptor 2 (``main``'s own error line, anything a C
library printed) followed by the log records ``main``'s logging would print, WARNING and above (the default
verbosity of ``convert``), in its format, tracebacks included. pytest's log handlers are on the root logger,
so ``main``'s ``logging.basicConfig`` adds none of its own; the records come from ``caplog``.
"""

from __future__ import annotations

import logging
import subprocess
import sys
from dataclasses import dataclass

import pytest
from wall_clock import bound_s

from bimbot.cli import PLAIN_FORMAT, main

LOG_FORMAT = PLAIN_FORMAT  # what a command prints of its warnings (bimbot.cli.log_format)


@dataclass(frozen=True)
class Ended:
    """How a ``bimbot`` command ended: what ``subprocess.run`` tells of a process, for either way."""

    returncode: int
    stdout: str
    stderr: str


def bimbot_process(*args: str) -> Ended:
    """``python -m bimbot.cli ARGS`` as a process of its own."""
    done = subprocess.run(
        [sys.executable, "-m", "bimbot.cli", *args],
        capture_output=True,
        text=True,
        timeout=bound_s(300),
        check=False,
    )
    return Ended(done.returncode, done.stdout, done.stderr)


def bimbot_in_process(
    *args: str, capfd: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> Ended:
    """``bimbot.cli.main(ARGS)`` in this process: its return code, what it printed and logged (see module)."""
    capfd.readouterr()
    caplog.clear()
    with caplog.at_level(logging.WARNING):
        try:
            code = main(list(args))
        except SystemExit as stopped:  # argparse's own exits (a bad option, --help)
            code = stopped.code if isinstance(stopped.code, int) else int(stopped.code is not None)
    printed = capfd.readouterr()
    formatter = logging.Formatter(LOG_FORMAT)
    logged = "".join(f"{formatter.format(record)}\n" for record in caplog.records)
    return Ended(code, printed.out, printed.err + logged)
