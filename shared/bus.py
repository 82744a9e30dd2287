"""The one place every service builds its Zenoh session and handles what it receives.

How a service joins the bus (``--mode/--connect/--listen/--bus-config``, their environment fallbacks, the
Zenoh config and opening a session) is :mod:`bimbot.shared.bus_config`; its names are re-exported here, so
services import everything bus-related from this module.

Received payloads are validated against their pydantic model by :class:`Inbox`; invalid ones are logged
with their key and counted, and never reach the service's state. Zenoh calls callbacks on its own
threads, so callbacks only enqueue: the service's own loop drains the inbox and changes state.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from collections import Counter
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Generic, TypeVar

import zenoh
from pydantic import BaseModel, ValidationError

from .bus_config import (
    DEFAULT_ENDPOINT,
    DEFAULT_LISTEN,
    MODES,
    BusOptions,
    add_bus_arguments,
    bus_options,
    open_session,
    zenoh_config,
)
from .keyspace import Queryable, Topic
from .messages import SensorsMsg
from .wire import encode_sensors, is_binary, sensors_fields

__all__ = [  # the bus_config names are re-exported: services import everything bus-related from here
    "DEFAULT_ENDPOINT",
    "DEFAULT_LISTEN",
    "MODES",
    "Answer",
    "BusOptions",
    "Handler",
    "Inbox",
    "IncomingQuery",
    "InvalidPayloads",
    "LivelinessChange",
    "RawSample",
    "Received",
    "add_bus_arguments",
    "bus_options",
    "decode",
    "encode",
    "open_session",
    "query_first",
    "reply_json",
    "zenoh_config",
]

_log = logging.getLogger(__name__)

M = TypeVar("M", bound=BaseModel)
R = TypeVar("R", bound=BaseModel)


def encode(message: BaseModel) -> bytes:
    """The payload of ``message``: its JSON, or for a binary topic's model the layout of :mod:`.wire`."""
    if isinstance(message, SensorsMsg):
        return encode_sensors(message)
    return message.model_dump_json().encode("utf-8")


@dataclass(frozen=True)
class Received(Generic[M]):
    """A validated message that arrived on ``key`` of ``topic``."""

    topic: Topic[M]
    key: str
    message: M


@dataclass(frozen=True)
class LivelinessChange:
    """A liveliness token on ``key`` appeared (``alive``) or went away."""

    key: str
    alive: bool

    @property
    def id(self) -> str:
        """The token's last key chunk (a robot id, a component key, …)."""
        return self.key.rsplit("/", 1)[-1]

    @property
    def kind(self) -> str:
        """The token owner's kind, the chunk before its id in ``ALIVE_KEY`` (robot, planner, component, …)."""
        return self.key.rsplit("/", 2)[-2]


@dataclass(frozen=True)
class IncomingQuery(Generic[R]):
    """A query to one of our ``queryable``s; the loop answers it (``reply``) and drops it."""

    queryable: Queryable[R]
    query: zenoh.Query


@dataclass(frozen=True)
class Answer(Generic[R]):
    """A validated reply from ``key`` to a query this service sent on ``queryable``."""

    queryable: Queryable
    key: str
    message: R


@dataclass(frozen=True)
class RawSample:
    """A payload put on ``key``, not validated yet (an observer of ``bimbot/**`` decodes only what it
    reads, see :func:`bimbot.shared.messages.topic_of`)."""

    key: str
    payload: bytes


class InvalidPayloads:
    """Counts invalid payloads per key expression; logs the first few per key and then every 100th."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.by_key: Counter[str] = Counter()

    @property
    def total(self) -> int:
        with self._lock:
            return sum(self.by_key.values())

    def record(self, key: str, error: str) -> None:
        with self._lock:
            self.by_key[key] += 1
            count = self.by_key[key]
        if count <= 3 or count % 100 == 0:
            _log.warning("invalid payload #%d on %s: %s", count, key, error)


def decode(model: type[M], key: str, payload: bytes, invalid: InvalidPayloads) -> M | None:
    """The validated message, or None (logged and counted) when the payload does not fit ``model``."""
    try:
        if is_binary(model):
            return model.model_validate(sensors_fields(payload))
        return model.model_validate_json(payload)
    except ValidationError as error:
        first = error.errors()[0]
        where = ".".join(str(part) for part in first.get("loc", ())) or "payload"
        invalid.record(key, f"{where}: {first.get('msg', 'invalid')}")
    except (ValueError, UnicodeDecodeError) as error:
        invalid.record(key, f"undecodable payload ({error})")
    return None


def in_arrival_order(callback: Callable[..., object]) -> zenoh.handlers.Callback:
    """``callback`` run on the thread that receives the data, so every subscriber of one session hears one
    sender's messages in the order they were put. It must be quick and never block (it only enqueues)."""
    return zenoh.handlers.Callback(callback, indirect=False)


class Inbox:
    """A thread-safe queue of typed items fed by Zenoh callbacks and drained by the service's loop.

    ``subscribe(session, COMPONENT_STATE, site=s, key="*")`` declares a subscriber whose callback
    validates the payload against the topic's registered model and enqueues a :class:`Received`;
    liveliness changes arrive as :class:`LivelinessChange`, queries to our queryables as
    :class:`IncomingQuery`, replies to ``ask`` as :class:`Answer`. A service puts its own items (timers,
    other adapters) with :meth:`put` as small dataclasses, so the loop dispatches on types (``match``).
    Callbacks never touch service state.
    """

    def __init__(self, invalid: InvalidPayloads | None = None, *, in_order: bool = False) -> None:
        """``in_order``: fed on the receiving thread, one sender's messages in the order they were put."""
        self._queue: queue.Queue[object] = queue.Queue()
        self.invalid = invalid or InvalidPayloads()
        self._in_order = in_order

    def _handler(self, callback: Callable[..., object]) -> Callable[..., object] | zenoh.handlers.Callback:
        return in_arrival_order(callback) if self._in_order else callback

    def subscribe(self, session: zenoh.Session, topic: Topic[M], **parts: str) -> zenoh.Subscriber:
        """Subscribe to ``topic`` with its key ``parts`` filled (``*`` for any)."""

        def on_sample(sample: zenoh.Sample) -> None:
            key = str(sample.key_expr)
            if sample.kind != zenoh.SampleKind.PUT:
                return
            message = decode(topic.model, key, sample.payload.to_bytes(), self.invalid)
            if message is not None:
                self._queue.put(Received(topic, key, message))

        return session.declare_subscriber(topic.key(**parts), self._handler(on_sample))

    def subscribe_raw(self, session: zenoh.Session, key_expr: str) -> zenoh.Subscriber:
        """Every payload put under ``key_expr``, as :class:`RawSample` (decoded later, by the loop)."""

        def on_sample(sample: zenoh.Sample) -> None:
            if sample.kind == zenoh.SampleKind.PUT:
                self._queue.put(RawSample(str(sample.key_expr), sample.payload.to_bytes()))

        return session.declare_subscriber(key_expr, self._handler(on_sample))

    def subscribe_liveliness(self, session: zenoh.Session, key_expr: str) -> zenoh.Subscriber:
        """Liveliness changes as :class:`LivelinessChange`; existing tokens are reported first."""

        def on_sample(sample: zenoh.Sample) -> None:
            self._queue.put(LivelinessChange(str(sample.key_expr), sample.kind == zenoh.SampleKind.PUT))

        return session.liveliness().declare_subscriber(key_expr, self._handler(on_sample), history=True)

    def serve(
        self, session: zenoh.Session, queryable: Queryable[R], *, complete: bool, **parts: str
    ) -> zenoh.Queryable:
        """Declare ``queryable`` (parts filled); each query is enqueued as an :class:`IncomingQuery`."""
        return session.declare_queryable(
            queryable.key(**parts),
            self._handler(lambda query: self._queue.put(IncomingQuery(queryable, query))),
            complete=complete,
        )

    def ask(self, session: zenoh.Session, queryable: Queryable[R], *, timeout_s: float, **parts: str) -> None:
        """Query ``queryable`` (parts filled) once; every valid reply is enqueued as an :class:`Answer`."""
        reply_model = queryable.reply

        def on_reply(reply: zenoh.Reply) -> None:
            if reply.ok is None:
                return
            key = str(reply.ok.key_expr)
            message = decode(reply_model, key, reply.ok.payload.to_bytes(), self.invalid)
            if message is not None:
                self._queue.put(Answer(queryable, key, message))

        session.get(queryable.key(**parts), self._handler(on_reply), timeout=timeout_s)

    def put(self, item: object) -> None:
        """Enqueue a service's own item from any thread (timers, other adapters)."""
        self._queue.put(item)

    def get(self, timeout_s: float | None = None) -> object | None:
        try:
            return self._queue.get(timeout=timeout_s)
        except queue.Empty:
            return None

    def drain(self, first_timeout_s: float | None = None, limit: int = 10_000) -> Iterator[object]:
        """Yield what is queued: wait up to ``first_timeout_s`` for the first item, then what is there."""
        item = self.get(first_timeout_s)
        count = 0
        while item is not None and count < limit:
            yield item
            count += 1
            item = self.get(0) if not self._queue.empty() else None


def reply_json(query: zenoh.Query, key: str, message: BaseModel) -> None:
    query.reply(key, encode(message))


Handler = Callable[[zenoh.Query], None]
# A start-up question asked before its answerer is up (a robot's for physics' site info, asked while
# physics builds its scene) is asked again soon, then less often: a fixed 0.5 s held every run's first step
# for up to half a second after physics was ready. A question nobody can answer yet costs next to nothing.
FIRST_RETRY_S = 0.05


def query_first(
    session: zenoh.Session,
    queryable: Queryable[R],
    invalid: InvalidPayloads,
    *,
    timeout_s: float,
    stop: threading.Event | None = None,
    retry_s: float = 0.5,
    **parts: str,
) -> R | None:
    """Ask ``queryable`` (parts filled) until a valid reply answers, at most ``timeout_s`` wall seconds (or
    ``stop``).

    For start-up questions to another service's queryable (physics' site info): a bounded wait, never a
    hang; None when nobody answered in time. Asked again after 0.05 s, then twice as long each time up to
    ``retry_s``.
    """
    selector, model = queryable.key(**parts), queryable.reply
    deadline = time.monotonic() + timeout_s
    pause_s = min(FIRST_RETRY_S, retry_s)
    while stop is None or not stop.is_set():
        left = deadline - time.monotonic()
        if left <= 0:
            return None
        for reply in session.get(selector, timeout=max(0.1, min(2.0, left))):
            if reply.ok is not None:
                message = decode(model, selector, reply.ok.payload.to_bytes(), invalid)
                if message is not None:
                    return message
        wait_s = min(pause_s, max(0.0, deadline - time.monotonic()))
        if stop is not None:
            stop.wait(wait_s)
        else:
            time.sleep(wait_s)
        pause_s = min(2.0 * pause_s, retry_s)
    return None
