"""The planner's preparation, told on the bus while it lasts (``planner/preparing``).

Before it hands out work the planner checks the plan for site access: on a large building that takes
minutes, and the clock waits at 0 meanwhile. Physics and the run bound that wait in wall time, and would
take a planner that is still working for one that hung. So the steps of the preparation report here as
they advance; a report goes out when the stage changes and at most every ``every_s`` wall seconds within a
stage. Reports come from the work itself, not from a timer: a planner that hangs stops reporting, and the
bounds still end the run.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

from bimbot.shared.messages import PreparingMsg

Report = Callable[[str, int, int], None]  # (stage, done, total)


def no_report(stage: str, done: int, total: int) -> None:
    """A preparation nobody waits for (offline checks, tests)."""


@dataclass
class PreparationReporter:
    """A :data:`Report` that publishes :class:`PreparingMsg` through ``publish``, throttled."""

    publish: Callable[[PreparingMsg], None]
    every_s: float = 2.0
    clock: Callable[[], float] = time.monotonic
    _stage: str | None = None
    _last_s: float = float("-inf")

    def __call__(self, stage: str, done: int, total: int) -> None:
        now = self.clock()
        if stage == self._stage and now - self._last_s < self.every_s:
            return
        self._stage, self._last_s = stage, now
        self.publish(PreparingMsg(stage=stage, done=done, total=max(done, total)))
