"""Which robot on site can build a component, from where, and at what cost: the fleet's capabilities (pure).

Why: the planner gives a task only to a robot that can carry and place its component, and among those to
the one that would finish it first (a bid). The rules are the robot description's
(:mod:`bimbot.shared.robot_description`: payload, placement height, reach; for a tower crane its load chart
and where it stands); this module applies them to a component where it lies now and where it goes.

* a **ground** robot builds a component when its type's payload and placement height allow it (it drives
  to both ends);
* a **tower crane** builds it when its hook reaches both where the component lies and its target with the
  component's mass (load chart), and its jib is high enough;
* otherwise, when a crane reaches the target but not where the component lies, a ground robot that can
  carry the mass **hands it off**: it carries it to the crane's staging area (a task of its own), and the
  crane builds it from there;
* a component cast in place or laid is built where it stands, only by a machine that can ``pour`` or
  ``lay`` within its boom's reach (:mod:`.work_in_place`): never carried, never handed off, its mass moot;
  a machine that only pours or lays never gets a part to carry.

A component where it lies is its centre (the planner follows positions, not orientations); a crane's hook
radius is the distance to that centre. Its target is its posed footprint.
Bids (:func:`task_estimate_s`) are sim seconds: driving at the type's speed along ``DETOUR`` times the
straight line, a crane's slew/trolley/hoist motion, the type's handling time to grip and to release, and
for a component set at its target the time its robot holds it there until its connections are made and its
temporary supports set (:func:`bimbot.shared.connection_hold.expected_hold_s`, physics' rule); for work in
place, the work itself (formwork + pour, or the blocks at the machine's rate), its handling
time to set up and to clear, and the drive of a machine that drives.
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Sequence
from dataclasses import dataclass

from bimbot.shared.connection_hold import expected_hold_s
from bimbot.shared.idle_machines import lifts_parts
from bimbot.shared.manifest import Component
from bimbot.shared.messages import SiteInfoMsg
from bimbot.shared.robot_description import Capability, RobotDescription
from bimbot.shared.site_plan import Rect, SiteLayout, machine_setups

from .work_in_place import can_work_on, target_footprint, work_s, works_in_place

DETOUR = 1.5  # driven path / straight line on a site with a yard, aisles and lanes
GROUND_PLACE_S = 2.0  # a ground robot's assembly motion (the executor's place duration)
STAGING_SLACK_M = 2.0  # a load put down at a staging spot lies beside the robot, up to this far out


@dataclass(frozen=True)
class SiteRobot:
    """One robot on site: its id, its type, where it starts (a crane: where it stands), its staging area."""

    robot_id: str
    description: RobotDescription
    home_xy_yaw: tuple[float, float, float]
    staging: Rect | None = None
    # a machine that stands fixed: where it may set up (its start first; more for one that relocates)
    setups: tuple[tuple[float, float, float], ...] = ()

    @property
    def stands_fixed(self) -> bool:
        """It stands where the site plan put it (``home_xy_yaw``, or one of its ``setups`` when it
        relocates)."""
        return self.description.can(Capability.STAND_FIXED)

    @property
    def set_up_at(self) -> tuple[tuple[float, float, float], ...]:
        """Where it may stand to work: its set-ups (its start alone when the plan gives none)."""
        return self.setups or (self.home_xy_yaw,)

    @property
    def lifts_by_hook(self) -> bool:
        return self.description.can(Capability.HOOK_LIFT)


def site_robots(info: SiteInfoMsg) -> list[SiteRobot]:
    """The robots physics serves in ``info``, with their descriptions and starts."""
    descriptions = [info.robot_types[info.robot_type_of[robot_id]] for robot_id in info.robot_ids]
    return robots_on_plan(info.robot_ids, descriptions, info.layout)


def robots_on_plan(
    robot_ids: Sequence[str], descriptions: Sequence[RobotDescription], layout: SiteLayout
) -> list[SiteRobot]:
    """The robots where the site plan puts them; cranes get their staging areas in robot id order."""
    robots: list[SiteRobot] = []
    staging = list(layout.staging)
    machine = 0
    for robot_id, description, start in zip(robot_ids, descriptions, layout.robot_starts, strict=True):
        area = staging.pop(0) if description.can(Capability.HOOK_LIFT) and staging else None
        home = (float(start[0]), float(start[1]), float(start[2]))
        setups: tuple[tuple[float, float, float], ...] = ()
        if description.can(Capability.STAND_FIXED):
            setups = machine_setups(layout, machine, home)
            machine += 1
        robots.append(SiteRobot(robot_id, description, home, area, setups))
    return robots


@dataclass(frozen=True)
class Where:
    """A component where it lies: its centre (x, y) and the z of its top."""

    xy_m: tuple[float, float]
    top_z_m: float


def target_centre_xy(component: Component) -> tuple[float, float]:
    """Where the component's body is at its target (the centre of its BIM box), which is not its
    placement's origin: a Revit member may have that at the project origin, 100 m from its body."""
    low, high = component.bbox_world.min_m, component.bbox_world.max_m
    return ((low[0] + high[0]) / 2.0, (low[1] + high[1]) / 2.0)


def crane_reaches_centre(crane: SiteRobot, where: Where, mass_kg: float) -> bool:
    """The hook reaches the centre of a component lying at ``where`` with ``mass_kg`` (its hook radius
    between the trolley's innermost radius and the chart's radius for that mass)."""
    spec = crane.description.crane
    assert spec is not None
    hook_m = math.hypot(where.xy_m[0] - crane.home_xy_yaw[0], where.xy_m[1] - crane.home_xy_yaw[1])
    return spec.min_radius_m - 1e-9 <= hook_m <= spec.radius_for(mass_kg) + 1e-9


def crane_reaches_target(crane: SiteRobot, component: Component) -> bool:
    polygon = target_footprint(component).polygon_xy_m
    return crane.description.reaches(crane.home_xy_yaw[:2], polygon, component.mass_kg)


def target_hook_radius_m(crane: SiteRobot, component: Component) -> float:
    """The crane's hook radius over the component at its target: what :func:`crane_reaches_target` holds
    against the load chart (the centre of its footprint, not its placement's origin, which a Revit member
    may have at the project origin, 100 m away)."""
    return crane.description.hook_radius_m(crane.home_xy_yaw[:2], target_footprint(component).polygon_xy_m)


def can_place(robot: SiteRobot, component: Component) -> bool:
    """Payload and placement height allow it, and a crane's hook reaches the target with its mass; for work
    in place: the robot can do the work and its boom covers the target (:mod:`.work_in_place`)."""
    if works_in_place(component):
        return any(can_work_on(robot.description, pose[:2], component) for pose in robot.set_up_at)
    if not lifts_parts(robot.description):
        return False
    top_z_m = component.bbox_world.max_m[2]
    if robot.description.refusal(component.mass_kg, top_z_m) is not None:
        return False
    return not robot.lifts_by_hook or crane_reaches_target(robot, component)


def can_build_from(robot: SiteRobot, component: Component, where: Where) -> bool:
    """``robot`` can pick ``component`` up where it lies and place it (or, for work in place, build it)."""
    if not can_place(robot, component):
        return False
    if works_in_place(component):
        return True
    return not robot.lifts_by_hook or crane_reaches_centre(robot, where, component.mass_kg)


def can_carry(robot: SiteRobot, component: Component) -> bool:
    """A robot that can carry the component to a crane's staging area (its placement height is moot); a
    component built in place is never carried."""
    return (
        not works_in_place(component)
        and robot.description.can(Capability.HAND_OFF)
        and component.mass_kg <= robot.description.payload_kg
    )


def staging_reached(crane: SiteRobot, component: Component) -> bool:
    """The crane's hook reaches a component put down anywhere in its staging area (or a little beyond:
    a load is put down beside the robot that carried it)."""
    area = crane.staging
    if area is None:
        return False
    grown = area.grown(STAGING_SLACK_M)
    corners = [(x, y) for x in (grown.min_xy[0], grown.max_xy[0]) for y in (grown.min_xy[1], grown.max_xy[1])]
    return all(crane_reaches_centre(crane, Where(corner, 0.0), component.mass_kg) for corner in corners)


_HOLDS: dict[int, float] = {}  # id of a component object → its expected hold, while the object lives


def _expected_hold_s(component: Component) -> float:
    """:func:`~bimbot.shared.connection_hold.expected_hold_s`, remembered per component object: it reads
    only the manifest's entry, and every assignment pass asks it of each released task for every robot
    (on a 988-component site a tenth of the planner's time). An entry goes with its object, so an id is
    never taken for another object's."""
    key = id(component)
    hold_s = _HOLDS.get(key)
    if hold_s is None:
        hold_s = _HOLDS[key] = expected_hold_s(component)
        weakref.finalize(component, _HOLDS.pop, key, None)
    return hold_s


def task_estimate_s(
    robot: SiteRobot,
    robot_xy_m: Sequence[float],
    component: Component,
    where: Where,
    to_xy_m: Sequence[float] | None = None,
) -> float:
    """Sim seconds for ``robot`` (at ``robot_xy_m``) to pick ``component`` up where it lies and place it
    at its target, holding it there until it is connected, or put it down at ``to_xy_m`` (a hand-off); for
    work in place, to go there (a machine that drives), set up, do the work and clear."""
    description = robot.description
    target = target_centre_xy(component)
    handling_s = 2.0 * description.handling_s
    if works_in_place(component):
        drive_s = 0.0
        if description.can(Capability.DRIVE):
            drive_s = DETOUR * math.dist(robot_xy_m[:2], target) / description.max_speed_mps
        elif description.relocates:
            drive_s = relocation_to_s(robot, robot_xy_m, component)
        return drive_s + handling_s + work_s(component, description)
    # set at its target, it is held until its connections are made (and its temporary supports set)
    hold_s = _expected_hold_s(component) if to_xy_m is None else 0.0
    if robot.lifts_by_hook and description.crane is not None:
        start = (*where.xy_m, where.top_z_m)
        end = (target[0], target[1], component.bbox_world.max_m[2])
        return description.crane.motion_s(robot.home_xy_yaw[:2], start, end) + handling_s + hold_s
    goal = to_xy_m if to_xy_m is not None else target
    drive_m = math.dist(robot_xy_m[:2], where.xy_m) + math.dist(where.xy_m, goal[:2])
    place_s = 0.0 if to_xy_m is not None else GROUND_PLACE_S
    return DETOUR * drive_m / description.max_speed_mps + handling_s + place_s + hold_s


def setup_for(
    robot: SiteRobot, robot_xy_m: Sequence[float], component: Component
) -> tuple[float, float, float] | None:
    """Where a machine that stands fixed (now at ``robot_xy_m``) works on ``component`` from: where it
    stands when that covers it, else the set-up that covers it nearest to it (the shortest relocation);
    None when none covers it (the rule of
    :meth:`~bimbot.shared.robot_description.RobotDescription.setup_for`, which the machine itself follows)."""
    polygon = target_footprint(component).polygon_xy_m
    return robot.description.setup_for(robot.set_up_at, robot_xy_m, polygon)


def relocation_to_s(robot: SiteRobot, robot_xy_m: Sequence[float], component: Component) -> float:
    """Sim seconds a machine at ``robot_xy_m`` spends relocating before it can work on ``component`` (0
    when its boom covers it from there, or when no set-up does: feasibility says so)."""
    pose = setup_for(robot, robot_xy_m, component)
    return 0.0 if pose is None else robot.description.relocation_s(robot_xy_m[:2], pose[:2])
