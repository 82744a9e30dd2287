"""``bimbot run``'s input check, run in a child of the fork server instead of in ``bimbot run`` itself.

The check (:func:`bimbot.run.preflight.check_run_input`) parses every service's command line with that
service's own parser and checks it with the service's own code, so it imports what the services import:
physics, the planner, scipy and numba, 0.4–0.5 s of CPU. The fork server imports the same modules at the
same moment to start the services from them. Done in ``bimbot run``, the two imported everything twice at
once on two cores, and the bus router, started as a plain process meanwhile, took 0.6 s to listen. So the
run asks the server for the check: the server forks a child that has everything imported already, the
child checks and answers, and the run goes on (or stops with the check's one line) as if it had checked
itself. The bus router is then forked too, in a blink.

The answer is one JSON line: ``{"checked": token, "ok": true}``, ``{"checked": token, "user_error":
"…"}`` (the one line a user sees, exit 2), or ``{"checked": token, "failed": "traceback"}`` when the check
itself broke; the warnings the check logged travel with it and are logged again in the run. Without an
answer (no server, a child that died, none within :data:`bimbot.fork_server.CHECK_TIMEOUT_S`) the run checks
in its own process, as it always could.
"""

from __future__ import annotations

import base64
import logging
import os
import pickle
import traceback
import uuid
from pathlib import Path
from typing import TYPE_CHECKING, Any

from bimbot.shared.errors import UserError

if TYPE_CHECKING:
    from bimbot.run.options import RunOptions

_log = logging.getLogger(__name__)

MAX_WARNINGS = 50  # an answer stays a short line, whatever the check logged


def check_request(build: Path, options: RunOptions) -> dict[str, Any]:
    """The request a fork server answers by checking ``build`` and ``options`` in a child."""
    payload = base64.b64encode(pickle.dumps((build, options))).decode("ascii")
    return {
        "check": uuid.uuid4().hex,
        "payload": payload,
        "cwd": os.getcwd(),
        "env": dict(os.environ),
    }


class _Collected(logging.Handler):
    """The warnings (and worse) the check logs, to be logged again in the run."""

    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.records: list[list[Any]] = []

    def emit(self, record: logging.LogRecord) -> None:
        if len(self.records) < MAX_WARNINGS:
            self.records.append([record.name, record.levelno, record.getMessage()])


def answer_check(request: dict[str, Any]) -> dict[str, Any]:
    """In the server's child: run the check the request asks for; the answer to send back."""
    from bimbot.run.preflight import check_run_input

    token = request["check"]
    os.environ.clear()
    os.environ.update(request["env"])
    os.chdir(request["cwd"])
    collected = _Collected()
    root = logging.getLogger()
    root.addHandler(collected)
    root.setLevel(logging.WARNING)
    try:
        build, options = pickle.loads(base64.b64decode(request["payload"]))
        check_run_input(build, options)
    except UserError as error:
        return {"checked": token, "user_error": str(error), "warnings": collected.records}
    except Exception:
        return {"checked": token, "failed": traceback.format_exc(), "warnings": collected.records}
    finally:
        root.removeHandler(collected)
    return {"checked": token, "ok": True, "warnings": collected.records}


def apply_answer(answer: dict[str, Any]) -> bool:
    """In the run: log the check's warnings again and raise its :class:`UserError`; whether the input was
    checked (False: the check itself failed, so the run checks in its own process)."""
    if "user_error" not in answer and not answer.get("ok"):  # "failed", or an answer of no known kind
        _log.debug("the fork server's input check failed; checking here:\n%s", answer.get("failed"))
        return False
    for name, level, message in answer.get("warnings", ()):
        logging.getLogger(name).log(level, "%s", message)
    if "user_error" in answer:
        raise UserError(answer["user_error"])
    return True
