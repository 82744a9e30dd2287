"""Why a component was not built: a small closed set of reason codes, each with a sentence naming numbers.

Every component a build does not construct ends ``failed`` or ``blocked`` with one :class:`Reason`. The
reason travels with the state change (``ComponentStateMsg.reason``, set by the component's agent from the
event that caused it), the digital twin (``TwinMsg.reason``), the planner's progress
(``ProgressMsg.reasons``) and the construction report (``report.json``: a ``reason`` object per component
that is not constructed). A robot that gives a task back says why on its ``abandon`` event; the planner
fails a component after a bounded number of give-backs with the last of those reasons.

Codes (what a user can act on):

========================  ==========================================================================
``no_approach_pose``      no free cell within the robot's reach beside the component or its target
``unreachable``           the target or the yard cell is cut off from the robot (walls, built parts)
``robot_trapped``         the robot could not get out of where it stood (recoveries exhausted)
``too_heavy``             the component's mass exceeds every robot's payload
``out_of_reach``          the target's height or distance exceeds the robot's reach
``no_capable_robot``      no robot on site can do the work its method needs (pour, lay, carry or lift)
``physics_refused``       physics refused an attach or a placement (its own reason quoted)
``misplaced``             every placement attempt was out of tolerance (the agent's own verdict)
``no_progress``           a task made no progress within its bound of sim time
``blocked_by``            a predecessor failed (``guid`` names it); never released
``stalled``               nothing on the site changed for too long; the run ended
``interrupted``           the run was stopped (signal or wall-time limit) before it was built
``unstable``              the placed component moved (slid, tipped, fell) beyond the threshold
========================  ==========================================================================
"""

from __future__ import annotations

from enum import StrEnum

from pydantic import BaseModel, ConfigDict, Field


class ReasonCode(StrEnum):
    NO_APPROACH_POSE = "no_approach_pose"
    UNREACHABLE = "unreachable"
    ROBOT_TRAPPED = "robot_trapped"
    TOO_HEAVY = "too_heavy"
    OUT_OF_REACH = "out_of_reach"
    NO_CAPABLE_ROBOT = "no_capable_robot"
    PHYSICS_REFUSED = "physics_refused"
    MISPLACED = "misplaced"
    NO_PROGRESS = "no_progress"
    BLOCKED_BY = "blocked_by"
    STALLED = "stalled"
    INTERRUPTED = "interrupted"
    UNSTABLE = "unstable"


MESSAGE_MAX = 2000  # characters of a reason's sentence

# a ground robot's give-back that says it cannot get to where the component goes (or to its yard slot)
CANNOT_GET_THERE = frozenset({ReasonCode.UNREACHABLE, ReasonCode.NO_APPROACH_POSE})


class Reason(BaseModel):
    """One reason: a code, a sentence with the numbers, and who or what it names."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    code: ReasonCode
    message: str = Field(max_length=MESSAGE_MAX, description="one sentence naming the numbers")
    guid: str | None = Field(default=None, description="the other component (blocked_by: the failed one)")
    robot_id: str | None = Field(default=None, description="the robot it happened to, if one")

    def line(self) -> str:
        """``code: message`` for a log line or a table cell."""
        return f"{self.code.value}: {self.message}"


def blocked_by(failed_guid: str, failed_reason: Reason | None = None, *, via: str | None = None) -> Reason:
    """The reason of a component resting on a failed one: directly, or ``via`` the one it stands on."""
    why = f" ({failed_reason.code.value})" if failed_reason is not None else ""
    message = (
        f"it rests on {failed_guid}, which was not built{why}"
        if via is None
        else f"it rests on {via}, which stands on {failed_guid}, not built{why}"
    )
    return Reason(code=ReasonCode.BLOCKED_BY, message=message, guid=failed_guid)


#: What a user can do about a clash in the IFC (two components the model puts into each other): said by a
#: component's failed ``unstable`` reason and by ``bimbot run --check-stability``.
CLASH_ADVICE = (
    "repair the clash in the model (two components cannot both be placed where they overlap), or leave one "
    "of them out"
)

#: How far a connection reaches (services/physics/connections.py): a component set down at its target is
#: connected to what is built this close at its side. Said by the ``unstable`` reasons and by
#: ``bimbot run --check-stability``, so one number serves physics and what the user reads.
CONNECTION_GAP_M = 0.1
BESIDE_IT = f"within {CONNECTION_GAP_M:g} m at its side"


def clash_clause(depths_m: list[tuple[str, float]]) -> str:
    """``"; at its target the model puts it into A (229 mm deep): a clash in the IFC, …"`` for the
    components (as the caller names them) a placed one overlapped deeper than a contact, or ``""``."""
    if not depths_m:
        return ""
    into = ", ".join(f"{name} ({1000.0 * depth_m:.0f} mm deep)" for name, depth_m in depths_m)
    return (
        f"; at its target the model puts it into {into}: a clash in the IFC, and physics pushed the two apart"
    )
