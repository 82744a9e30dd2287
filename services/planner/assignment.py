"""Who gets a released task: the capable robot that would finish it first (a bid), or a hand-off (pure).

Why apart from :mod:`.scheduler`: the scheduler decides *when* a task is assigned; this decides *to whom*.
For each released component, in plan priority order, every alive robot whose type can build it where it
lies (:mod:`.capability`) bids its estimated finish: when it will be free (now if idle; its current
task's estimate, growing once overrun, if busy; plus what this round already promised it) plus the task's
own estimate. The lowest bid wins. An idle winner gets the task now; a busy winner is promised it (its
bid time grows by the estimate for the next components of this round) and nothing is assigned, so a
slow idle robot does not take what a fast busy one would finish sooner.

When no robot can build the component where it lies but a tower crane can place it and its staging area
is in reach, the same auction runs among ground robots that can carry it to a free staging spot: a
**hand-off** task (``TaskKind.HAND_OFF``). A component a ground robot gave back because it could not get
to its target goes to a crane first (lifted where it lies, or handed off), and only then to a ground robot.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass

from bimbot.shared.manifest import Component
from bimbot.shared.messages import RobotState, TaskKind
from bimbot.shared.robot_description import Capability
from bimbot.shared.site_cranes import staging_spots
from bimbot.shared.site_layout import INFLATION_MARGIN_M

from .capability import (
    SiteRobot,
    Where,
    can_build_from,
    can_carry,
    can_place,
    staging_reached,
    target_centre_xy,
    task_estimate_s,
)
from .records import RobotRecord

SPOT_CLEARANCE_M = 2.5  # a staging spot is taken while a component lies (or is on its way) this close


@dataclass(frozen=True)
class StagedLoad:
    """A load lying at a staging spot or on its way there: where (world xy, m) and half its plan diagonal
    lying flat (m)."""

    xy_m: tuple[float, float]
    half_m: float


def lying_half_m(component: Component) -> float:
    """Half the plan diagonal of ``component`` put down flat (its two largest extents lie horizontal)."""
    low, high = component.bbox_local.min_m, component.bbox_local.max_m
    extents = sorted(h - lo for lo, h in zip(low, high, strict=True))
    return 0.5 * math.hypot(extents[1], extents[2])


def spot_is_free(
    spot_xy_m: tuple[float, float], half_m: float, taken: Iterable[StagedLoad], lane_m: float
) -> bool:
    """Whether a load of ``half_m`` (:func:`lying_half_m`) put down at ``spot_xy_m`` keeps a ``lane_m`` lane
    from every load in ``taken`` (and at least :data:`SPOT_CLEARANCE_M` from each)."""
    return all(
        math.dist(spot_xy_m, load.xy_m) >= max(SPOT_CLEARANCE_M, load.half_m + half_m + lane_m)
        for load in taken
    )


def aisle_m(site: Mapping[str, SiteRobot]) -> float:
    """The lane the widest driving robot needs between two loads: its inflated diameter, as it plans."""
    widths = [
        2.0 * (robot.description.radius_m + INFLATION_MARGIN_M)
        for robot in site.values()
        if robot.description.can(Capability.DRIVE)
    ]
    return max(widths, default=0.0)


@dataclass(frozen=True)
class Choice:
    robot_id: str
    kind: TaskKind
    estimate_s: float  # the task's own duration estimate (sim s)
    put_down_xy_m: tuple[float, float] | None = None  # hand-off: the staging spot
    idle: bool = True  # False: the winner is busy, the task waits for it


def ready_s(robot: RobotRecord, now_s: float) -> float:
    """When ``robot`` will be free: now when idle; its estimate when busy, growing once overrun, and not
    before the end of timed work it says it is busy with (``RobotStateMsg.busy_until_s``)."""
    if robot.task_guid is None and robot.state is RobotState.IDLE:
        return now_s
    said_s = robot.reported_busy_until_s if robot.state is RobotState.WORK_IN_PLACE else None
    overrun_s = max(0.0, now_s - robot.busy_until_s)
    estimate_s = max(robot.busy_until_s, now_s) + overrun_s
    return max(estimate_s, said_s) if said_s is not None else estimate_s


def choose(
    component: Component,
    where: Where,
    records: Iterable[RobotRecord],
    site: Mapping[str, SiteRobot],
    *,
    now_s: float,
    promised_s: Mapping[str, float],
    avoid: set[str],
    taken_spots: list[StagedLoad],
    able_to_build: Callable[[SiteRobot, Component, Where], bool] = can_build_from,
    crane_first: bool = False,
) -> Choice | None:
    """The winning bid for ``component`` lying at ``where`` (None: no alive robot can take it now).
    ``promised_s``: extra busy time promised to robots earlier in this round; ``avoid``: robots that gave
    the task back (bidding only when nobody else can); ``able_to_build``: :func:`can_build_from`, or a
    memo of it (what a robot can build does not change while the component lies where it lies);
    ``crane_first``: a ground robot could not get to its target (given back ``unreachable`` or with no
    stand-point): a crane sets it if one can, lifting it where it lies or from a hand-off, before a ground
    robot tries again, as a site lifts what cannot be driven to."""
    alive = [record for record in records if record.alive and record.robot_id in site]
    fresh = [record for record in alive if record.robot_id not in avoid]

    def bids(
        kind: TaskKind, spot: tuple[float, float] | None, pool: list[RobotRecord]
    ) -> list[tuple[float, str, Choice]]:
        able = able_to_build if kind is TaskKind.BUILD else lambda robot, item, _where: can_carry(robot, item)
        return [
            _bid(record, site[record.robot_id], component, where, now_s, promised_s, kind, spot)
            for record in pool
            if able(site[record.robot_id], component, where)
        ]

    # a robot that gave the task back bids again only when no other robot *can* take it (not: when no
    # other is alive — on the hub a trapped carrier's give-back left a beam only carriers lift "waiting
    # for a robot" beside an idle Husky and crane until the run stalled)
    def by_crane(pool: list[RobotRecord]) -> list[RobotRecord]:
        return [record for record in pool if site[record.robot_id].lifts_by_hook]

    for pool in (fresh, alive) if len(fresh) < len(alive) else (alive,):
        found = bids(TaskKind.BUILD, None, by_crane(pool) if crane_first else pool)
        if not found:
            spot = _hand_off_spot(component, pool, site, taken_spots)
            found = bids(TaskKind.HAND_OFF, spot, pool) if spot is not None else []
        if not found and crane_first:
            found = bids(TaskKind.BUILD, None, pool)
        if found:
            return min(found, key=lambda bid: (bid[0], bid[1]))[2]
    return None


def _bid(  # noqa: PLR0917 - one bid's inputs, named at the single call
    record: RobotRecord,
    robot: SiteRobot,
    component: Component,
    where: Where,
    now_s: float,
    promised_s: Mapping[str, float],
    kind: TaskKind,
    spot: tuple[float, float] | None,
) -> tuple[float, str, Choice]:
    xy = record.pose_xy_yaw[:2] if record.pose_xy_yaw is not None else robot.home_xy_yaw[:2]
    estimate = task_estimate_s(robot, xy, component, where, spot)
    idle = record.task_guid is None and record.state is RobotState.IDLE
    start = ready_s(record, now_s) + promised_s.get(record.robot_id, 0.0)
    choice = Choice(record.robot_id, kind, estimate, spot, idle and record.robot_id not in promised_s)
    return start + estimate, record.robot_id, choice


def _hand_off_spot(
    component: Component,
    records: list[RobotRecord],
    site: Mapping[str, SiteRobot],
    taken: list[StagedLoad],
) -> tuple[float, float] | None:
    """A free staging spot of an alive crane that can place ``component`` (the nearest crane to its
    target first), or None. Free: every load lying there or on its way keeps a driving robot's lane from
    it (:func:`aisle_m`). Four ceiling panels 2.4 m long on the spots 4 m apart of the Janesville
    restaurant's staging area closed its middle round the carrier that had set the last one down: it was
    walled in there, again and again, with three carriers."""
    half_m, lane_m = lying_half_m(component), aisle_m(site)
    target = target_centre_xy(component)
    cranes = [
        site[record.robot_id]
        for record in records
        if site[record.robot_id].description.can(Capability.HOOK_LIFT)
        and can_place(site[record.robot_id], component)
        and staging_reached(site[record.robot_id], component)
    ]
    cranes.sort(key=lambda crane: math.dist(crane.home_xy_yaw[:2], target))
    for crane in cranes:
        assert crane.staging is not None
        for spot in staging_spots(crane.staging):
            if spot_is_free(spot, half_m, taken, lane_m):
                return spot
    return None


def staged_where(component: Component, xy_m: tuple[float, float]) -> Where:
    """A component lying at ``xy_m`` (put down flat: its top low)."""
    return Where(xy_m, 0.5)
