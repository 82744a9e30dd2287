"""The robot's side of the construction protocol, as small pure pieces (docs/architecture.md).

* :class:`EventQueue` — events to one component, delivered **at least once and in order**: only the oldest
  unconfirmed event is (re)sent, every ``resend_s`` wall seconds with the same ``event_id``, until the
  component's state shows it applied (:data:`CONFIRMS`); then the next goes out at once. An agent that is
  down for a while loses nothing, and never sees ``attach`` before ``pick``. The agent ignores a repeat of
  an event it applied, so when the state message that confirmed it was lost (a router that restarted),
  only the twin can say: the robot asks it once the event has gone unconfirmed for a while
  (:meth:`EventQueue.unconfirmed_for_s`).
* :class:`PhysicsRequest` / :class:`PhysicsResult` — an attach, place, drop or build request for the adapter
  to send without blocking (``session.get`` with a callback), and what came back (or a timeout).
* :func:`injected` — which first placements are deliberately offset (tests, demos), deterministically.
"""

from __future__ import annotations

import math
import zlib
from collections import deque
from dataclasses import dataclass
from typing import Protocol

from bimbot.shared.component_states import TwinQuestion
from bimbot.shared.messages import (
    AttachRequest,
    BuildRequest,
    ClockMsg,
    CmdVelMsg,
    ComponentEvent,
    ComponentEventMsg,
    ComponentState,
    DropRequest,
    PhysicsReply,
    PlaceRequest,
    PlanMsg,
    RobotStateMsg,
    SetUpRequest,
    TaskMsg,
    TaskStatus,
)

_E, _C = ComponentEvent, ComponentState

CONFIRMS: dict[ComponentEvent, frozenset[ComponentState]] = {
    _E.PICK: frozenset({_C.PICKING, _C.TRANSPORTING, _C.ASSEMBLING, _C.VERIFYING, _C.CONSTRUCTED}),
    _E.ATTACH: frozenset({_C.TRANSPORTING, _C.ASSEMBLING, _C.VERIFYING, _C.CONSTRUCTED}),
    _E.ARRIVE: frozenset({_C.ASSEMBLING, _C.VERIFYING, _C.CONSTRUCTED}),
    _E.PLACE: frozenset({_C.VERIFYING, _C.CONSTRUCTED, _C.MISPLACED, _C.FAILED}),
    _E.ABANDON: frozenset({_C.RELEASED, _C.CONSTRUCTED, _C.FAILED, _C.MISPLACED}),
    # not transporting: that is the state before the hand-off (then a crane picks it up)
    _E.HAND_OFF: frozenset({_C.RELEASED, _C.PICKING, _C.ASSEMBLING, _C.VERIFYING, _C.CONSTRUCTED}),
    _E.FORM: frozenset({_C.FORMING, _C.POURING, _C.VERIFYING, _C.CONSTRUCTED}),
    _E.POUR: frozenset({_C.POURING, _C.VERIFYING, _C.CONSTRUCTED}),
    _E.LAY: frozenset({_C.LAYING, _C.VERIFYING, _C.CONSTRUCTED}),
    _E.DRIVE: frozenset({_C.DRIVING, _C.VERIFYING, _C.CONSTRUCTED}),
}
"""The component states that show an event applied (or overtaken by what followed it)."""

VERDICTS = frozenset({_C.CONSTRUCTED, _C.MISPLACED, _C.FAILED})


class EventQueue:
    """Events for one component, sent at least once and in order (see the module doc)."""

    def __init__(self, resend_s: float) -> None:
        self.resend_s = resend_s
        self._pending: deque[ComponentEventMsg] = deque()
        self._last_send_wall_s = -math.inf
        self._head_sent_wall_s: float | None = None  # when the oldest unconfirmed event first went out
        self.queued: set[ComponentEvent] = set()  # every event ever queued here

    def push(self, message: ComponentEventMsg) -> None:
        self._pending.append(message)
        self.queued.add(message.event)

    @property
    def unconfirmed(self) -> set[ComponentEvent]:
        return {message.event for message in self._pending}

    def __bool__(self) -> bool:
        return bool(self._pending)

    def confirm(self, state: ComponentState | None, *, verdict_seen: bool = False) -> None:
        """Drop the events the component's latest ``state`` shows applied (``place`` also by a verdict
        seen earlier: the state may already have moved on, e.g. misplaced → released by a retry)."""
        while self._pending:
            head = self._pending[0].event
            applied = state is not None and state in CONFIRMS[head]
            if not applied and not (head is _E.PLACE and verdict_seen):
                return
            self._pending.popleft()
            self._last_send_wall_s = -math.inf  # the next one goes out at once
            self._head_sent_wall_s = None

    def due(self, wall_s: float) -> ComponentEventMsg | None:
        """The event to (re)send now, if any."""
        if not self._pending or wall_s - self._last_send_wall_s < self.resend_s:
            return None
        self._last_send_wall_s = wall_s
        if self._head_sent_wall_s is None:
            self._head_sent_wall_s = wall_s
        return self._pending[0]

    def unconfirmed_for_s(self, wall_s: float) -> float:
        """Wall seconds since the oldest unconfirmed event first went out (0 when none is out)."""
        if not self._pending or self._head_sent_wall_s is None:
            return 0.0
        return wall_s - self._head_sent_wall_s


@dataclass(frozen=True)
class PhysicsRequest:
    """A request for the adapter to send to ``physics/<kind>`` with a callback (never blocking)."""

    kind: str  # "attach", "place", "drop", "build" or "relocate"
    request_id: int
    message: AttachRequest | PlaceRequest | DropRequest | BuildRequest | SetUpRequest
    timeout_s: float


@dataclass(frozen=True)
class PhysicsResult:
    """What came back for a request: the reply, or None with ``error`` (timeout, undecodable)."""

    request_id: int
    reply: PhysicsReply | None
    error: str = ""


Outgoing = CmdVelMsg | RobotStateMsg | PlanMsg | ComponentEventMsg | PhysicsRequest | TwinQuestion
"""What an executor hands its adapter to send."""


class RobotExecutor(Protocol):
    """What the robot's adapter needs of an executor (:class:`.executor.Executor` for robots that carry or
    lift, :class:`.site_work.SiteWorkExecutor` for those that work in place)."""

    robot_id: str
    sim_s: float  # set by the lock-step loop before a step's inputs (:mod:`.stepped`)
    step: int
    localisation_error_m: float
    max_localisation_error_m: float

    @property
    def home_xy_yaw(self) -> tuple[float, float, float]: ...

    @property
    def distance_m(self) -> float: ...

    @property
    def done(self) -> list[tuple[str, ComponentState]]: ...

    def handle(self, message: object) -> None: ...

    def tick(self, clock: ClockMsg, wall_s: float) -> list[Outgoing]: ...

    def after_tick(self) -> None: ...

    def can_sleep(self) -> bool: ...

    def sleeps_until_s(self) -> float | None: ...

    def poll(self, wall_s: float) -> list[Outgoing]: ...


def injected(
    guid: str, attempt: int, *, error_m: float, guids: frozenset[str], fraction: float, seed: int
) -> bool:
    """Whether the placement of ``guid`` at ``attempt`` (0: the first) is offset by ``error_m``: the named
    ``guids``, else a ``fraction`` of all (every one when 0) chosen by a CRC of seed and GUID."""
    if error_m <= 0 or attempt > 0:
        return False
    if guids:
        return guid in guids
    share = fraction if fraction > 0 else 1.0
    return zlib.crc32(f"{seed}:{guid}".encode()) / 2**32 < share


def assignment_waiting(
    tasks: dict[str, TaskMsg], robot_id: str, performed: set[tuple[str, int, float]]
) -> bool:
    """Whether a task assigned to ``robot_id`` has not been taken on (it waits for its component's
    release: a component state, not a task message, starts it)."""
    return any(
        message.status is TaskStatus.ASSIGNED
        and message.robot_id == robot_id
        and (message.task_id, message.attempt, message.wall_time_s) not in performed
        for message in tasks.values()
    )
