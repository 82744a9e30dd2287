"""What the plan fidelity's clock hears, taken at a defined step, in a defined order (pure).

Why: the plan fidelity's physics (:mod:`.plan_fidelity`) jumps its clock once nothing was heard for a few
periods, to the earliest event it knows (a robot's timed work, a drive's end). What it has heard decides
when it jumps and where to: a robot's state, path or event, a task, a component's state. Heard as they
arrived, the messages a participant stamped at the open step ``k`` came before physics advanced from ``k``
in some runs and after it in others: the jump fell a period earlier or later, or went past what a robot
had just said, and two runs of one seed drifted apart. In
lock-step, physics advances from ``k`` only once every participant has answered ``k − 1``, and each
participant's messages come before its answer (:mod:`bimbot.shared.step_gate`): what is stamped at or
before ``k − 1`` has all arrived by then. That, and only that, is taken before advancing from ``k``, in
(stamp, sender, arrival) order; what is stamped ``k`` waits for the next advance. A participant's answer
to a step (:class:`~bimbot.shared.messages.StepDoneMsg`) is taken the same way: it says when the
participant acts next of its own accord (the planner: a curing's end), which the clock must not jump past.
"""

from __future__ import annotations

from bimbot.shared.messages import (
    ComponentEventMsg,
    ComponentStateMsg,
    PlanMsg,
    RobotStateMsg,
    StepDoneMsg,
    TaskMsg,
)
from bimbot.shared.step_gate import StepGate

DELAY_STEPS = 1  # before advancing from k: what was stamped at k - 1 or before (everyone answered k - 1)

News = PlanMsg | RobotStateMsg | TaskMsg | ComponentEventMsg | ComponentStateMsg | StepDoneMsg


def sender(message: News) -> str:
    """Who sent ``message``, as far as its order goes: one name per process whose puts keep their order
    (a robot, the planner) or per component (an agents shard keeps each component's order)."""
    match message:
        case PlanMsg() | RobotStateMsg():
            return message.robot_id
        case TaskMsg():
            return "planner"
        case ComponentEventMsg():
            return message.source
        case ComponentStateMsg():
            return message.guid
        case StepDoneMsg():
            return message.participant


class SteppedNews:
    """Messages held until the advance that takes them (see the module doc)."""

    def __init__(self) -> None:
        self.gate: StepGate[News] = StepGate(delay_steps=DELAY_STEPS)

    def clock(self, step: int, sim_time_s: float) -> None:
        """Step ``step`` went out at ``sim_time_s`` (what its answers are stamped with)."""
        self.gate.clock(step, sim_time_s)

    def put(self, message: object) -> bool:
        """Hold ``message`` for its step; False when it is no news (another kind)."""
        if not isinstance(message, News):
            return False
        self.gate.put(message.sim_time_s, sender(message), message)
        return True

    def take(self, step: int) -> list[News]:
        """Before advancing from ``step``: what is stamped at ``step − 1`` or before, in (stamp, sender,
        arrival) order (nothing while the time of ``step − 1`` is not known: the first step after a start)."""
        return self.gate.take(step)

    def pending(self) -> int:
        return self.gate.pending()
