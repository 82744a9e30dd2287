"""A fact another service owns, asked for from a loop that must never block: ask, go on, look again.

Physics owns the site layout and the robots (``physics/info``), the planner its plan (``planner/plan``);
the run's monitor and the observer ask them instead of computing a copy of their own. Their loops drain an
inbox every few milliseconds, so the question goes out with a reply callback (Zenoh calls it on its own
thread; it only stores the answer) and is asked again every ``retry_s`` until a valid reply came; a
service that answers late (it starts after the asker) is then still heard.
:func:`bimbot.shared.bus.query_first` is the blocking form for start-up questions.
"""

from __future__ import annotations

import threading
import time
from typing import Generic, TypeVar

import zenoh
from pydantic import BaseModel

from .bus import InvalidPayloads, decode
from .keyspace import Queryable

M = TypeVar("M", bound=BaseModel)


class Asked(Generic[M]):
    """The answer of ``queryable`` (its parts filled) once one came: :meth:`poll` asks (again) when due."""

    def __init__(
        self,
        session: zenoh.Session,
        queryable: Queryable[M],
        invalid: InvalidPayloads,
        *,
        retry_s: float = 1.0,
        reply_timeout_s: float = 2.0,
        **parts: str,
    ) -> None:
        self._session, self._selector, self._invalid = session, queryable.key(**parts), invalid
        self._model: type[M] = queryable.reply
        self._retry_s, self._reply_timeout_s = retry_s, reply_timeout_s
        self._lock = threading.Lock()
        self._answer: M | None = None
        self._asked_at = -float("inf")

    @property
    def answer(self) -> M | None:
        with self._lock:
            return self._answer

    def poll(self) -> M | None:
        """The answer when one came; otherwise asks when the last question is ``retry_s`` old."""
        answer = self.answer
        if answer is None and time.monotonic() - self._asked_at >= self._retry_s:
            self._asked_at = time.monotonic()
            self._session.get(self._selector, self._on_reply, timeout=self._reply_timeout_s)
        return answer

    def _on_reply(self, reply: zenoh.Reply) -> None:
        if reply.ok is None:
            return
        message = decode(self._model, self._selector, reply.ok.payload.to_bytes(), self._invalid)
        if message is not None:
            with self._lock:
                if self._answer is None:
                    self._answer = message
