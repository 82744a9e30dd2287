"""Connections made and temporary supports standing: the record physics keeps of both, and when a support
may go.

A member set down at its target is connected to the built neighbours its manifest links name
(``Component.connection_links``: bolted base, pinned or fixed end, bearing, grouted; :mod:`.connections`
chooses what is made). A fixing connection holds from ``ready_at_s`` on (made after its crew time; a
grouted one once its grout has set). A member that cannot stand until its frame closes
(``Component.temporary_support``: props on a precast wall panel, braces on a slender column with no
fixed base) is supported by them from its release: in physics it is held where it was set (static, as a
fixed constraint to the ground makes it), and its robot's task includes setting them. That holds for a
member set down off its target too (no connection is made: the holes miss): it stands propped where it
was set until a robot takes it up again for its retry (:meth:`SupportRecord.take_up`).

A support is removed once the member stands without it: its fixing connections that hold reach, through
other members' fixing connections that hold, something that stands by itself (in place from the start,
cast or laid where it stands). A bearing is no such path (friction carries no pull), and members on the
way may still be supported themselves (their supports stay). Then the member is held by its connections
alone (static, joined to a static structure). The record keeps every support's placing and removal for
the report: how many were used, most at once, how long each stood.
"""

from __future__ import annotations

import logging
import math
from collections import deque
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

from bimbot.shared.connection_kinds import ConnectionKind, SupportKind, TemporarySupportNeed

_log = logging.getLogger(__name__)


@dataclass
class StandingSupport:
    """The temporary supports of one member: ``count`` of ``kind``, set at ``placed_s``."""

    guid: str
    kind: SupportKind
    count: int
    placed_s: float
    removed_s: float | None = None


@dataclass
class SupportRecord:
    """What physics knows of connections made and temporary supports, for the whole run."""

    # GUID → other GUID → when the fixing connection between the two holds (sim s), both ways round
    holds_at_s: dict[str, dict[str, float]] = field(default_factory=dict)
    kinds: dict[str, dict[str, ConnectionKind]] = field(default_factory=dict)  # made, GUID → other → kind
    standing: dict[str, StandingSupport] = field(default_factory=dict)
    history: list[StandingSupport] = field(default_factory=list)  # every support set, in order
    most_at_once: int = 0  # supports standing at once, at most

    def connect(
        self, guid: str, kinds: Mapping[str, ConnectionKind], holds_at_s: Mapping[str, float]
    ) -> None:
        """``guid`` was connected to ``kinds`` (other → kind); its fixing ones hold from ``holds_at_s``."""
        self.kinds.setdefault(guid, {}).update(kinds)
        for other, at_s in holds_at_s.items():
            self.holds_at_s.setdefault(guid, {})[other] = at_s
            self.holds_at_s.setdefault(other, {})[guid] = at_s

    def place(self, guid: str, need: TemporarySupportNeed, now_s: float) -> StandingSupport:
        support = StandingSupport(guid, need.kind, need.count, now_s)
        self.standing[guid] = support
        self.history.append(support)
        self.most_at_once = max(self.most_at_once, sum(s.count for s in self.standing.values()))
        return support

    def count(self, guid: str) -> int:
        support = self.standing.get(guid)
        return support.count if support is not None else 0

    def removable(self, now_s: float, anchors: Iterable[str]) -> list[str]:
        """The supported members that now stand without their supports (in GUID order)."""
        anchor_set = set(anchors)
        return [guid for guid in sorted(self.standing) if anchored(guid, self.holds_at_s, anchor_set, now_s)]

    def take_up(self, guid: str, now_s: float) -> StandingSupport | None:
        """A robot takes ``guid`` up again (its retry): its connections are undone, both ways round, and
        its supports come away; the supports it stood on, if any."""
        for other in self.holds_at_s.pop(guid, {}):
            self.holds_at_s.get(other, {}).pop(guid, None)
        for other in self.kinds.pop(guid, {}):
            self.kinds.get(other, {}).pop(guid, None)
        return self.remove(guid, now_s)

    def remove(self, guid: str, now_s: float) -> StandingSupport | None:
        support = self.standing.pop(guid, None)
        if support is not None:
            support.removed_s = now_s
        return support


def anchored(
    guid: str, holds_at_s: Mapping[str, Mapping[str, float]], anchors: set[str], now_s: float = math.inf
) -> bool:
    """Whether ``guid``'s fixing connections that hold by ``now_s`` reach one of ``anchors`` (breadth
    first through other members' holding connections)."""
    seen, queue = {guid}, deque([guid])
    while queue:
        here = queue.popleft()
        for other, at_s in holds_at_s.get(here, {}).items():
            if at_s > now_s or other in seen:
                continue
            if other in anchors:
                return True
            seen.add(other)
            queue.append(other)
    return False
