"""Connections made and temporary supports, as physics' component poses tell them (pure, for report.json).

Physics says, in every component's pose message, the built neighbours it was connected to and how
(``connection_kinds``: bolted_base, pinned_end, fixed_end, bearing, grouted, fastened) and how many
temporary supports stand on it now (``temporary_supports``: props or braces). :class:`SupportsSeen` keeps
the latest kinds and every span a member stood on supports; the report gives per component
``connections`` (GUID → kind) and ``temporary_supports`` (how many, from when to when), and in its totals
the supports used, the most standing at once, and how long each stood (until the end of the run for those
still standing).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Any

from bimbot.shared.messages import ComponentPoseMsg


@dataclass
class SupportSpan:
    count: int
    from_s: float
    to_s: float | None = None  # None: still standing


@dataclass
class SupportsSeen:
    kinds: dict[str, dict[str, str]] = field(default_factory=dict)  # GUID → other GUID → kind
    spans: dict[str, list[SupportSpan]] = field(default_factory=dict)  # GUID → its spans on supports

    def take(self, msg: ComponentPoseMsg) -> None:
        if msg.connection_kinds:
            self.kinds[msg.guid] = dict(msg.connection_kinds)
        spans = self.spans.get(msg.guid)
        open_span = spans[-1] if spans and spans[-1].to_s is None else None
        if msg.temporary_supports and open_span is None:
            self.spans.setdefault(msg.guid, []).append(SupportSpan(msg.temporary_supports, msg.sim_time_s))
        elif not msg.temporary_supports and open_span is not None:
            open_span.to_s = max(msg.sim_time_s, open_span.from_s)

    def entry(self, guid: str, end_s: float) -> dict[str, Any]:
        """The component's ``connections`` and ``temporary_supports`` entries."""
        return {
            "connections": dict(sorted(self.kinds.get(guid, {}).items())),
            "temporary_supports": [
                {
                    "count": span.count,
                    "placed_s": span.from_s,
                    "removed_s": span.to_s,
                    "stood_s": (span.to_s if span.to_s is not None else end_s) - span.from_s,
                }
                for span in self.spans.get(guid, [])
            ],
        }

    def totals(self, end_s: float) -> dict[str, Any]:
        """Connections by kind; temporary supports used, most at once, and how long each member's stood."""
        by_kind = Counter(kind for kinds in self.kinds.values() for kind in kinds.values())
        events = sorted(
            (time_s, delta)
            for spans in self.spans.values()
            for span in spans
            for time_s, delta in (
                (span.from_s, span.count),
                (span.to_s if span.to_s is not None else end_s + 1.0, -span.count),
            )
        )
        standing = most = 0
        for _, delta in sorted(events, key=lambda event: (event[0], event[1])):  # removals first at a tie
            standing += delta
            most = max(most, standing)
        stood = {
            guid: sum((span.to_s if span.to_s is not None else end_s) - span.from_s for span in spans)
            for guid, spans in sorted(self.spans.items())
        }
        return {
            "connections_by_kind": dict(sorted(by_kind.items())),
            "temporary_supports": {
                "used": sum(span.count for spans in self.spans.values() for span in spans),
                "members": len(self.spans),
                "most_at_once": most,
                "standing_at_end": sum(
                    span.count for spans in self.spans.values() for span in spans if span.to_s is None
                ),
                "stood_s_by_member": stood,
            },
        }
