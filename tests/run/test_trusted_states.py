"""A state message is a hint: the run takes an ordinary step of the agents' protocol as it comes, asks the
twin about any claim of a terminal state or anything that does not follow from what it knows, and drops
what the agents' state table does not allow. Only a twin makes a component constructed."""

from __future__ import annotations

from run_builders import GUIDS, manifest, state, twin, walk

from bimbot.shared.messages import ComponentState as S
from bimbot.shared.trusted_states import Judgement, TrustedStates

SITE_MANIFEST = manifest()
GUID = GUIDS[0]


def _states() -> TrustedStates:
    return TrustedStates(GUIDS)


def test_the_steps_of_a_placement_are_applied_and_the_verdict_constructed_is_asked() -> None:
    trusted = _states()
    *steps, verdict = walk(GUID, S.CONSTRUCTED)
    for message in steps:
        assert trusted.judge(message) is Judgement.APPLY
        trusted.apply(message)
    assert trusted.states[GUID] == S.VERIFYING
    assert trusted.judge(verdict) is Judgement.ASK
    assert trusted.constructed() == set()


def test_a_forged_constructed_that_the_state_table_does_not_allow_is_rejected() -> None:
    trusted = _states()
    assert trusted.judge(state(GUID, S.CONSTRUCTED, S.PLANNED, "verified")) is Judgement.REJECT
    assert trusted.judge(state(GUID, S.CONSTRUCTED, S.VERIFYING, "release")) is Judgement.REJECT
    assert trusted.judge(state("not-in-the-manifest", S.RELEASED, S.PLANNED, "release")) is Judgement.REJECT
    assert trusted.rejected == 3


def test_a_claim_of_a_terminal_state_or_one_that_does_not_follow_is_asked() -> None:
    trusted = _states()
    assert trusted.judge(state(GUID, S.CONSTRUCTED, None, "resume")) is Judgement.ASK  # an announcement
    assert trusted.judge(state(GUID, S.CONSTRUCTED, S.VERIFYING, "verified")) is Judgement.ASK
    assert trusted.judge(state(GUID, S.TRANSPORTING, S.PICKING, "attach")) is Judgement.ASK  # known: planned
    assert trusted.judge(state(GUID, S.RELEASED, None, "resume")) is Judgement.ASK
    assert trusted.judge(state(GUID, S.PLANNED, None, "start")) is Judgement.APPLY


def test_only_the_twin_makes_a_component_constructed_and_nothing_leaves_it() -> None:
    trusted = _states()
    assert trusted.take_twin(twin(SITE_MANIFEST, GUID, S.CONSTRUCTED))
    assert trusted.constructed() == {GUID}
    for message in walk(GUID, S.RELEASED):
        assert trusted.judge(message) is Judgement.REJECT
    assert trusted.judge(state(GUID, S.FAILED, S.MISPLACED, "fail")) is Judgement.REJECT
    assert trusted.rejected == 2
    # a restarted agent announces what is known: dropped, not counted as a forgery
    assert trusted.judge(state(GUID, S.CONSTRUCTED, None, "resume")) is Judgement.REJECT
    assert trusted.rejected == 2


def test_a_twin_that_says_otherwise_overrules_the_hints() -> None:
    trusted = _states()
    for message in walk(GUID, S.VERIFYING):
        trusted.apply(message)
    assert trusted.take_twin(twin(SITE_MANIFEST, GUID, S.RELEASED))
    assert trusted.states[GUID] == S.RELEASED and trusted.constructed() == set()
