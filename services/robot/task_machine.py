"""The robot's task states as data (paper §5.2, Fig. 12): idle → detect component position → pick up →
identify target location → assemble → idle.

The table is a plain tuple of ``(trigger, source, dest)`` rows over
:class:`bimbot.shared.messages.RobotState`, and :class:`TaskMachine` is a minimal interpreter of it. A
plain table rather than a ``transitions`` machine (the agents use one because thousands of them share
it): the robot is one object per process, needs no callbacks, and the executor asks "may I fire this?" on
every control tick, which is a dict lookup here. The table is still data, tested on its own, like the
agents' table.

Triggers (what the executor observed):

* ``assigned`` — the planner assigned a task to this robot;
* ``located`` — the component's current pose is known and an approach pose beside it was found;
* ``attached`` — physics accepted the attach request: the component rides on the robot;
* ``arrived`` — the robot stands at the approach pose of the component's target;
* ``finished`` — the component gave its verdict after the placement (constructed, misplaced or failed);
* ``aborted`` — the task was withdrawn (reassigned, released again) or given up: back to idle from anywhere.
"""

from __future__ import annotations

from enum import StrEnum

from bimbot.shared.messages import RobotState


class Trigger(StrEnum):
    ASSIGNED = "assigned"
    LOCATED = "located"
    ATTACHED = "attached"
    ARRIVED = "arrived"
    FINISHED = "finished"
    ABORTED = "aborted"


_S = RobotState
_T = Trigger

TRANSITIONS: tuple[tuple[Trigger, RobotState, RobotState], ...] = (
    (_T.ASSIGNED, _S.IDLE, _S.DETECT_COMPONENT_POSITION),
    (_T.LOCATED, _S.DETECT_COMPONENT_POSITION, _S.PICK_UP),
    (_T.ATTACHED, _S.PICK_UP, _S.IDENTIFY_TARGET_LOCATION),
    (_T.ARRIVED, _S.IDENTIFY_TARGET_LOCATION, _S.ASSEMBLE),
    (_T.FINISHED, _S.ASSEMBLE, _S.IDLE),
    (_T.ABORTED, _S.DETECT_COMPONENT_POSITION, _S.IDLE),
    (_T.ABORTED, _S.PICK_UP, _S.IDLE),
    (_T.ABORTED, _S.IDENTIFY_TARGET_LOCATION, _S.IDLE),
    (_T.ABORTED, _S.ASSEMBLE, _S.IDLE),
)

INITIAL = RobotState.IDLE
PAPER_ORDER: tuple[RobotState, ...] = (
    _S.IDLE,
    _S.DETECT_COMPONENT_POSITION,
    _S.PICK_UP,
    _S.IDENTIFY_TARGET_LOCATION,
    _S.ASSEMBLE,
    _S.IDLE,
)

_TABLE: dict[tuple[Trigger, RobotState], RobotState] = {(t, s): d for t, s, d in TRANSITIONS}


def next_state(state: RobotState, trigger: Trigger) -> RobotState | None:
    """Where ``trigger`` leads from ``state``, or None when the table does not allow it."""
    return _TABLE.get((trigger, state))


def triggers_from(state: RobotState) -> set[Trigger]:
    """The triggers the table accepts in ``state``."""
    return {t for t, s, _ in TRANSITIONS if s == state}


class TaskMachine:
    """The robot's current task state; :meth:`fire` applies a trigger the table allows."""

    def __init__(self, state: RobotState = INITIAL) -> None:
        self.state = state

    def can(self, trigger: Trigger) -> bool:
        return next_state(self.state, trigger) is not None

    def fire(self, trigger: Trigger) -> bool:
        """Apply ``trigger``; False (state unchanged) when the table does not allow it here."""
        dest = next_state(self.state, trigger)
        if dest is None:
            return False
        self.state = dest
        return True
