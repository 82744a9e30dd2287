"""A bounded wait on a condition, polled: what the starters of processes wait for (a socket, a file, a
child's answer) has no event to wait on."""

from __future__ import annotations

import time
from collections.abc import Callable


def wait_until(condition: Callable[[], bool], timeout_s: float, interval_s: float = 0.05) -> bool:
    """True once ``condition()`` is, False when ``timeout_s`` (wall s) passed first."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(interval_s)
    return False
