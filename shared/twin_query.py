"""Ask every component agent for its twin at once: how a service that (re)starts learns what is built.

The agents' twins are the truth of construction state (``docs/architecture.md``, "One truth per fact"):
a restarted physics, planner or robot asks ``bimbot/<site>/components/*/twin`` once instead of waiting for
the next state change; every agent's queryable answers (``QueryTarget.ALL``). A session that has just
opened may not know the agents' queryables yet, so an empty answer is asked again until the bound.
"""

from __future__ import annotations

import logging
import time

import zenoh

from .bus import Inbox, InvalidPayloads, decode
from .messages import COMPONENT_TWIN, TwinMsg

_log = logging.getLogger(__name__)

RETRY_S = 0.5
TWIN_REPLY_TIMEOUT_S = 2.0  # wall seconds a question to one twin stays open


def ask_twin(inbox: Inbox, session: zenoh.Session, site: str, key: str) -> None:
    """Ask one component's twin without blocking; its answer comes back through ``inbox`` as an
    :class:`~.bus.Answer` (check it with :func:`answered_on_its_key`)."""
    inbox.ask(session, COMPONENT_TWIN, timeout_s=TWIN_REPLY_TIMEOUT_S, site=site, key=key)


def answered_on_its_key(site: str, reply_key: str, twin: TwinMsg) -> bool:
    """Whether ``twin`` came on its own component's key (a twin answered on another key is not taken)."""
    return reply_key == COMPONENT_TWIN.key(site=site, key=twin.key)


def ask_twins(
    session: zenoh.Session,
    site: str,
    timeout_s: float,
    invalid: InvalidPayloads | None = None,
    retry_s: float = RETRY_S,
) -> list[TwinMsg]:
    """Every twin the agents answer within ``timeout_s`` wall seconds (none when no agent runs). Invalid
    answers, and twins answered on another component's key, are counted in ``invalid`` and left out. A
    session that has just opened may not know the agents' queryables yet (their declarations are still on
    the way): while nobody answers, it asks again every ``retry_s`` until ``timeout_s`` has passed."""
    invalid = invalid or InvalidPayloads()
    selector = COMPONENT_TWIN.key(site=site, key="*")
    deadline = time.monotonic() + timeout_s
    while True:
        twins = []
        left = max(0.1, deadline - time.monotonic())
        for reply in session.get(selector, target=zenoh.QueryTarget.ALL, timeout=left):
            if reply.ok is None:
                continue
            reply_key = str(reply.ok.key_expr)
            twin = decode(TwinMsg, reply_key, reply.ok.payload.to_bytes(), invalid)
            if twin is None:
                continue
            if COMPONENT_TWIN.key(site=site, key=twin.key) != reply_key:
                invalid.record(reply_key, f"a twin of {twin.key!r} answered on another key")
                continue
            twins.append(twin)
        if twins or time.monotonic() + retry_s >= deadline:
            return twins
        time.sleep(retry_s)
