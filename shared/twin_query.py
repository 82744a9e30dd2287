"""Ask every component agent for its twin at once: how a service that (re)starts learns what is built.

The agents' twins are the truth of construction state (``docs/architecture.md``, "One truth per fact"):
a restarted physics, planner or robot asks ``bimbot/<site>/components/*/twin`` once instead of waiting for
the next state change. Every agent declares a *complete* queryable for its own key, so the query must
target all of them (Zenoh's default, best matching, would stop at one).
"""

from __future__ import annotations

import logging

import zenoh

from .bus import InvalidPayloads, decode
from .messages import COMPONENT_TWIN, TwinMsg

_log = logging.getLogger(__name__)


def ask_twins(
    session: zenoh.Session, site: str, timeout_s: float, invalid: InvalidPayloads | None = None
) -> list[TwinMsg]:
    """Every twin the agents answer within ``timeout_s`` wall seconds (none when no agent runs); invalid
    answers are counted in ``invalid`` and left out."""
    invalid = invalid or InvalidPayloads()
    selector = COMPONENT_TWIN.key(site=site, key="*")
    twins = []
    for reply in session.get(selector, target=zenoh.QueryTarget.ALL, timeout=timeout_s):
        if reply.ok is None:
            continue
        twin = decode(TwinMsg, str(reply.ok.key_expr), reply.ok.payload.to_bytes(), invalid)
        if twin is not None:
            twins.append(twin)
    return twins
