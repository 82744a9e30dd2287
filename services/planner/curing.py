"""Curing holds: what rests on a cast-in-place element waits until it has cured (pure).

Why: concrete carries load only after it has cured. A component whose predecessor in the plan is cast in
place is released only once that predecessor has been constructed for its ``cast.cure_s`` of sim time.
The planner records when each cast component became constructed (the sim time of the state change: the
state message's, or the constructed record in its twin's history, so a restarted planner rebuilds every
hold from the twins it syncs at start) and asks :class:`CuringHolds` which predecessors still hold.

Times are sim seconds. A time learnt twice keeps the earlier one: a twin's history is exact, while a
component seen constructed without one (a twin with no history) is taken as constructed when it was
seen, which can only be later (the hold is then longer, never shorter).
"""

from __future__ import annotations

import logging
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

from bimbot.shared.messages import ComponentState, TwinMsg

_log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Hold:
    """``guid`` waits for ``cast_guid`` to cure, until ``until_s`` (sim s)."""

    guid: str
    cast_guid: str
    until_s: float


@dataclass
class CuringHolds:
    """When each cast component was constructed and until when it cures (``cure_s``: GUID → seconds)."""

    cure_s: Mapping[str, float]
    constructed_s: dict[str, float] = field(default_factory=dict)

    def constructed(self, guid: str, sim_s: float) -> None:
        """``guid`` was constructed at ``sim_s`` (the earlier of two accounts is kept)."""
        if guid in self.cure_s:
            known = self.constructed_s.get(guid)
            self.constructed_s[guid] = sim_s if known is None else min(known, sim_s)

    def cured_at_s(self, guid: str) -> float | None:
        """When ``guid`` has cured (None: not cast, or not constructed yet)."""
        at = self.constructed_s.get(guid)
        return None if at is None else at + self.cure_s[guid]

    def holding(self, guid: str, predecessors: Iterable[str], now_s: float) -> Hold | None:
        """The hold on ``guid`` at ``now_s``: its constructed cast predecessor that cures last, if any
        cures after ``now_s``."""
        latest: Hold | None = None
        for pred in sorted(predecessors):
            until = self.cured_at_s(pred)
            if until is not None and until > now_s and (latest is None or until > latest.until_s):
                latest = Hold(guid, pred, until)
        return latest


def constructed_time_s(twin: TwinMsg) -> float | None:
    """The sim time of the twin's (last) change to constructed, from its history; None when it has none."""
    for record in reversed(twin.history):
        if record.state is ComponentState.CONSTRUCTED:
            return record.sim_time_s
    return None
