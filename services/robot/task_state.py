"""What one task of the robot carries along, and the executor's bounds (data, and how a task is named).

Why apart from :mod:`.executor`: the executor and its parts (:mod:`.driving`, :mod:`.handover`,
:mod:`.crane_work`) share them. Every wait of a task is bounded in sim time and every retry counted here
(see the executor's module doc).
"""

from __future__ import annotations

import math
import uuid
from dataclasses import dataclass, field

import numpy as np

from bimbot.shared.footprint import Footprint
from bimbot.shared.manifest import Component
from bimbot.shared.messages import ComponentEvent, ComponentEventMsg, ComponentState, TaskKind, TaskMsg
from bimbot.shared.reasons import Reason
from bimbot.shared.site_plan import SiteLayout

from .approach import Approach
from .protocol import EventQueue, PhysicsRequest


@dataclass(frozen=True)
class ExecutorConfig:
    robot_id: str
    resend_s: float = 0.5  # wall seconds between repeats of an unconfirmed event
    # wall seconds an event goes unconfirmed before the component's twin is asked (its confirmation may have
    # been lost); an agent confirms within a control period or two
    confirm_ask_s: float = 10.0
    state_period_s: float = 1.0  # wall seconds between periodic state messages
    request_timeout_s: float = 60.0  # wall seconds for a physics reply (the adapter reports a timeout)
    place_duration_s: float = 2.0  # sim seconds of the assembly motion
    max_tries: int = 4  # approaches (navigation failed, attach/place refused) before a task is given back
    max_reselections: int = 20  # approach poses chosen again at once when their cell becomes occupied
    max_approach_misses: int = 10  # searches for an approach pose that found none, then given back
    traffic_wait_s: float = 120.0  # sim seconds to wait for a stand-point only laser marks cut off
    shut_in_wait_s: float = 900.0  # sim seconds to hold a placement that would shut a robot in (planner's)
    shut_in_recheck_s: float = 5.0  # …asking again this often (a flood fill of the site per robot)
    retry_delay_s: float = 1.0  # sim seconds before looking for an approach again
    task_timeout_s: float = 900.0  # sim seconds in one task state → given back (no_progress)
    give_back_timeout_s: float = 60.0  # sim seconds for the agent to confirm an abandon (else go idle)
    carried_wait_s: float = 10.0  # sim seconds a component on another robot may take to be put down
    park_after_s: float = 8.0  # sim seconds idle → drive back to the start pose (clears the structure)
    park_retry_s: float = (
        120.0  # a parking drive that failed (its recoveries spent) is tried again after this
    )
    leave_margin_m: float = 1.0  # after a task: out of the building footprint grown by this much
    placement_error_m: float = 0.0  # injected on first placement attempts (tests, demos)
    inject_guids: frozenset[str] = frozenset()
    inject_fraction: float = 0.0  # without inject_guids: this share of components (0: all)
    seed: int = 0


@dataclass
class Task:
    message: TaskMsg
    component: Component
    target: Footprint  # the footprint at the BIM target pose
    events: EventQueue
    request: PhysicsRequest | None = None
    request_sent: bool = False
    tries: int = 0
    localisation_off_m: float = 0.0  # the most physics found the robot's belief off by (refused requests)
    reselections: int = 0  # approach poses chosen again because their cell became occupied
    retry_at_s: float = -math.inf
    approach: Approach | None = None
    failed_xy_m: list[tuple[float, float]] = field(default_factory=list)  # stand-points that failed
    misses: int = 0  # approach searches that found nothing
    traffic_since_s: float | None = None  # since when only laser marks cut every stand-point off
    shut_in_since_s: float | None = None  # since when placing it would shut another robot in
    shut_in_robots: list[str] = field(default_factory=list)  # the robots placing it would shut in, last asked
    waiting_since_s: float | None = None  # since when physics says another robot stands where it goes
    placed: bool = False
    placement_note: str = ""  # said with the place event: how the robot placed it when it matters
    verdict: ComponentState | None = None
    abandoning: bool = False
    abandon_at_s: float = math.inf
    dropping: Reason | None = None  # putting the load down before giving the task back with this reason
    withdrawn: bool = False  # the planner took it back: after the drop just go idle
    drop_tries: int = 0
    carried_seen_s: float | None = None  # sim time it was first seen on another robot
    handed_off: bool = False  # a hand-off task: physics put the load down at the staging spot


def component_name(task: Task) -> str:
    """The task's component as a user knows it: ``Column R1 (2O2Fr$t4X7Zf8NOew3FLOH)``."""
    name = task.component.name
    return f"{name} ({task.message.guid})" if name else task.message.guid


PUT_DOWN_SIDE_M = 1.0  # the square a hand-off drives to (its centre: the staging spot)


def put_down_footprint(xy_m: tuple[float, float]) -> Footprint:
    """The target of a hand-off task: a small square on the ground at the staging spot."""
    half = PUT_DOWN_SIDE_M / 2.0
    x, y = xy_m
    polygon = np.array(
        [[x - half, y - half], [x + half, y - half], [x + half, y + half], [x - half, y + half]]
    )
    return Footprint(polygon, 0.0, 0.5)


def put_down_target(layout: SiteLayout, message: TaskMsg) -> Footprint:
    """Where a task that puts its load down drives to: a clear-away's yard slot (the component's own, as
    at its pick-up from the yard), else the square at its put-down spot."""
    assert message.put_down_xy_m is not None
    slot = layout.slots.get(message.guid)
    if message.kind is TaskKind.CLEAR and slot is not None:
        area = slot.footprint
        (x0, y0), (x1, y1) = area.min_xy, area.max_xy
        polygon = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=float)
        return Footprint(polygon, 0.0, slot.height_m)
    return put_down_footprint(message.put_down_xy_m)


def task_event(
    message: TaskMsg,
    event: ComponentEvent,
    robot_id: str,
    *,
    sim_s: float,
    wall_s: float,
    reason: Reason | None = None,
    note: str = "",
) -> ComponentEventMsg:
    """``event`` on the component of the task ``message``, by ``robot_id``, with a fresh ``event_id`` (a
    resend keeps it: the agents take the first copy that comes)."""
    return ComponentEventMsg(
        guid=message.guid,
        event=event,
        source=robot_id,
        event_id=uuid.uuid4().hex,
        task_id=message.task_id,
        robot_id=robot_id,
        sim_time_s=sim_s,
        wall_time_s=wall_s,
        reason=reason,
        note=note,
    )
