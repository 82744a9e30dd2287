"""``bimbot run`` restarts a service that dies, as ``docker compose`` does: bounded, with backoff, reported.

A service process that exits while the run goes on (killed, crashed, out of memory) is started again with
the same command line (:meth:`bimbot.supervisor.ServiceProcess.restart`; the agents without ``--fresh``,
so they resume from their journal) after a backoff that doubles with each restart of that service
(``first_backoff_s``, 2×, 4×, … at most ``max_backoff_s``). A service that died ``max_restarts`` times
ends the run as before: "… stopped unexpectedly", with the tail of its log. The planner's own verdicts
(exit 0/1 with ``--exit-when-done``) and its input error (exit 2) are endings, not deaths.

Every death is a :class:`Restart` record; the report lists them (``report.json`` ``restarts``) and the
summary names them. A restarted service rebuilds its view from the owners of each fact (physics from its
record and the twins, the planner and robots from the twins and physics, the agents from their journal):
see ``docs/architecture.md``, "Restart is normal".

Pure: the loop passes the time and the process in.
"""

from __future__ import annotations

import logging
from collections import Counter
from dataclasses import asdict, dataclass, field
from typing import Protocol

from bimbot.shared.report.durations import duration_text

_log = logging.getLogger(__name__)


class Restartable(Protocol):
    name: str

    def restart(self) -> None: ...


@dataclass(frozen=True)
class RestartPolicy:
    max_restarts: int = 3  # per service and run; 0: a dead service ends the run
    first_backoff_s: float = 1.0
    max_backoff_s: float = 30.0

    def backoff_s(self, restarts_so_far: int) -> float:
        return min(self.max_backoff_s, self.first_backoff_s * 2.0**restarts_so_far)


@dataclass
class Restart:
    """One death of a service during a run, and what the run did about it."""

    service: str
    exit_code: int | None
    died_wall_s: float  # since the run started
    died_sim_time_s: float
    restarted_wall_s: float | None = None  # None: not (yet) restarted

    def line(self) -> str:
        code = "killed by a signal" if self.exit_code is not None and self.exit_code < 0 else None
        how = f"exit {self.exit_code}" + (f", {code}" if code else "")
        if self.restarted_wall_s is None:
            then = "not restarted"
        else:
            then = f"restarted {duration_text(self.restarted_wall_s - self.died_wall_s)} later"
        return f"{self.service} died ({how}) at sim {duration_text(self.died_sim_time_s)}, {then}"


@dataclass
class Restarter:
    """Decides, per dead service, whether and when it is started again; keeps the records."""

    policy: RestartPolicy = field(default_factory=RestartPolicy)
    records: list[Restart] = field(default_factory=list)
    _counts: Counter[str] = field(default_factory=Counter)
    _pending: dict[str, tuple[float, Restart]] = field(default_factory=dict)  # name → (due wall s, record)

    def keep_going(
        self, service: Restartable, exit_code: int | None, wall_s: float, sim_time_s: float
    ) -> bool:
        """``service`` is not running: True while it is (or will be) restarted, False when the run must
        end because it died once too often."""
        name = service.name
        pending = self._pending.get(name)
        if pending is None:
            if self._counts[name] >= self.policy.max_restarts:
                self.records.append(Restart(name, exit_code, wall_s, sim_time_s))
                return False
            record = Restart(name, exit_code, wall_s, sim_time_s)
            self.records.append(record)
            due = wall_s + self.policy.backoff_s(self._counts[name])
            self._pending[name] = (due, record)
            _log.warning(
                "%s died (exit %s) at sim %.1f s; restarting it in %.1f s",
                name,
                exit_code,
                sim_time_s,
                due - wall_s,
            )
            return True
        due, record = pending
        if wall_s >= due:
            del self._pending[name]
            self._counts[name] += 1
            record.restarted_wall_s = wall_s
            service.restart()
            _log.warning(
                "%s restarted (%d of at most %d)", name, self._counts[name], self.policy.max_restarts
            )
        return True

    def restarts(self, name: str) -> int:
        return self._counts[name]

    def report(self) -> list[dict]:
        """The records for ``report.json``."""
        return [asdict(record) for record in self.records]

    def summary_lines(self) -> list[str]:
        return [record.line() for record in self.records]
