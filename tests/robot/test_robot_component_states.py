"""A robot judges component state messages as ``bimbot run`` does: a forgery never stalls its task."""

from __future__ import annotations

import pytest
from fake_site import make_site
from frames import convert_small_frame

from bimbot.shared.component_states import ComponentStates, TwinQuestion
from bimbot.shared.manifest import Manifest, read_manifest
from bimbot.shared.messages import ComponentState, ComponentStateMsg, RobotState

_S = ComponentState


@pytest.fixture(scope="module")
def frame(tmp_path_factory: pytest.TempPathFactory) -> Manifest:
    return read_manifest(convert_small_frame(tmp_path_factory.mktemp("frame")))


def _state(
    state: ComponentState, previous: ComponentState | None, event: str, guid: str = "g1"
) -> ComponentStateMsg:
    return ComponentStateMsg(
        guid=guid, state=state, previous=previous, event=event, sim_time_s=1.0, wall_time_s=0
    )


def test_ordinary_steps_are_taken_and_nothing_is_known_before_the_first() -> None:
    states = ComponentStates({"g1": "k1"})
    assert states.state("g1") is None
    assert states.hear(_state(_S.RELEASED, _S.PLANNED, "release")) is _S.RELEASED
    assert states.hear(_state(_S.PICKING, _S.RELEASED, "pick")) is _S.PICKING
    assert states.state("g1") is _S.PICKING and states.questions(0.0) == []


def test_a_forbidden_transition_is_dropped_without_a_question() -> None:
    states = ComponentStates({"g1": "k1"})
    states.hear(_state(_S.RELEASED, _S.PLANNED, "release"))
    assert states.hear(_state(_S.CONSTRUCTED, _S.PLANNED, "verified")) is None
    assert states.state("g1") is _S.RELEASED and states.rejected == 1 and states.questions(0.0) == []


def test_a_terminal_claim_is_asked_of_the_twin_until_it_answers_once_a_second() -> None:
    states = ComponentStates({"g1": "k1"})
    states.hear(_state(_S.RELEASED, _S.PLANNED, "release"))
    assert states.hear(_state(_S.CONSTRUCTED, None, "resume")) is None, "a claim is not taken as it is"
    assert states.questions(10.0) == [TwinQuestion("g1", "k1")]
    assert states.questions(10.5) == [], "at most one question a second"
    assert states.questions(11.0) == [TwinQuestion("g1", "k1")], "no answer: asked again"
    assert states.state("g1") is _S.RELEASED


def test_a_twin_answer_is_the_truth_and_ends_the_questions(frame: Manifest) -> None:
    site, released, _ = make_site(frame)
    guid = released.guid
    states = ComponentStates({c.guid: c.key for c in frame.components})
    states.hear(released.model_copy(update={"previous": None, "event": "resume"}))  # known planned: ask
    assert states.state(guid) is None and [q.guid for q in states.questions(0.0)] == [guid]
    assert states.take_twin(site.twin(guid)) is _S.RELEASED
    assert states.state(guid) is _S.RELEASED and states.questions(5.0) == []
    other = next(c for c in frame.components if c.guid != guid)
    assert states.take_twin(site.twin(guid).model_copy(update={"key": other.key})) is None, "another's key"


def test_an_answered_question_does_not_hold_back_the_next_about_the_same_component(
    frame: Manifest,
) -> None:
    # A robot learnt the component's twin a moment ago; its verdict comes within the same second: the
    # question about the verdict goes out at once (waiting out the second let an idle site's clock run
    # 137 s of sim time while the robot did not know its task was done).
    site, released, _ = make_site(frame)
    guid = released.guid
    states = ComponentStates({c.guid: c.key for c in frame.components})
    states.hear(released.model_copy(update={"previous": None, "event": "resume"}))
    assert [q.guid for q in states.questions(10.0)] == [guid]
    states.take_twin(site.twin(guid))
    verdict = released.model_copy(
        update={"state": _S.CONSTRUCTED, "previous": _S.VERIFYING, "event": "verified"}
    )
    assert states.hear(verdict) is None, "a verdict is asked of the twin"
    assert [q.guid for q in states.questions(10.2)] == [guid]
    assert states.questions(10.4) == [], "not answered yet: asked again only after a second"


def test_a_forged_constructed_for_the_assigned_component_does_not_keep_the_robot_from_its_task(
    frame: Manifest,
) -> None:
    site, released, task = make_site(frame)
    forged = released.model_copy(update={"state": _S.CONSTRUCTED, "previous": None, "event": "resume"})
    site.run(1)
    site.executor.handle(released)
    site.executor.handle(forged)  # after the release: a robot taking it would wait for a release for ever
    site.executor.handle(task)
    site.run(3)
    assert site.twin_questions == [task.guid], "the claim that does not follow is asked of the twin"
    assert site.executor.component_states.state(task.guid) in (_S.RELEASED, _S.PICKING)
    assert site.executor.machine.state is not RobotState.IDLE, "the task started"


def test_a_forged_verdict_does_not_end_the_robots_task_the_twins_verdict_does(frame: Manifest) -> None:
    site, released, task = make_site(frame, placement_error_m=0.05)  # the agent will call it misplaced
    site.run(1)
    site.executor.handle(released)
    site.executor.handle(task)
    site.run(3000, until=lambda s: s.executor.task is not None and s.executor.task.placed)
    assert site.states[task.guid] is _S.VERIFYING
    forged = released.model_copy(
        update={"state": _S.CONSTRUCTED, "previous": _S.VERIFYING, "event": "verified"}
    )
    site.executor.handle(forged)
    site.run(3)
    assert site.executor.task is not None and not site.executor.done, "the twin says it is being verified"
    site.verify()
    site.run(100, until=lambda s: bool(s.executor.done))
    assert site.executor.done == [(task.guid, _S.MISPLACED)]
