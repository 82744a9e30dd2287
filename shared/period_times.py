"""Where a service's wall time goes per control period, for its status lines.

Physics sums the wall time of stepping, publishing and waiting for the robots; a robot that of answering
the step and of the work done after the answer. Between two status lines the loop adds to the sums and the
line reports their means per period (``docs/performance.md`` quotes them). Pure: the loop passes seconds.
"""

from __future__ import annotations


class PeriodTimes:
    """Wall seconds per control period by kind (``advance``, ``publish``, ``wait`` …) since the last
    :meth:`take`; the loop adds to them, the status line reports their means."""

    def __init__(self) -> None:
        self._sums: dict[str, float] = {}
        self.periods = 0

    def add(self, kind: str, seconds: float) -> None:
        self._sums[kind] = self._sums.get(kind, 0.0) + seconds

    def period(self) -> None:
        self.periods += 1

    def take(self) -> str:
        """``advance 2.91 ms, publish 0.21 ms, wait 1.30 ms per period (n periods)``, then start again."""
        periods = max(1, self.periods)
        text = ", ".join(f"{kind} {total / periods * 1e3:.2f} ms" for kind, total in self._sums.items())
        text = f"{text or 'nothing'} per period ({self.periods} periods)"
        self._sums, self.periods = {}, 0
        return text
