"""What the parts of one robot's executor share: the robot, its bounds, its map and navigator, and the time.

Why one object: the executor (:mod:`.executor`), its physics requests and give-backs (:mod:`.handover`),
its drives (:mod:`.driving`), a crane's reach checks (:mod:`.crane_work`), parking (:mod:`.parking`) and
the task cycle (:mod:`.task_cycle`) read the same facts and the clock the executor advances. Each
receives this object instead of declaring the executor's attributes. Only the executor sets the time
(``sim_s``, ``wall_s``) and the distance driven; a plan-fidelity robot swaps the navigator once, when it is
built.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from bimbot.shared.footprint import Footprint
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import ComponentEvent, SiteInfoMsg
from bimbot.shared.reasons import Reason
from bimbot.shared.robot_description import Capability, RobotDescription
from bimbot.shared.seeds import robot_stream

from .approach import ApproachConfig, cut_off
from .nav_types import controller_limits
from .navigator import Navigator, NavigatorConfig
from .recovery import held_where_it_stands
from .site_map import MapConfig, SiteMap
from .task_state import ExecutorConfig, Task, task_event


@dataclass
class RobotContext:
    """One robot as its executor's parts see it (see the module doc)."""

    config: ExecutorConfig
    description: RobotDescription
    site_map: SiteMap
    navigator: Navigator
    home_xy_yaw: tuple[float, float, float]  # its start pose: where it parks, where a crane stands
    approach_config: ApproachConfig
    sim_s: float = 0.0  # the sim time of the step being worked on
    wall_s: float = 0.0  # the wall time of the last tick or poll (event stamps, resends)
    distance_m: float = 0.0  # driven so far (its state message says it)
    # the other robots that drive: id → (their map inflation, their depot start), and where each last said
    # it stood (its state messages): what a placement must not shut in (:mod:`.shut_in_check`)
    drivers: dict[str, tuple[float, tuple[float, float]]] = field(default_factory=dict)
    others_xy: dict[str, tuple[float, float]] = field(default_factory=dict)
    # the other robots setting a part at its target now (their state messages: assembling or working in
    # place on a build task): id → (its guid, the outlines of the robots' height band it will occupy)
    others_placing: dict[str, tuple[str, list[NDArray[np.float64]]]] = field(default_factory=dict)

    @property
    def robot_id(self) -> str:
        return self.config.robot_id

    def cut_off_from_depot(self) -> bool:
        """Whether the robot is walled in: no way on its static map (the site plan and what is built; laser
        marks left out, they pass) leads from where it believes it stands to its depot start, or it cannot
        leave where it stands (:func:`.recovery.held_where_it_stands`: a part came to stand over it)."""
        grid = self.site_map.inflated_grid()
        here = self.navigator.pose_xy_yaw[:2]
        if cut_off(grid, here, self.home_xy_yaw[:2]):
            return True
        config = self.navigator.config
        body = self.site_map.inflated_grid(config.body_half_width_m)
        return held_where_it_stands(grid, body, here, config.plan_out_max_m)

    def beside_words(self, xy_m: tuple[float, float]) -> str:
        """``; beside it: Stud S4 (0.6 m), Door D1 (1.2 m)``: the components within the navigator's
        ``beside_m`` of the robot's body at ``xy_m`` (what may wall it in), nearest first, at most three;
        nothing when none is."""
        within_m = self.navigator.config.beside_m + self.site_map.config.inflation_m  # of its body
        beside = self.site_map.components_near(xy_m, within_m)
        if not beside:
            return ""
        return "; beside it: " + ", ".join(f"{name} ({m:.1f} m)" for name, m in beside[:3])

    def queue_event(
        self,
        task: Task,
        event: ComponentEvent,
        sim_s: float | None = None,
        reason: Reason | None = None,
        note: str = "",
    ) -> None:
        """Queue ``event`` for the task's component, stamped now (``sim_s`` when the event happened earlier
        or later than this step, e.g. physics fixed a placement): sent in order, at least once."""
        task.events.push(
            task_event(
                task.message,
                event,
                self.robot_id,
                sim_s=self.sim_s if sim_s is None else sim_s,
                wall_s=self.wall_s,
                reason=reason,
                note=note,
            )
        )


def robot_context(
    manifest: Manifest,
    info: SiteInfoMsg,
    config: ExecutorConfig,
    *,
    map_config: MapConfig,
    nav_config: NavigatorConfig | None,
    approach_config: ApproachConfig | None,
    start_xy_yaw: tuple[float, float, float] | None,
) -> RobotContext:
    """The context of robot ``config.robot_id`` on the site ``info`` describes: its type, its map (inflated
    by its radius), a navigator limited to its type and to physics' command latency (localised from
    ``start_xy_yaw``, else its start pose, with the robot's own seeded random stream) and its reach."""
    robot_id = config.robot_id
    description = info.robot_types[info.robot_type_of[robot_id]]
    map_config = replace(map_config, robot_radius_m=description.radius_m, step_m=description.max_step_m)
    site_map = SiteMap(info.layout, manifest.components, map_config, in_place=manifest.in_place)
    home_xy_yaw = info.robot_starts_xy_yaw[info.robot_ids.index(robot_id)]
    nav_config = nav_config or NavigatorConfig()
    nav_config = replace(
        nav_config,
        dwa=controller_limits(nav_config.dwa, description, info),
        command_latency_s=info.command_latency_steps * info.control_period_s,
    )
    rng = np.random.default_rng(robot_stream(config.seed, robot_id))
    start = home_xy_yaw if start_xy_yaw is None else start_xy_yaw
    navigator = Navigator(site_map, start, nav_config, rng, robot_id=robot_id)
    approach_config = approach_config or ApproachConfig(
        reach_m=description.reach_m,
        body_clearance_m=map_config.inflation_m,
    )
    drivers: dict[str, tuple[float, tuple[float, float]]] = {}
    for other, (x, y, _) in zip(info.robot_ids, info.robot_starts_xy_yaw, strict=True):
        kind = info.robot_types.get(info.robot_type_of.get(other, ""))
        if other != robot_id and kind is not None and kind.can(Capability.DRIVE):
            drivers[other] = (kind.radius_m + map_config.inflation_margin_m, (float(x), float(y)))
    context = RobotContext(config, description, site_map, navigator, home_xy_yaw, approach_config)
    context.drivers = drivers
    return context


class GettingThere(Protocol):
    """How a robot gets to where it works on a component: a ground robot drives to a stand-point beside it
    (:class:`.driving.Driving`), a crane checks that its hook reaches (:class:`.crane_work.CraneReach`).
    A task that cannot get there is given back through :class:`.handover.Handover` with the reason."""

    def target_cut_off(self, task: Task) -> Reason | None:
        """Why the task's target cannot be got to, checked before the pick-up; None when it can."""
        ...

    def approach(self, task: Task, footprint: Footprint) -> bool:
        """Set off for ``footprint`` (choose where to stand); False when not now (waits, or gave it back)."""
        ...

    def drive(self, task: Task, footprint: Footprint | None) -> bool:
        """One step of getting to ``footprint``; True once there."""
        ...
