"""Terminal state claims awaiting their twin's answer in a lock-step run (pure).

Why: a message that says a component is constructed, failed or blocked is only a claim; a lock-step
participant takes it at its step once the component's twin confirms it (:mod:`.step_gate`). A claim the
twin does not confirm must not hold the steps for ever: a forged or stale message, or a flood of them,
would otherwise stop the site (every later step waiting out its hold). So:

* every claim of a component is kept until answered (a newer claim does not orphan an older one);
* the twin is asked again while it says otherwise, at most ``MAX_ASKS`` times per component (an agent's
  twin may lag its own message by a moment);
* then every claim it still contradicts is settled by what the twin says: the twin is the truth;
* a question that got no answer at all (lost with a router that restarted under it) is asked again while
  a step waits for its claim (:meth:`TwinClaims.ask_again`), not only once the step's bound ran out.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

from .messages import ComponentStateMsg, TwinMsg

_log = logging.getLogger(__name__)

MAX_ASKS = 3  # answers a contradicted claim waits through before the twin's word settles it
# wall s a waiting step gives its twins' questions before asking again: a twin answers in milliseconds, and
# a question's query ends after 2 s (bimbot.shared.twin_query), so one unanswered by then was lost
ASK_AGAIN_S = 2.0


@dataclass
class TwinClaims:
    """Claims by GUID, each settled by its twin's answer (see the module docstring)."""

    pending: dict[str, list[ComponentStateMsg]] = field(default_factory=dict)
    asks: dict[str, int] = field(default_factory=dict)
    _asked_again_s: float = -math.inf

    def claim(self, message: ComponentStateMsg) -> bool:
        """Keep a claim; True when its twin is to be asked (no claim of it awaits an answer already)."""
        claims = self.pending.setdefault(message.guid, [])
        claims.append(message)
        return len(claims) == 1

    def guids(self) -> list[str]:
        return sorted(self.pending)

    def ask_again(self, held_since_s: float, now_s: float) -> list[str]:
        """While a step has waited since ``held_since_s`` (wall s): the GUIDs whose twins are to be asked
        again now, every pending one each ``ASK_AGAIN_S`` (their questions got no answer); else none."""
        if not self.pending or now_s - max(held_since_s, self._asked_again_s) < ASK_AGAIN_S:
            return []
        self._asked_again_s = now_s
        return self.guids()

    def answer(self, twin: TwinMsg) -> tuple[list[ComponentStateMsg], bool]:
        """The claims ``twin`` settles (each to be taken as the twin says) and whether to ask it again."""
        claims = self.pending.get(twin.guid)
        if not claims:
            return [], False
        confirmed = [claim for claim in claims if claim.state is twin.state]
        contradicted = [claim for claim in claims if claim.state is not twin.state]
        settled = confirmed
        if contradicted:
            self.asks[twin.guid] = self.asks.get(twin.guid, 0) + 1
            if self.asks[twin.guid] >= MAX_ASKS:
                _log.warning(
                    "%d claim(s) that %s is %s: its twin says %s after %d answers; taken as the twin says",
                    len(contradicted),
                    twin.guid,
                    "/".join(sorted({claim.state.value for claim in contradicted})),
                    twin.state.value,
                    self.asks[twin.guid],
                )
                settled, contradicted = claims, []
        if contradicted:
            self.pending[twin.guid] = contradicted
        else:
            del self.pending[twin.guid]
            self.asks.pop(twin.guid, None)
        return settled, bool(contradicted)
