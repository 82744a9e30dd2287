"""The agents' Zenoh adapter: one session for all the agents of one shard.

Declared, in this order, so that a component seen alive can already be driven and queried:

* subscribers (through :class:`bimbot.shared.bus.Inbox`, which validates and only enqueues) on
  ``bimbot/<site>/components/*/event``, ``bimbot/<site>/components/*/pose`` and ``bimbot/<site>/clock``;
  messages for components of other shards are dropped by the host; and on physics' liveliness: when it
  comes back after it went (the bus was cut), every agent says its state again (:mod:`.reconnect`);
* one queryable on ``bimbot/<site>/components/*/twin`` whose callback only enqueues the query. The loop
  replies once per owned component whose twin key matches the query (so ``components/*/twin`` gets one
  reply per component from each shard) and then drops the query, which finalises it. It is declared
  incomplete, so a querier's default target reaches every shard's queryable;
* one liveliness token per agent, ``bimbot/<site>/alive/component/<key>``. Zenoh's per-session cost of
  a token grows with the tokens the session already holds (measured: 10,000 in one session 2.1 s alone,
  3–7 s connected to a router; the same 10,000 over ten sessions 0.2 s alone). So beyond
  ``TOKENS_PER_SESSION`` tokens the process opens extra sessions just for tokens, in client mode to
  the same router: they hold no subscriptions and join no peer mesh. Without endpoints to connect to,
  every token stays on the main session.

Then, once the bus routes state messages to a subscriber (or after ``LISTENERS_WAIT_S``), every agent
announces its state once and the loop drains the inbox, applies, journals, publishes the
state changes on ``components/<key>/state`` (``session.put``: declaring a publisher per agent measured
2.1 s and 2.5 KB per agent for 5,000 agents, for no gain at a few messages per component per build) and
checks the verification timeouts. A failure while handling one item is logged and the loop goes on.
Setting ``stop`` (SIGTERM/SIGINT in the CLI) ends the loop; the session is closed by ``with``.
"""

from __future__ import annotations

import contextlib
import logging
import threading
import time
from collections.abc import Iterable
from dataclasses import replace
from pathlib import Path
from typing import cast

import zenoh

from bimbot.shared.asked import Asked
from bimbot.shared.bus import BusOptions, Inbox, IncomingQuery, LivelinessChange, encode, open_session
from bimbot.shared.messages import (
    ALIVE_KEY,
    CLOCK,
    COMPONENT_EVENT,
    COMPONENT_POSE,
    COMPONENT_STATE_KEY,
    COMPONENT_TWIN,
    PHYSICS_INFO,
    STEP_DONE_KEY,
    SiteInfoMsg,
    key,
)
from bimbot.shared.service_runner import BuildInput

from .agent import AgentConfig
from .host import AgentHost, Outgoing
from .journal import Journal, journal_path
from .reconnect import PhysicsReach
from .stepped import VERIFY_TIMEOUT_SIM_S, SteppedAgents, participant_name

_log = logging.getLogger(__name__)

LOOP_WAIT_S = 0.05  # longest wait for input before the verification timeouts are checked
LISTENERS_WAIT_S = 2.0  # longest wait at start for the bus to route state messages to their subscribers
TOKENS_PER_SESSION = 1_000
SITE_INFO_WAIT_S = 3.0  # wall seconds the agents wait for physics' site info before they judge by their own


def main(
    options: BusOptions,
    build: BuildInput,
    config: AgentConfig,
    stop: threading.Event,
    *,
    shard: tuple[int, int],
    state_dir: Path,
    fresh: bool = False,
    stepped: bool = False,
) -> int:
    """Run shard ``shard`` (i, n) of the build's agents until ``stop`` is set; 0 on a clean stop.
    ``build.manifest`` holds that shard's components (:func:`.host.shard_manifest`)."""
    manifest, (index, n_shards) = build.manifest, shard
    path = journal_path(state_dir, index, n_shards)  # in the run folder (bimbot.shared.run_folder)
    if stepped:  # a lock-step participant: the verification timeout in sim seconds (.stepped)
        config = replace(config, sim_deadlines=True, verify_timeout_s=VERIFY_TIMEOUT_SIM_S)
    with Journal(path, fresh=fresh) as journal:
        waiting = replace(config, tolerances_known=False)  # until physics' site info says the site's
        host = AgentHost(manifest, index, n_shards, config=waiting, journal=journal, resume=journal.replayed)
        _log.info(
            "shard %d/%d: %d agents of site %s (journal %s, %d resumed)",
            index,
            n_shards,
            len(host.agents),
            host.site,
            path,
            len(host.resumed),
        )
        with open_session(options) as session, contextlib.ExitStack() as extra:
            token_sessions = [session] + [
                extra.enter_context(open_session(options_for_tokens))
                for options_for_tokens in token_session_options(options, len(host.agents))
            ]
            serve(session, host, stop, token_sessions, stepped=stepped)
        _log.info("agents stopped: %s", dict(host.counts))
    return 0


def token_session_options(options: BusOptions, n_tokens: int) -> list[BusOptions]:
    """Options of the extra sessions that carry liveliness tokens beyond the main session's share."""
    extra = max(0, -(-n_tokens // TOKENS_PER_SESSION) - 1)
    if extra == 0 or options.mode == "router" or not options.connect:
        return []
    return [replace(options, mode="client", listen=())] * extra  # the same credentials (--bus-config)


def serve(
    session: zenoh.Session,
    host: AgentHost,
    stop: threading.Event,
    token_sessions: list[zenoh.Session] | None = None,
    *,
    stepped: bool = False,
) -> None:
    """Declare everything on ``session`` (tokens spread over ``token_sessions``) and run the loop until
    ``stop`` is set; ``stepped``: as a lock-step participant (:mod:`.stepped`)."""
    site = host.site
    inbox = Inbox(in_order=True)
    # Kept referenced until the session closes (an undropped declaration stays declared anyway).
    declarations: list[object] = [
        inbox.subscribe(session, COMPONENT_EVENT, site=site, key="*"),
        inbox.subscribe(session, COMPONENT_POSE, site=site, key="*"),
        inbox.subscribe(session, CLOCK, site=site),
        inbox.serve(session, COMPONENT_TWIN, complete=False, site=site, key="*"),
        inbox.subscribe_liveliness(session, key(ALIVE_KEY, site=site, kind="physics", id="*")),
    ]
    physics = PhysicsReach()
    steps = None
    if stepped:  # a lock-step participant (.stepped)
        answer_key = key(STEP_DONE_KEY, site=site, participant=participant_name(host.shard, host.n_shards))
        steps = SteppedAgents(
            host,
            lambda out: _publish(session, out),
            lambda message: session.put(answer_key, encode(message)),
        )
    started = time.perf_counter()
    livelinesses = [token_session.liveliness() for token_session in token_sessions or [session]]
    per_session = -(-len(host.agents) // len(livelinesses)) if host.agents else 1
    declarations.extend(
        livelinesses[index // per_session].declare_token(key(ALIVE_KEY, site=site, kind="component", id=k))
        for index, k in enumerate(host.agents)
    )
    _log.info(
        "declared %d liveliness tokens over %d session(s) in %.2f s",
        len(host.agents),
        len(livelinesses),
        time.perf_counter() - started,
    )
    if host.agents:
        _wait_for_listeners(session, key(COMPONENT_STATE_KEY, site=site, key=next(iter(host.agents))))
    _publish(session, host.start())
    site_info: Asked[SiteInfoMsg] | None = Asked(session, PHYSICS_INFO, inbox.invalid, site=site)
    asked_since = time.monotonic()

    while not stop.is_set():
        if site_info is not None and (info := site_info.poll()) is not None:
            host.use_tolerances(info.tolerances)  # the tolerances in force: physics' site info
            host.use_fleet(info.robot_type_of, info.robot_types)
            if steps is not None:
                steps.start()
            site_info = None
        elif site_info is not None and time.monotonic() - asked_since > SITE_INFO_WAIT_S:
            host.assume_own_tolerances(SITE_INFO_WAIT_S)  # still asked: physics' answer wins when it comes
        for item in inbox.drain(first_timeout_s=LOOP_WAIT_S):
            try:
                if isinstance(item, IncomingQuery):
                    _answer(item.query, host)
                elif isinstance(item, LivelinessChange):
                    if physics.back(item):  # the bus was cut: what was said meanwhile may be lost
                        _log.info("physics is back in reach: every agent's state again")
                        if steps is not None:
                            steps.restate()
                        else:
                            _publish(session, host.restate())
                elif steps is None or not steps.hear(item):
                    _publish(session, host.handle(item))
            except Exception:
                host.counts["handler_errors"] += 1
                _log.exception("handling %s failed; going on", type(item).__name__)
            if stop.is_set():
                break
        try:
            if steps is not None:
                steps.step_ready()
            else:
                _publish(session, host.tick())
        except Exception:
            host.counts["handler_errors"] += 1
            _log.exception("checking verification timeouts failed; going on")
    if steps is not None:
        steps.finish()
    invalid = inbox.invalid.total
    if invalid:
        _log.info("%d invalid payloads were received and ignored", invalid)
    del declarations


def _wait_for_listeners(session: zenoh.Session, key_expr: str, timeout_s: float = LISTENERS_WAIT_S) -> bool:
    """Wait until the bus routes ``key_expr`` to a subscriber (at most ``timeout_s``).

    A session that has just connected learns the other sessions' subscriptions a moment later, and what it
    puts before then reaches nobody: the start-up announcements (the resumed states of a restarted shard)
    were lost that way now and then. Nobody listening at all costs ``timeout_s`` once, at start."""
    publisher = session.declare_publisher(key_expr)
    try:
        deadline = time.monotonic() + timeout_s
        while not _matching(publisher) and time.monotonic() < deadline:
            time.sleep(0.01)
        return _matching(publisher)
    finally:
        publisher.undeclare()


def _matching(publisher: zenoh.Publisher) -> bool:
    """Whether a subscriber matches ``publisher``'s key expression now."""
    # zenoh's stubs (1.10) type ``Publisher.matching_status`` as bool; it returns a MatchingStatus.
    status = cast(zenoh.MatchingStatus, publisher.matching_status)
    return status.matching


def _publish(session: zenoh.Session, outgoing: Iterable[Outgoing]) -> None:
    for item in outgoing:
        session.put(item.key_expr, encode(item.message))


def _answer(query: zenoh.Query, host: AgentHost) -> None:
    """Reply with the twin of every owned component the query's key expression matches, then finalise."""
    try:
        query_ke = query.key_expr
        replies = host.twins(str(query_ke), lambda _query, twin_key: query_ke.intersects(twin_key))
        for reply_key, twin in replies:
            query.reply(reply_key, encode(twin))
    finally:
        query.drop()
