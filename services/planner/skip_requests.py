"""Asking physics to skip a quiet site's clock (``physics/skip``): the bus side of :mod:`.quiet`.

The planner's loop calls :meth:`Skipper.tick` after every step. It asks the core whether the site is quiet
(:meth:`~.scheduler.PlannerCore.quiet_until`, a pass over the tasks when the robots are still) at most once
per ``check_s`` wall seconds, and physics only when it is: one question at a time and at most one per
``retry_s`` wall seconds, so a site physics keeps refusing (something still moves) costs one query now and
then, not one per loop. The answer comes back through the inbox as a :class:`SkipAnswer`, which the loop
hands to :meth:`Skipper.answered`: an accepted skip is logged (INFO), a refusal or silence at DEBUG.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass

import zenoh

from bimbot.shared.bus import Inbox, decode, encode
from bimbot.shared.messages import PHYSICS_SKIP, PhysicsReply, SkipRequest

from .quiet import Skip

_log = logging.getLogger(__name__)

RETRY_S = 2.0  # wall seconds between two skip requests
CHECK_S = 0.5  # wall seconds between two looks at whether the site is quiet
TIMEOUT_S = 5.0  # wall seconds for physics to answer one


@dataclass(frozen=True)
class SkipAnswer:
    """Physics' reply to a skip request (None: no reply, ``error`` says why)."""

    request: SkipRequest
    reply: PhysicsReply | None
    error: str = ""


class Skipper:
    """When to ask for a skip, and what came of it. ``send`` puts the request on the bus (its answer must
    come back as a :class:`SkipAnswer`); pure otherwise, the wall time is passed in."""

    def __init__(
        self,
        send: Callable[[SkipRequest], None],
        *,
        retry_s: float = RETRY_S,
        timeout_s: float = TIMEOUT_S,
        check_s: float = CHECK_S,
        participant: str | None = None,
    ) -> None:
        """``participant``: the lock-step participant the requests say asked (its answer counts them)."""
        self._send = send
        self.participant = participant
        self.retry_s, self.timeout_s, self.check_s = retry_s, timeout_s, check_s
        self._asked_wall_s: float | None = None  # a question in flight since then
        self._next_wall_s = 0.0  # no question before then
        self._next_check_wall_s = 0.0  # no look at the site before then
        self.accepted = 0
        self.refused = 0

    def tick(
        self, quiet_until: Callable[[], Skip | None], now_wall_s: float, *, step: int | None = None
    ) -> SkipRequest | None:
        """Ask for the skip ``quiet_until`` allows, when no question is in flight and the last one is
        ``retry_s`` old; the request sent, or None. ``step``: the clock step the planner answers (in
        lock-step physics acts on the request after it, at the same step in every run)."""
        if self._asked_wall_s is not None and now_wall_s - self._asked_wall_s <= self.timeout_s + 1.0:
            return None
        if now_wall_s < self._next_wall_s or now_wall_s < self._next_check_wall_s:
            return None
        self._next_check_wall_s = now_wall_s + self.check_s
        skip = quiet_until()
        if skip is None:
            return None
        request = SkipRequest(
            to_sim_s=skip.to_sim_s,
            why=skip.why[:500],
            step=step,
            participant=self.participant,
            holding=list(skip.holding),
        )
        self._asked_wall_s, self._next_wall_s = now_wall_s, now_wall_s + self.retry_s
        self._send(request)
        return request

    def answered(self, answer: SkipAnswer) -> None:
        self._asked_wall_s = None
        reply = answer.reply
        if reply is not None and reply.ok:
            self.accepted += 1
            request = answer.request
            if reply.sim_time_s < request.to_sim_s - 1e-6:
                held = ", ".join(request.holding)
                _log.info(
                    "physics skipped its clock to %.0f s, where a hold of %s ends", reply.sim_time_s, held
                )
            else:
                _log.info("physics skipped its clock to %.0f s: %s", request.to_sim_s, request.why)
            return
        self.refused += 1
        why = reply.reason if reply is not None else answer.error
        _log.debug("skip to %.0f s not made: %s", answer.request.to_sim_s, why or "refused")


def bus_sender(session: zenoh.Session, site: str, inbox: Inbox) -> Callable[[SkipRequest], None]:
    """A ``send`` for :class:`Skipper`: a query on ``physics/skip`` whose answer goes to ``inbox``."""
    selector = PHYSICS_SKIP.key(site=site)

    def send(request: SkipRequest) -> None:
        replied = False

        def on_reply(reply: zenoh.Reply) -> None:
            nonlocal replied
            replied = True
            if reply.ok is None:
                error = reply.err.payload.to_string() if reply.err is not None else "error reply"
                inbox.put(SkipAnswer(request, None, error))
                return
            message = decode(PhysicsReply, selector, reply.ok.payload.to_bytes(), inbox.invalid)
            inbox.put(SkipAnswer(request, message, "" if message else "invalid reply"))

        def on_done() -> None:
            if not replied:
                inbox.put(SkipAnswer(request, None, "no reply (timeout)"))

        handler = zenoh.handlers.Callback(on_reply, on_done, indirect=False)  # in order with the clock
        session.get(selector, handler, payload=encode(request), timeout=TIMEOUT_S)

    return send
