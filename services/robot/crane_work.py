"""A tower crane's side of a task: it never drives, it reaches or it does not.

Why apart from :mod:`.executor`: the executor's cycle (detect → pick up → carry → assemble) is the same
for every robot type, but where a ground robot chooses a stand-point and drives there (:mod:`.driving`),
a crane only checks that its hook reaches the component where it lies and its target with that mass (its
load chart, :meth:`bimbot.shared.robot_description.RobotDescription.reaches`). A task it cannot reach is
given back at once with ``out_of_reach`` naming the numbers (the planner should never assign one: this is
the guard). Its assembly motion lasts what its slew, trolley and hoist take (:meth:`CraneSpec.motion_s`)
plus its handling time, so the sim clock charges a crane lift what it costs.
"""

from __future__ import annotations

import logging
import math

import numpy as np

from bimbot.shared.footprint import Footprint
from bimbot.shared.messages import PlaceRequest
from bimbot.shared.reasons import Reason, ReasonCode

from .handover import Handover
from .robot_context import RobotContext
from .task_state import Task, component_name

_log = logging.getLogger(__name__)


class CraneReach:
    """Reach checks instead of driving (a :class:`.robot_context.GettingThere` for a crane): the crane is
    there when its hook reaches; else the task goes back through ``handover`` (``out_of_reach``)."""

    def __init__(self, context: RobotContext, handover: Handover) -> None:
        self.context, self.handover = context, handover

    def _hook_reaches(self, task: Task, footprint: Footprint | None) -> Reason | None:
        """None when the hook reaches ``footprint`` with the task's component; else why not."""
        if footprint is None:
            return None
        context = self.context
        description, home_xy = context.description, context.home_xy_yaw[:2]
        mass = task.component.mass_kg
        if description.reaches(home_xy, footprint.polygon_xy_m, mass):
            return None
        crane = description.crane
        assert crane is not None
        corners = np.hypot(*(footprint.polygon_xy_m - np.asarray(home_xy)).T)
        robot_id = context.robot_id
        return Reason(
            code=ReasonCode.OUT_OF_REACH,
            robot_id=robot_id,
            message=(
                f"{component_name(task)} spans {corners.min():.1f}–{corners.max():.1f} m from {robot_id}; "
                f"its hook reaches {crane.min_radius_m:.1f}–{crane.radius_for(mass):.1f} m with "
                f"{mass:,.0f} kg (load chart)"
            ),
        )

    def drive(self, task: Task, footprint: Footprint | None) -> bool:
        """A crane is there when its hook reaches; else the task is given back (``out_of_reach``)."""
        why = self._hook_reaches(task, footprint)
        if why is None:
            return True
        self.handover.give_back(task, why)
        return False

    def approach(self, task: Task, footprint: Footprint) -> bool:
        return self.drive(task, footprint)

    def target_cut_off(self, task: Task) -> Reason | None:
        return self._hook_reaches(task, task.target)


class CraneHandover(Handover):
    """A crane's physics requests: a placement lasts what the lift takes (slew, trolley, hoist, handling)."""

    def place_request(self, task: Task) -> PlaceRequest:
        request = super().place_request(task)
        context = self.context
        description, home_xy = context.description, context.home_xy_yaw[:2]
        crane = description.crane
        assert crane is not None
        lying = context.site_map.footprints.get(task.message.guid)
        start = lying.centre_xy_m if lying is not None else np.asarray(home_xy)
        start_z = lying.z_max_m if lying is not None else 0.0
        end = request.pose.position_m
        motion_s = crane.motion_s(home_xy, (*start, start_z), end)
        duration_s = max(request.duration_s, motion_s + description.handling_s)
        _log.info(
            "%s: lifting %s, %.0f s (slew, trolley, hoist %.0f s; handling %.0f s)",
            context.robot_id,
            task.message.guid,
            duration_s,
            motion_s,
            description.handling_s,
        )
        return request.model_copy(update={"duration_s": math.ceil(duration_s)})
