"""The ``bimbot`` console script: one sub-command per service, each a thin adapter living beside its service.

The command line is parsed by :mod:`bimbot.command_line`, which imports only the chosen sub-command. A
:class:`bimbot.shared.errors.UserError` ends in one clear line (``bimbot run: error: …``, as a bad option's)
and exit code 2, never a traceback. Any other exception is a bug: its traceback is logged to stderr (a
service's log file under ``bimbot run``, which shows its tail) and the exit code is 1. Commands check the
user's input before they start their work, so a bug is never reported as bad input.
"""

from __future__ import annotations

import importlib
import logging
import os
import sys

from bimbot.child_process import stop_with_parent
from bimbot.command_line import EXIT_USER_ERROR, SERVICE_COMMANDS, parse_arguments
from bimbot.shared.errors import UserError

_log = logging.getLogger("bimbot")

EXIT_BUG = 1  # an unexpected exception: its traceback is in the log
EXIT_BROKEN_PIPE = 141  # as a shell reports a command killed by SIGPIPE (128 + 13)
BUG_MARK = "failed with an unexpected error"  # in the log line above the traceback (bimbot run looks for it)


def log_verbosity(command: str, verbose: int, quiet: bool) -> int:
    """The verbosity :func:`configure_logging` takes for ``command``: -1 (warnings) with ``-q``; for a
    service 0 (INFO) plus each ``-v``; for any other command (convert, run, compare …) -1 plus each ``-v``:
    a user reads its summary on stdout, not the INFO lines of its steps (``-v`` shows them)."""
    if quiet:
        return -1
    return verbose if command in SERVICE_COMMANDS else verbose - 1


NAMED_FORMAT = "%(levelname)s %(name)s: %(message)s"  # a service's log, or a command's with -v
PLAIN_FORMAT = "%(levelname)s: %(message)s"  # a command's warnings as its user reads them


def log_format(command: str, verbosity: int) -> str:
    """A service's log lines name their module (its log is read to debug it), and so do a command's with
    ``-v``; a command's warnings (convert, run, fleet …) read as plain lines: ``WARNING: IfcSlab …``."""
    return NAMED_FORMAT if command in SERVICE_COMMANDS or verbosity >= 0 else PLAIN_FORMAT


def configure_logging(verbosity: int, log_format: str = NAMED_FORMAT) -> None:
    """Configure the root logger once, from ``main`` only (libraries just call ``getLogger``)."""
    level = logging.WARNING if verbosity < 0 else logging.INFO if verbosity == 0 else logging.DEBUG
    logging.basicConfig(level=level, format=log_format, stream=sys.stderr)
    if level > logging.DEBUG:
        # transitions logs every state entry and exit at INFO: thousands of lines a second in the agents,
        # most of a robot's log; the services log their own transitions where they matter
        logging.getLogger("transitions").setLevel(logging.WARNING)


def main(argv: list[str] | None = None) -> int:
    """Parse ``argv``, run the chosen sub-command and map how it ended to the exit code."""
    argv = sys.argv[1:] if argv is None else argv
    stop_with_parent()
    args = parse_arguments(argv)
    verbosity = log_verbosity(args.command, args.verbose, args.quiet)
    configure_logging(verbosity, log_format(args.command, verbosity))
    module = importlib.import_module(args._module)
    try:
        code = int(module.run(args) or 0)
        sys.stdout.flush()  # a reader gone (below) is found here, not in the interpreter's last flush
        return code
    except UserError as error:  # the same one-line form as a bad option's (OneLineErrorParser)
        sys.stderr.write(f"bimbot {args.command}: error: {error}\n")
        return EXIT_USER_ERROR
    except KeyboardInterrupt:
        _log.error("interrupted")
        return 130
    except BrokenPipeError:  # its reader went away (``bimbot runs | head``): nothing more to say, and no bug
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # Python's exit flush fails quietly
        return EXIT_BROKEN_PIPE
    except Exception:  # a bug: keep the traceback for the log, not the "bad input" exit code
        _log.exception("bimbot %s %s (a bug; traceback follows)", args.command, BUG_MARK)
        return EXIT_BUG


if __name__ == "__main__":
    sys.exit(main())
