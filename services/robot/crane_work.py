"""A tower crane's side of a task: it never drives, it reaches or it does not (a mixin of the executor).

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
from typing import TYPE_CHECKING

import numpy as np

from bimbot.shared.footprint import Footprint
from bimbot.shared.messages import PlaceRequest
from bimbot.shared.reasons import Reason, ReasonCode
from bimbot.shared.robot_description import RobotDescription

from .handover import Handover
from .task_state import Task

if TYPE_CHECKING:
    from .navigator import Navigator
    from .site_map import SiteMap

_log = logging.getLogger(__name__)


class CraneWork:
    """Reach checks instead of driving: listed before :class:`.executor.Executor` in
    :class:`.executor.CraneExecutor`, its methods replace the driving ones."""

    description: RobotDescription
    robot_id: str
    site_map: SiteMap
    navigator: Navigator
    home_xy_yaw: tuple[float, float, float]

    if TYPE_CHECKING:  # defined by the executor and its other mixins

        def _give_back(self, task: Task, reason: Reason) -> None: ...

        def _name(self, task: Task) -> str: ...

    def _hook_reaches(self, task: Task, footprint: Footprint | None) -> Reason | None:
        """None when the hook reaches ``footprint`` with the task's component; else why not."""
        if footprint is None:
            return None
        mass = task.component.mass_kg
        if self.description.reaches(self.home_xy_yaw[:2], footprint.polygon_xy_m, mass):
            return None
        crane = self.description.crane
        assert crane is not None
        corners = np.hypot(*(footprint.polygon_xy_m - np.asarray(self.home_xy_yaw[:2])).T)
        return Reason(
            code=ReasonCode.OUT_OF_REACH,
            robot_id=self.robot_id,
            message=(
                f"{self._name(task)} spans {corners.min():.1f}–{corners.max():.1f} m from {self.robot_id}; "
                f"its hook reaches {crane.min_radius_m:.1f}–{crane.radius_for(mass):.1f} m with "
                f"{mass:,.0f} kg (load chart)"
            ),
        )

    def _drive(self, task: Task, footprint: Footprint | None) -> bool:
        """A crane is there when its hook reaches; else the task is given back (``out_of_reach``)."""
        why = self._hook_reaches(task, footprint)
        if why is None:
            return True
        self._give_back(task, why)
        return False

    def _approach(self, task: Task, footprint: Footprint) -> bool:
        return self._drive(task, footprint)

    def _target_cut_off(self, task: Task) -> Reason | None:
        return self._hook_reaches(task, task.target)

    def _park(self) -> None:
        """A crane stays where it stands."""

    def _place_request(self, task: Task) -> PlaceRequest:
        request = Handover._place_request(self, task)  # type: ignore[arg-type]
        crane = self.description.crane
        assert crane is not None
        lying = self.site_map.footprints.get(task.message.guid)
        start = lying.centre_xy_m if lying is not None else np.asarray(self.home_xy_yaw[:2])
        start_z = lying.z_max_m if lying is not None else 0.0
        end = request.pose.position_m
        motion_s = crane.motion_s(self.home_xy_yaw[:2], (*start, start_z), end)
        duration_s = max(request.duration_s, motion_s + self.description.handling_s)
        _log.info(
            "%s: lifting %s, %.0f s (slew, trolley, hoist %.0f s; handling %.0f s)",
            self.robot_id,
            task.message.guid,
            duration_s,
            motion_s,
            self.description.handling_s,
        )
        return request.model_copy(update={"duration_s": math.ceil(duration_s)})
