"""The lock-step waits of a run that ran out their bound, from its service logs: each one is a hang.

Every participant logs a step it took without an answer that never came (physics "no command for step …",
"goes on without the twins of …", the planner and the agents "step N taken without …", a robot "step N
ticked without …"). A restart, even of a router, is ridden out within its own start-up: physics says the
open step again while it waits, a participant that rejoins takes the first step it hears, and a twin's
question that got no answer is asked again. So a test of restarts asserts that no wait ran out.
"""

from __future__ import annotations

import re
from pathlib import Path

_RAN_OUT = re.compile(
    r"lock-step: (no command for step \d+|step \d+ (taken|ticked|goes on) without|going on without)"
)


def waits_that_ran_out(logs_dir: Path) -> list[str]:
    """Every log line (``<log>: <line>``) of ``logs_dir`` that says a lock-step wait ran out."""
    return [
        f"{log.name}: {line}"
        for log in sorted(logs_dir.glob("*.log"))
        for line in log.read_text(encoding="utf-8", errors="replace").splitlines()
        if _RAN_OUT.search(line)
    ]
