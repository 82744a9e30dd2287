"""The message registry: every key of the bus is registered once with its model, the docs' key table is
the registry's, and the inbox validates against the model the registry names, as typed items."""

from __future__ import annotations

import pytest
import zenoh

from bimbot.shared import messages
from bimbot.shared.bus import Inbox, LivelinessChange, Received, encode
from bimbot.shared.keyspace import Liveliness, Queryable, Topic, key_table
from bimbot.shared.messages import (
    CLOCK,
    COMPONENT_STATE,
    KEY_SPACE,
    MESSAGE_SCHEMA_VERSION,
    QUERYABLES,
    TOPICS,
    ClockMsg,
    ComponentStateMsg,
    topic_of,
)


def _templates() -> dict[str, str]:
    return {name: value for name, value in vars(messages).items() if name.endswith("_KEY")}


def test_every_key_template_of_the_module_is_registered_once() -> None:
    registered = [entry.template for entry in KEY_SPACE]
    assert len(registered) == len(set(registered))
    assert sorted(registered) == sorted(_templates().values())


def test_the_module_docstring_key_table_is_the_registry() -> None:
    assert messages.__doc__ is not None
    assert key_table(KEY_SPACE) in messages.__doc__


def test_topics_and_queryables_name_message_models_of_the_current_schema() -> None:
    assert set(TOPICS) | set(QUERYABLES) == {e.template for e in KEY_SPACE if not isinstance(e, Liveliness)}
    for entry in KEY_SPACE:
        models = [entry.model] if isinstance(entry, Topic) else []
        if isinstance(entry, Queryable):
            models = [entry.reply, *([entry.request] if entry.request is not None else [])]
        for model in models:
            assert model.model_fields["schema_version"].default == MESSAGE_SCHEMA_VERSION, model


@pytest.mark.parametrize(
    ("key_expr", "expected"),
    [
        ("bimbot/s/components/2$E2-x/state", COMPONENT_STATE),
        ("bimbot/s/clock", CLOCK),
        ("bimbot/s/robots/r1/plan", TOPICS[messages.ROBOT_PLAN_KEY]),
        ("bimbot/other/clock", None),
        ("bimbot/s/components/k/twin", None),  # a queryable, not a topic
        ("bimbot/s/robots/r1/plan/extra", None),
    ],
)
def test_a_concrete_key_finds_its_topic(key_expr: str, expected: Topic | None) -> None:
    assert topic_of("s", key_expr) is expected


class _Sample:
    """What the inbox's callback reads of a ``zenoh.Sample``."""

    def __init__(self, key_expr: str, payload: bytes) -> None:
        self.key_expr, self.payload, self.kind = key_expr, zenoh.ZBytes(payload), zenoh.SampleKind.PUT


class _Session:
    """Records the callbacks the inbox declares, so a test can call them as Zenoh would."""

    def __init__(self) -> None:
        self.subscribers: dict[str, object] = {}

    def declare_subscriber(self, key_expr: str, callback: object) -> None:
        self.subscribers[key_expr] = callback


def test_the_inbox_validates_against_the_topics_model_and_yields_typed_items() -> None:
    inbox, session = Inbox(), _Session()
    inbox.subscribe(session, COMPONENT_STATE, site="s", key="*")  # type: ignore[arg-type]
    inbox.subscribe(session, CLOCK, site="s")  # type: ignore[arg-type]
    on_state = session.subscribers["bimbot/s/components/*/state"]
    on_clock = session.subscribers["bimbot/s/clock"]
    state = ComponentStateMsg(guid="g", state="planned", event="start", sim_time_s=0.0, wall_time_s=0.0)
    clock = ClockMsg(sim_time_s=1.0, step=10, real_time_factor=1.0)
    on_state(_Sample("bimbot/s/components/k/state", encode(state)))  # type: ignore[operator]
    on_state(_Sample("bimbot/s/components/k/state", encode(clock)))  # type: ignore[operator]
    on_clock(_Sample("bimbot/s/clock", encode(clock)))  # type: ignore[operator]
    inbox.put(LivelinessChange("bimbot/s/alive/robot/r1", alive=True))
    items = list(inbox.drain(first_timeout_s=0.0))
    assert items == [
        Received(COMPONENT_STATE, "bimbot/s/components/k/state", state),
        Received(CLOCK, "bimbot/s/clock", clock),
        LivelinessChange("bimbot/s/alive/robot/r1", alive=True),
    ]
    assert inbox.invalid.by_key == {"bimbot/s/components/k/state": 1}  # a clock on a state key
    assert items[2].id == "r1"
