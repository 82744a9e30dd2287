"""A start-up question asked before its answerer is up is asked again soon, not after a fixed pause."""

from __future__ import annotations

import threading
import time

import zenoh
from planner.planner_builders import twin_msg
from wall_clock import bound_s

from bimbot.shared.bus import BusOptions, InvalidPayloads, encode, open_session, query_first
from bimbot.shared.messages import COMPONENT_TWIN, ComponentState
from bimbot.supervisor import free_port

SITE = "test-site"


def test_an_answerer_that_comes_up_late_is_heard_soon_after_and_the_wait_stays_bounded() -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    selector = COMPONENT_TWIN.key(site=SITE, key="foot_a")
    answer = encode(twin_msg("foot_a", ComponentState.RELEASED))
    with (
        open_session(BusOptions(mode="peer", connect=(), listen=(endpoint,))) as answerer,
        open_session(BusOptions(mode="peer", connect=(endpoint,), listen=())) as asker,
    ):
        declared: list[zenoh.Queryable] = []
        declared_at: list[float] = []

        def come_up() -> None:
            declared.append(answerer.declare_queryable(selector, lambda query: query.reply(selector, answer)))
            declared_at.append(time.monotonic())

        later = threading.Timer(0.3, come_up)
        later.start()
        # retry_s: with a fixed pause the second question would come retry_s after the first
        retry_s = bound_s(5.0)
        twin = query_first(
            asker,
            COMPONENT_TWIN,
            InvalidPayloads(),
            timeout_s=4 * retry_s,
            retry_s=retry_s,
            site=SITE,
            key="foot_a",
        )
        answered_at = time.monotonic()
        later.join()
        assert twin is not None and twin.guid == "foot_a"
        assert answered_at - declared_at[0] < retry_s * 0.4
        started = time.monotonic()
        assert (
            query_first(asker, COMPONENT_TWIN, InvalidPayloads(), timeout_s=0.5, site=SITE, key="none")
            is None
        )
        assert time.monotonic() - started < bound_s(3.0)  # bounded by timeout_s (plus one question's own)
        assert len(declared) == 1
