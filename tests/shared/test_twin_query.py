"""Asking every twin: all agents answer (not just the best match), and agents that come up a moment after
the question are still heard."""

from __future__ import annotations

import threading
import time

import zenoh
from planner.planner_builders import twin_msg
from wall_clock import bound_s

from bimbot.polling import wait_until
from bimbot.shared.bus import BusOptions, encode, open_session
from bimbot.shared.messages import COMPONENT_TWIN, ComponentState, TwinMsg
from bimbot.shared.twin_query import ask_twins
from bimbot.supervisor import free_port

SITE = "test-site"


def _agent(session: zenoh.Session, guid: str) -> zenoh.Queryable:
    """One agent's complete queryable for its own key, as the agents declare it."""
    selector = COMPONENT_TWIN.key(site=SITE, key=guid)
    answer = encode(twin_msg(guid, ComponentState.RELEASED))
    return session.declare_queryable(selector, lambda query: query.reply(selector, answer), complete=True)


def test_agents_that_come_up_after_the_question_are_heard_and_every_agent_answers() -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with (
        open_session(BusOptions(mode="peer", connect=(), listen=(endpoint,))) as agents,
        open_session(BusOptions(mode="peer", connect=(endpoint,), listen=())) as asker,
    ):
        first: list[zenoh.Queryable] = []
        later = threading.Timer(1.0, lambda: first.append(_agent(agents, "foot_a")))
        later.start()
        started, timeout_s = time.monotonic(), bound_s(10.0)
        twins = ask_twins(asker, SITE, timeout_s=timeout_s)  # asked before any agent is up
        later.join()
        assert [twin.guid for twin in twins] == ["foot_a"]
        assert 1.0 <= time.monotonic() - started < timeout_s / 2  # answered, not waited out
        others = [_agent(agents, guid) for guid in ("foot_b", "col_a")]
        everyone: list[TwinMsg] = []

        def all_answer() -> bool:  # once their declarations reach the asker
            everyone[:] = ask_twins(asker, SITE, timeout_s=1.0)
            return len(everyone) == 3

        wait_until(all_answer, timeout_s=bound_s(5.0))
        assert sorted(twin.guid for twin in everyone) == ["col_a", "foot_a", "foot_b"]
        assert ask_twins(asker, "no-such-site", timeout_s=1.0) == []
        assert len(first) == 1 and len(others) == 2  # kept declared until here
