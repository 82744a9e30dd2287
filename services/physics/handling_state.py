"""What the parts of the handling share: every component's phase and pose, the site's facts and records.

Why one object passed to each part: carrying (:mod:`.transport`), placing (:mod:`.placing`), the release
into dynamics (:mod:`.releasing`) and the watch over what was released (:mod:`.watching`) read and change
the same items and records. Each part receives this object when it is built, instead of declaring the
attributes of a common host class. It makes no decision; it answers the small questions several parts
ask: may a robot handle a component at all, may it carry it from where it stands, does a component's box
overlap a robot's.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum

from bimbot.shared.manifest import Component
from bimbot.shared.messages import PoseMsg
from bimbot.shared.site_plan import Rect
from bimbot.shared.work_methods import BUILT_IN_PLACE

from .client import p
from .connections import ConnectionConfig
from .load_rules import carry_refusal
from .pits import Pits
from .release import SettleConfig, Watch
from .robots import Robot
from .scene import ComponentBody, Frame, Quat
from .temporary_supports import SupportRecord


class Phase(StrEnum):
    UNBUILT = "unbuilt"  # cast in place or laid, not built yet: out of sight (:mod:`.in_place_work`)
    RESTING = "resting"
    CARRIED = "carried"
    ASSEMBLING = "assembling"
    SETTLING = "settling"
    PLACED = "placed"
    JOINED = "joined"


DYNAMIC_PHASES = (Phase.SETTLING, Phase.PLACED)


@dataclass(frozen=True)
class HandlingConfig:
    lift_s: float = 1.0
    hook_lift_m: float = 1.0  # a crane lifts its load this far above where it lay
    carry_clearance_m: float = 0.02
    max_place_duration_s: float = 900.0  # a tower crane's lift across the site takes minutes


@dataclass
class Item:
    """One component's handling state; ``pose`` is its component frame in the world."""

    component: Component
    body: ComponentBody
    phase: Phase
    pose: Frame
    carrier: str | None = None
    offset: Frame | None = None  # carried: component frame in the carrier's base frame
    motion_from: Frame | None = None
    motion_to: Frame | None = None  # assembling: where the placement really puts it
    meant_quat_xyzw: Quat | None = None  # assembling: the orientation the robot meant (its target's)
    motion_start_s: float = 0.0
    motion_duration_s: float = 0.0
    tag: object = None  # assembling: handed back with the reply
    separating_from: Robot | None = None  # placed, still overlapping its former carrier
    dropped_by: str | None = None  # resting where this robot put it down (a repeated drop request is ok)
    drift_m: float | None = None  # joined: how far it had moved since its release
    supports: tuple[str, ...] = ()  # placed or joined: the components it rests on
    connected_to: tuple[str, ...] = ()  # joined: the components it was connected to as it was set down
    # placed or joined by a robot: its target fitted to the structure as built (.support_fit; None: its
    # BIM target); its placement is judged there
    fitted_target: Frame | None = None


@dataclass
class HandlingState:
    """The items and the records the handling's parts share (see the module doc)."""

    client_id: int
    items: dict[str, Item]  # GUID → its handling state
    config: HandlingConfig
    site_bounds: Rect
    ground_id: int
    pits: Pits | None
    settle: SettleConfig
    connections: ConnectionConfig
    in_place: dict[int, str]  # body → GUID of the components in place from the start
    joints: dict[str, frozenset[str]]  # GUID → the GUIDs it is jointed with (.joints): never a clash
    guid_of: dict[int, str]  # body → GUID of every item
    # GUID → {GUID it is framed to at an end: how deep they may overlap at release, m} (.joints.framed_ends)
    framed: dict[str, dict[str, float]] = field(default_factory=dict)
    carrying: dict[str, str] = field(default_factory=dict)  # robot id → GUID (carried or assembling)
    changed: set[str] = field(default_factory=set)  # GUIDs whose pose changed since the last take_changed()
    constructed: set[str] = field(
        default_factory=set
    )  # declared constructed by their agents: joined for good
    moving: set[str] = field(default_factory=set)  # carried or assembling: moved after every physics step
    separating: set[str] = field(default_factory=set)  # placed, still overlapping their former carrier
    watch: dict[str, Watch] = field(default_factory=dict)  # settling and placed components
    # connections made and temporary supports (.temporary_supports)
    supports: SupportRecord = field(default_factory=SupportRecord)

    def cannot_carry(
        self, robot: Robot, component: Component, frame: Frame, what: str
    ) -> tuple[str | None, float | None]:
        """:func:`.load_rules.carry_refusal` for ``robot`` where it stands now."""
        (x, y, _), _ = robot.frame(self.client_id)
        return carry_refusal(robot.description, robot.robot_id, (x, y), component, frame, what=what)

    def overlaps(self, item: Item, robot: Robot) -> bool:
        """Whether ``item``'s box overlaps the box of any of ``robot``'s links."""
        low, high = p.getAABB(item.body.body_id, -1, physicsClientId=self.client_id)
        for link in range(-1, p.getNumJoints(robot.body_id, physicsClientId=self.client_id)):
            r_low, r_high = p.getAABB(robot.body_id, link, physicsClientId=self.client_id)
            if all(low[i] < r_high[i] and r_low[i] < high[i] for i in range(3)):
                return True
        return False


def handling_refusal(
    robot: Robot | None, guid: str, item: Item | None, *, fixed_ok: bool = False
) -> str | None:
    """Why ``robot`` may not handle ``guid`` at all (None: it may): unknown, joined, built where it stands,
    or placed (unless ``fixed_ok``: taken up again for its retry)."""
    if robot is None:
        return "unknown robot"
    if item is None:
        return f"unknown component {guid}"
    if item.phase is Phase.JOINED:
        return f"{guid} is constructed (joined to the structure)"
    if item.phase is Phase.UNBUILT or item.component.method in BUILT_IN_PLACE:
        return f"{guid} is {item.component.method.value}: it is built where it stands, never carried"
    if item.phase in DYNAMIC_PHASES and not fixed_ok:
        return f"{guid} is placed"
    return None


def target_frame(component: Component) -> Frame:
    """The component frame at its BIM target pose."""
    target = component.target_pose_world
    position, quat = target.position_m, target.quat_xyzw
    return ((position[0], position[1], position[2]), (quat[0], quat[1], quat[2], quat[3]))


def pose_msg(frame: Frame) -> PoseMsg:
    return PoseMsg(position_m=frame[0], quat_xyzw=frame[1])
