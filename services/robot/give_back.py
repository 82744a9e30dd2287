"""Why a robot gives a task back: the reasons it sends with ``abandon``, as sentences with the numbers (pure).

Why apart from the executor: every reason a robot can give is here, each one small function, tested on its
own; the executor only decides *when*. Codes (:class:`bimbot.shared.reasons.ReasonCode`): navigation keeps
the code the navigator diagnosed (``robot_trapped``, ``unreachable``, ``no_progress``); physics refusing is
``physics_refused`` with physics' own words; a task that stalls, a component someone else carries or whose
position nobody knows is ``no_progress``. ``no_approach_pose`` / ``unreachable`` for stand-points come
from :func:`.approach.no_approach_reason`.
"""

from __future__ import annotations

from bimbot.shared.messages import RobotState
from bimbot.shared.reasons import Reason, ReasonCode


def stalled(robot_id: str, state: RobotState, stalled_s: float, bound_s: float) -> Reason:
    """The task watchdog: no task state change within its bound."""
    return Reason(
        code=ReasonCode.NO_PROGRESS,
        robot_id=robot_id,
        message=(
            f"{robot_id} stayed in {state.value.replace('_', ' ')} for {stalled_s:.0f} s of sim time "
            f"(the task watchdog allows {bound_s:.0f} s)"
        ),
    )


def navigation_failed(robot_id: str, what: str, tries: int, failure: Reason | None) -> Reason:
    """Navigation to ``what`` failed ``tries`` times (each after the recovery chain and a new approach)."""
    if failure is None:
        return Reason(
            code=ReasonCode.NO_PROGRESS,
            robot_id=robot_id,
            message=f"{robot_id} could not drive to {what} in {tries} attempts",
        )
    return Reason(
        code=failure.code,
        robot_id=robot_id,
        message=f"{robot_id} could not drive to {what} in {tries} attempts; last: {failure.message}",
    )


def physics_refused(robot_id: str, kind: str, what: str, tries: int, why: str) -> Reason:
    """Physics refused the ``kind`` request (attach, place) ``tries`` times: its own reason quoted."""
    return Reason(
        code=ReasonCode.PHYSICS_REFUSED,
        robot_id=robot_id,
        message=f"physics refused the {kind} of {what} by {robot_id} {tries} times; last: {why}",
    )


def carried_by(robot_id: str, what: str, carrier: str) -> Reason:
    return Reason(
        code=ReasonCode.NO_PROGRESS,
        robot_id=robot_id,
        message=f"{what} is carried by {carrier}, so {robot_id} cannot pick it up",
    )


def position_unknown(robot_id: str, what: str) -> Reason:
    return Reason(
        code=ReasonCode.NO_PROGRESS,
        robot_id=robot_id,
        message=f"{robot_id} knows no position of {what}: physics published no pose of it",
    )


def withdrawn(robot_id: str, what: str) -> Reason:
    return Reason(
        code=ReasonCode.NO_PROGRESS,
        robot_id=robot_id,
        message=f"the planner took the task of {what} back while {robot_id} carried it",
    )


def walls_itself_in(robot_id: str, what: str, reach_m: float) -> Reason:
    """Setting ``what`` would wall the robot in: once it stands, no stand-point within reach keeps a way
    back to the depot (``no_approach_pose``: the planner asks a crane first, :mod:`bimbot.services.planner.
    dispatch`)."""
    return Reason(
        code=ReasonCode.NO_APPROACH_POSE,
        robot_id=robot_id,
        message=(
            f"{robot_id} would wall itself in setting {what}: once it stands, no stand-point within "
            f"{robot_id}'s reach ({reach_m:.2f} m) of it keeps a way back to its depot; a crane lifts it "
            "in, or it is set from where its robot can still leave"
        ),
    )
