"""A terminal claim waits for its twin: a question that got no answer (lost with a router that restarted
under it) is asked again while the step waits, so the step is not held for its whole bound."""

from __future__ import annotations

from bimbot.shared.messages import ComponentState, ComponentStateMsg
from bimbot.shared.twin_claims import ASK_AGAIN_S, TwinClaims


def _claim(guid: str) -> ComponentStateMsg:
    return ComponentStateMsg(
        guid=guid,
        state=ComponentState.CONSTRUCTED,
        previous=ComponentState.VERIFYING,
        event="verified",
        sim_time_s=1.0,
        wall_time_s=0,
    )


def test_an_unanswered_twin_is_asked_again_every_few_seconds_while_its_step_waits() -> None:
    claims = TwinClaims()
    assert claims.claim(_claim("g2")) and claims.claim(_claim("g1"))  # each asked once, as it came
    held_since = 100.0
    assert claims.ask_again(held_since, held_since + 0.5 * ASK_AGAIN_S) == []  # its answer may be on the way
    assert claims.ask_again(held_since, held_since + ASK_AGAIN_S) == ["g1", "g2"]
    assert claims.ask_again(held_since, held_since + 1.5 * ASK_AGAIN_S) == []
    assert claims.ask_again(held_since, held_since + 2.0 * ASK_AGAIN_S) == ["g1", "g2"]


def test_nothing_is_asked_again_when_no_claim_waits() -> None:
    assert TwinClaims().ask_again(0.0, 10.0 * ASK_AGAIN_S) == []
