"""The no-progress watchdog: an assigned task whose component stands still too long is taken back.

Why: a robot can stall without a word (boxed in, a lost message, a bug); the bound in sim time makes
every wait finite. An assigned task whose component has not changed state for ``task_timeout_s`` sim
seconds is given back (``no_progress``, counted as a give-back); one worked on in place (forming,
pouring, laying) gets the expected duration of its work on top (:func:`.work_in_place.work_s`), and a
machine that relocates before it works its longest relocation too.
"""

from __future__ import annotations

from bimbot.shared.messages import ComponentState
from bimbot.shared.reasons import Reason, ReasonCode

from .capability import relocation_to_s
from .give_backs import GiveBacks
from .planner_state import PlannerState
from .records import WORKING, Phase, TaskRecord
from .work_in_place import work_s


class Watchdog:
    """Bounds how long an assigned task may stand still (owns when it last looked: revision, sim time)."""

    def __init__(self, state: PlannerState, give_backs: GiveBacks) -> None:
        self._state = state
        self._give_backs = give_backs
        self._watched: tuple[int, float] | None = None  # (revision, sim time) of the last pass

    def watch(self) -> None:
        """Give back every assigned task past its bound (:meth:`task_bound_s`)."""
        state = self._state
        if self._watched == (state.revision, state.sim_time_s):
            return  # no sim time passed and nothing changed since the last pass
        self._watched = (state.revision, state.sim_time_s)
        for task in state.tasks_in(Phase.ASSIGNED):
            component_state = state.components[task.guid].state
            if task.phase is not Phase.ASSIGNED or component_state is ComponentState.VERIFYING:
                continue  # given back by this very pass (its revision follows), or being verified
            idle_s = state.sim_time_s - task.changed_sim_s
            bound = self.task_bound_s(task)
            if idle_s > bound:
                work = bound - state.limits.task_timeout_s
                of_work = f" with {work:.0f} s of work in place" if work > 0 else ""
                reason = Reason(
                    code=ReasonCode.NO_PROGRESS,
                    message=(
                        f"{task.active_id} made no progress for {idle_s:.0f} s of sim time "
                        f"(bound {bound:.0f} s{of_work}; component {component_state.value}, "
                        f"robot {task.robot_id})"
                    ),
                    robot_id=task.robot_id,
                )
                self._give_backs.give_back(task.guid, reason.message, reason)

    def task_bound_s(self, task: TaskRecord) -> float:
        """How long an assigned task may go without a state change of its component (sim s): the fixed
        bound, plus the expected duration of its work while it is worked on in place (and for a machine
        that relocates before it works, its longest relocation to where it works on it)."""
        state = self._state
        bound = state.limits.task_timeout_s
        if state.components[task.guid].state in WORKING:
            robot = state.site.get(task.robot_id or "") if state.site is not None else None
            bound += work_s(state.manifest[task.guid], robot.description if robot is not None else None)
            if robot is not None and robot.description.relocates:  # it may relocate first: from anywhere
                component = state.manifest[task.guid]
                bound += max(relocation_to_s(robot, pose[:2], component) for pose in robot.set_up_at)
        return bound
