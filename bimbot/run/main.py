"""``bimbot run OUT/``: the command's entry (its options, the build, the summary and the exit code).

The run itself is :func:`bimbot.run.build.run_build`; ``--check-stability`` replays the plan without
robots instead (:mod:`bimbot.run.stability`). Exit codes: 0 when every component is constructed; 1
otherwise (failed, blocked, stalled, timed out, a service died); 128 + the signal when stopped (130 after
SIGINT, 143 after SIGTERM); 2 for unusable input.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from bimbot.run.build import run_build
from bimbot.run.options import add_run_arguments, run_options
from bimbot.run.summary import RunOutcome, summary_text


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("build", type=Path, help="a converted build folder (bimbot convert … -o BUILD)")
    add_run_arguments(parser)


def run(args: argparse.Namespace) -> int:
    if getattr(args, "check_stability", False):
        from bimbot.run.stability import check_stability_command

        return check_stability_command(args, say)
    return finish(run_build(args.build, run_options(args), announce=say))


def say(line: str) -> None:
    """One line for the user on stdout, at once (the commands' output; logs go to stderr)."""
    sys.stdout.write(line + "\n")
    sys.stdout.flush()


def finish(outcome: RunOutcome) -> int:
    """Print the summary (unless it went out already) and return the exit code."""
    if not outcome.summary_announced:
        sys.stdout.write(summary_text(outcome))
    return outcome.exit_code
