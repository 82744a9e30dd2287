"""The robot's task states as data (paper §5.2, Fig. 12): idle → detect component position → pick up →
identify target location → assemble → idle.

The table is a plain tuple of ``(trigger, source, dest)`` rows over
:class:`bimbot.shared.messages.RobotState`, tested on its own, and run by the same mechanism as the
component agents' table: :class:`bimbot.shared.table_machine.TableMachine`, one ``transitions`` machine
(built once per process) with :class:`TaskMachine` as its model. The executor fires a trigger only when
it observed something, a few times per task, so the ~6 µs of a ``transitions`` trigger do not matter.

Triggers (what the executor observed):

* ``assigned`` — the planner assigned a task to this robot;
* ``located`` — the component's current pose is known and an approach pose beside it was found;
* ``attached`` — physics accepted the attach request: the component rides on the robot;
* ``arrived`` — the robot stands at the approach pose of the component's target;
* ``finished`` — the component gave its verdict after the placement (constructed, misplaced or failed);
* ``handed_off`` — a hand-off task: the component lies at the crane's staging spot, released again;
* ``aborted`` — the task was withdrawn (reassigned, released again) or given up: back to idle from anywhere;
* ``work_assigned`` — a machine that builds in place (a pump, a block layer) took a task: it works where
  it stands (``work_in_place``) until the component's verdict (``finished``) or it gives the task back.
"""

from __future__ import annotations

from enum import StrEnum

from bimbot.shared import table_machine
from bimbot.shared.messages import RobotState
from bimbot.shared.table_machine import TableMachine


class Trigger(StrEnum):
    """What the executor observed (the module doc says when each is fired)."""

    ASSIGNED = "assigned"
    LOCATED = "located"
    ATTACHED = "attached"
    ARRIVED = "arrived"
    FINISHED = "finished"
    HANDED_OFF = "handed_off"
    ABORTED = "aborted"
    WORK_ASSIGNED = "work_assigned"


_S = RobotState
_T = Trigger

TRANSITIONS: tuple[tuple[Trigger, RobotState, RobotState], ...] = (
    (_T.ASSIGNED, _S.IDLE, _S.DETECT_COMPONENT_POSITION),
    (_T.LOCATED, _S.DETECT_COMPONENT_POSITION, _S.PICK_UP),
    (_T.ATTACHED, _S.PICK_UP, _S.IDENTIFY_TARGET_LOCATION),
    (_T.ARRIVED, _S.IDENTIFY_TARGET_LOCATION, _S.ASSEMBLE),
    (_T.FINISHED, _S.ASSEMBLE, _S.IDLE),
    (_T.HANDED_OFF, _S.IDENTIFY_TARGET_LOCATION, _S.IDLE),
    (_T.ABORTED, _S.DETECT_COMPONENT_POSITION, _S.IDLE),
    (_T.ABORTED, _S.PICK_UP, _S.IDLE),
    (_T.ABORTED, _S.IDENTIFY_TARGET_LOCATION, _S.IDLE),
    (_T.ABORTED, _S.ASSEMBLE, _S.IDLE),
    (_T.WORK_ASSIGNED, _S.IDLE, _S.WORK_IN_PLACE),
    (_T.FINISHED, _S.WORK_IN_PLACE, _S.IDLE),
    (_T.ABORTED, _S.WORK_IN_PLACE, _S.IDLE),
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

_MACHINE = TableMachine(RobotState, TRANSITIONS, INITIAL)


def next_state(state: RobotState, trigger: Trigger) -> RobotState | None:
    """Where ``trigger`` leads from ``state``, or None when the table does not allow it."""
    return table_machine.next_state(TRANSITIONS, state, trigger)


def triggers_from(state: RobotState) -> set[Trigger]:
    """The triggers the table accepts in ``state``."""
    return {Trigger(name) for name in table_machine.triggers_from(TRANSITIONS, state)}


class TaskMachine:
    """The robot's current task state; :meth:`fire` applies a trigger the table allows."""

    __slots__ = ("state",)

    def __init__(self, state: RobotState = INITIAL) -> None:
        self.state: RobotState
        _MACHINE.start(self, state)

    def can(self, trigger: Trigger) -> bool:
        """True when the table allows ``trigger`` in the current state."""
        return _MACHINE.may_fire(self, trigger)

    def fire(self, trigger: Trigger) -> bool:
        """Apply ``trigger``; False (state unchanged) when the table does not allow it here."""
        return _MACHINE.fire(self, trigger)
