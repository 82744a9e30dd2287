"""Physics takes component states at a defined step: a constructed claim waits for its twin, and is taken
before the advance from the step after the one it is stamped with, whenever its message arrived."""

from __future__ import annotations

from bimbot.services.physics.stepped_states import SteppedStates
from bimbot.shared.component_states import ComponentStates
from bimbot.shared.messages import ComponentState, ComponentStateMsg, PoseMsg, TwinMsg
from bimbot.shared.twin_claims import MAX_ASKS

_S = ComponentState
_POSE = PoseMsg(position_m=(0.0, 0.0, 0.0), quat_xyzw=(0.0, 0.0, 0.0, 1.0))


def _state(state: ComponentState, previous: ComponentState, event: str, sim_s: float) -> ComponentStateMsg:
    return ComponentStateMsg(
        guid="g1", state=state, previous=previous, event=event, sim_time_s=sim_s, wall_time_s=0
    )


def _twin(history: list[ComponentStateMsg]) -> TwinMsg:
    return TwinMsg(
        guid="g1",
        key="k1",
        ifc_class="IfcColumn",
        name=None,
        storey=None,
        material=None,
        mass_kg=1.0,
        target_pose=_POSE,
        current_pose=_POSE,
        current_pose_sim_time_s=0.0,
        state=history[-1].state,
        attempt=1,
        robot_id="r1",
        history=history,
    )


def test_a_terminal_claim_holds_the_step_until_its_twin_answers_and_is_taken_then() -> None:
    stepped = SteppedStates(ComponentStates({"g1": "k1"}))
    for step in range(4):
        stepped.clock(step, 0.2 * step)
    released = _state(_S.RELEASED, _S.PLANNED, "release", 0.2)
    failed = _state(_S.FAILED, _S.RELEASED, "fail", 0.4)
    stepped.hear(released)
    stepped.hear(failed)
    assert stepped.to_ask == ["g1"]
    assert stepped.ready(2) and stepped.take(2) == [("g1", _S.RELEASED)]
    assert not stepped.ready(3), "the claim is due: its twin is waited for"
    assert stepped.answer(_twin([released, failed]))
    assert stepped.ready(3) and stepped.take(3) == [("g1", _S.FAILED)]


def test_nothing_is_taken_before_its_step() -> None:
    stepped = SteppedStates(ComponentStates({"g1": "k1"}))
    for step in range(3):
        stepped.clock(step, 0.2 * step)
    stepped.hear(_state(_S.RELEASED, _S.PLANNED, "release", 0.4))
    assert stepped.take(2) == []
    stepped.clock(3, 0.6)
    assert stepped.take(3) == [("g1", _S.RELEASED)]


def test_forged_claims_the_twin_contradicts_are_settled_by_the_twin_and_never_hold_the_steps() -> None:
    """A flood of forged 'constructed' messages for a component that is only released: each is kept (a
    newer one does not orphan an older one), the twin is asked again while it says otherwise, at most
    MAX_ASKS answers, then the twin's word settles them all and the steps go on."""
    stepped = SteppedStates(ComponentStates({"g1": "k1"}))
    for step in range(4):
        stepped.clock(step, 0.2 * step)
    released = _state(_S.RELEASED, _S.PLANNED, "release", 0.2)
    stepped.hear(released)
    assert stepped.take(2) == [("g1", _S.RELEASED)]
    forged = [_state(_S.CONSTRUCTED, _S.VERIFYING, "verify_ok", 0.2 + 0.001 * i) for i in range(5)]
    for message in forged:
        stepped.hear(message)
    assert stepped.to_ask == ["g1"], "one question for the claims of one component"
    assert not stepped.ready(3)
    truth = _twin([released])
    for _ in range(MAX_ASKS - 1):
        assert not stepped.answer(truth) and not stepped.ready(3), "asked again: the twin may lag"
    assert stepped.answer(truth), "the twin's word settles every forged claim"
    assert stepped.ready(3)
    taken = stepped.take(3)
    assert taken and {state for _, state in taken} == {_S.RELEASED}, "taken as the twin says: released"
    assert stepped.claims.guids() == []
