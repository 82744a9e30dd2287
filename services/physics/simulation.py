"""The physics core: owns a DIRECT pybullet client, builds the site and advances it one control period at a
time. No bus: requests come in as message objects, outgoing messages go out as ``(key, message)`` pairs.

Scene (from the converter's build and :func:`bimbot.shared.site_layout.plan_site`, like the paper's Fig.
10): the ground plane, the fence, every component static in its yard slot (its body built from its
``model.sdf``, :mod:`.scene`), and the fleet's robots (ids ``r1``…, each from its own type's URDF,
:mod:`.fleet_spawn`): ground robots at the depot, tower cranes beside the building.

Clock: physics steps of ``step_s`` (1/240 s); a control period of ``control_period_s`` (0.1 s) is a whole
number of them. :meth:`Simulation.advance` applies the latest commands, steps one period (moving carried
and assembling components after every step, :mod:`.handling`), then measures: ``ClockMsg.step`` counts
control periods, and the messages of a period are stamped with the sim time at its end.

Per period the outgoing messages are: the clock; per robot its odometry (noisy, :class:`.odometry.Odometry`,
seeded per robot from ``seed``; a crane's is its fixed pose), its laser scan (:mod:`.sensors`; none for a
crane), both keyed on the robot's ``sensors`` key (the adapter sends them, with the clock, as one
:class:`~bimbot.shared.messages.SensorsMsg`, :mod:`.outbox`), and its ground-truth pose (a crane's with its
joint values); the pose of every component that moved (carried, assembling, just placed or dropped); and a
slice of the others, so that every component's pose is repeated once per ``pose_refresh_s`` of *wall* time
for late subscribers (the sim time it spans follows the real-time factor: a message missed is a wall-clock
matter), but at most ``pose_refresh_max`` a period: on a site of a thousand components the repeats were 80
messages a period that every subscriber decoded, and at ×20 real time a 2 s cycle in sim time repeated
every pose ten times a wall second, for a safety net (who starts late asks ``physics/poses``).
:meth:`Simulation.start_messages` gives all of that for step 0 (every component included).
Same build, config, seed and command sequence → the same trajectories (pybullet is deterministic for an
identical call sequence on a fresh client).
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from types import TracebackType

import numpy as np
from pydantic import BaseModel

from bimbot.shared.crane_erection import erected_for, erection_words
from bimbot.shared.fleet import Fleet
from bimbot.shared.footprint import posed_footprint
from bimbot.shared.identifiers import guid_to_key
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import (
    CLOCK_KEY,
    COMPONENT_POSE_KEY,
    ROBOT_POSE_KEY,
    ROBOT_SENSORS_KEY,
    AttachRequest,
    BuildRequest,
    ClockMsg,
    CmdVelMsg,
    DropRequest,
    OdomMsg,
    PhysicsReply,
    PlaceRequest,
    ScanMsg,
    SetUpRequest,
    SiteInfoMsg,
    SitePosesMsg,
    SkipRequest,
    key,
)
from bimbot.shared.site_layout import plan_site
from bimbot.shared.site_plan import SiteLayout
from bimbot.shared.verification import Tolerances

from .client import BulletClient, p
from .connections import ConnectionConfig
from .crane import HOIST, SLEW, TROLLEY, CraneJoints
from .fleet_spawn import robot_pose_msg, robot_types, spawn_fleet, types_on_site
from .handling import Handling
from .handling_state import HandlingConfig, Item, Phase
from .in_place_work import BUILT_IN_PLACE, InPlaceWork, hide
from .joints import framed_ends, joint_partners, let_joints_overlap, trimmed_boards
from .landing_zone import ASK_AGAIN_S, Bystander, LandingWaits, in_the_way
from .odometry import Odometry
from .pits import Pits, collision_part_boxes
from .placing import valid_frame
from .positioning import TotalStation
from .profiles import FINE, MAX_TOTAL_STATION_MM
from .ray_scene import RayScene
from .release import SettleConfig
from .relocation import is_setup, move_base, relocate, robot_setups
from .robots import Robot, RobotConfig
from .scene import (
    component_model,
    compose,
    create_component_body,
    create_fence,
    create_ground,
    yaw_quat,
)
from .sensors import Laser, LaserConfig

_log = logging.getLogger(__name__)

GRAVITY_MPS2 = 9.80665


LOCK_STEP_REFRESH_RTF = 10.0  # lock-step: pose repeats as at this real-time factor (a 20 s sim cycle)


@dataclass(frozen=True)
class SimConfig:
    """The simulation's settings. ``fleet``: the robots on site (each type's limits, URDF, reach and
    payload); without one, ``robots`` robots of ``DEFAULT_ROBOT`` (tests, benches)."""

    fleet: Fleet | None = None
    robots: int = 1  # without a fleet only
    step_s: float = 1.0 / FINE.physics_hz
    control_period_s: float = FINE.control_period_s
    odom_noise: float = 0.02  # relative standard deviation of each period's odometry increment
    seed: int = 0
    lock_step: bool = False  # reported in ClockMsg and SiteInfoMsg; the adapter does the waiting
    # lock-step: control periods between a robot's sensing and its command acting (the adapter applies
    # a command answering step k from step k + this; robots plan from where they will be then)
    command_latency_steps: int = FINE.command_latency_steps
    real_time_factor: float = FINE.rtf  # the pace asked for: reported until one is measured
    pose_refresh_s: float = 2.0  # wall seconds (see the module)
    pose_refresh_max: int = 5  # repeated poses per control period at most (a large site: a longer cycle)
    visuals: bool = False
    total_station_std_m: float | None = (
        None  # a positioning sensor fixing every ground robot (positioning.py)
    )
    robot: RobotConfig = field(default_factory=RobotConfig)
    laser: LaserConfig = field(default_factory=LaserConfig)
    compiled_laser: bool = True  # scans cast by the compiled caster (ray_scene.py); False: by Bullet
    handling: HandlingConfig = field(default_factory=HandlingConfig)
    settle: SettleConfig = field(default_factory=SettleConfig)
    connections: ConnectionConfig = field(default_factory=ConnectionConfig)
    # the placement tolerances in force: served in the site info, and a connection is made only where
    # the agents would accept the placement
    tolerances: Tolerances = field(default_factory=Tolerances)

    @property
    def substeps(self) -> int:
        return round(self.control_period_s / self.step_s)

    def validate(self) -> None:
        if self.robots < 0:
            raise ValueError("robots must be >= 0")
        if self.step_s <= 0.0 or self.control_period_s < self.step_s:
            raise ValueError("need 0 < step_s <= control_period_s")
        if abs(self.substeps * self.step_s - self.control_period_s) > 1e-9:
            raise ValueError(
                f"control period {self.control_period_s} s is not a whole number of {self.step_s} s steps"
            )
        if self.command_latency_steps not in (0, 1):
            raise ValueError("command latency must be 0 or 1 control period")
        top_m = MAX_TOTAL_STATION_MM / 1000.0
        if self.total_station_std_m is not None and not 0.0 < self.total_station_std_m <= top_m:
            raise ValueError(f"a total station's standard deviation must be within (0, {top_m:g}] m")
        if self.odom_noise < 0.0 or self.pose_refresh_s <= 0.0 or self.pose_refresh_max < 1:
            raise ValueError("odom noise must be >= 0, pose refresh > 0 and at least one pose a period")


@dataclass(frozen=True)
class Outgoing:
    key_expr: str
    message: BaseModel


@dataclass
class PeriodResult:
    messages: list[Outgoing]
    replies: list[tuple[object, PhysicsReply]]  # (tag given to place(), reply) of finished placements


class Simulation:
    """``with Simulation(manifest, build_dir, config) as sim:`` — the whole site in one pybullet client."""

    def __init__(
        self, manifest: Manifest, build_dir: Path, config: SimConfig | None = None, *, gui: bool = False
    ) -> None:
        self.manifest = manifest
        self.build_dir = Path(build_dir)
        self.config = _erected(config or SimConfig(), manifest)
        self.config.validate()
        self.site = manifest.site
        self.robot_types = robot_types(self.config.fleet, self.config.robots)  # one per robot, r1 first
        self.layout: SiteLayout = plan_site(manifest.components, fleet=self.robot_types)
        self._client = BulletClient(p.GUI if gui else None)
        self.step = 0
        self.skipped_s = (
            0.0  # sim time jumped over a quiet site (:meth:`skip`): sim time is not step × period
        )
        self.epoch = 0  # physics starts of this run - 1 (:mod:`.restore`)
        self.stepping_wall_s = 0.0  # wall seconds in pybullet's stepSimulation alone (a run's reference)
        self.steps_taken = 0
        self.scan_wall_s = 0.0  # wall seconds in the laser's scans (status line: their share of a period)
        self.scans_taken = 0
        self.robots: dict[str, Robot] = {}
        self._landing_waits = LandingWaits()  # loads waiting for a robot to move off where they go
        self.alive: set[str] = set()
        self._odometry: dict[str, Odometry] = {}
        self.in_place_bodies: dict[str, int] = {}  # GUID → body of a component in place from the start
        self._laser = Laser(self.config.laser)
        self._ray_scene: RayScene | None = None  # the laser's compiled caster (built with the scene)
        std = self.config.total_station_std_m
        self._station = TotalStation(std, self.config.seed) if std is not None else None
        if std is not None:
            _log.info(
                "a total station on site: every ground robot gets a fix each period (%.1f mm)", std * 1e3
            )
        self._beam_starts: dict[str, np.ndarray] = {}
        self._unknown_logged: set[str] = set()
        self._refresh_cursor = 0
        self._refresh_credit = 0.0  # repeated poses due, a fraction carried to the next period
        self._late_replies: list[tuple[object, PhysicsReply]] = []
        self.skips = 0  # clock jumps over a quiet site
        self.handling: Handling
        self.in_place_work: InPlaceWork

    # --- lifecycle -----------------------------------------------------------------------------------

    def __enter__(self) -> Simulation:
        self._client.__enter__()
        try:
            self._build()
        except BaseException:
            self._client.close()
            raise
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, traceback: TracebackType | None
    ) -> None:
        self._client.close()

    @property
    def client_id(self) -> int:
        return self._client.id

    def _build(self) -> None:
        cid = self.client_id
        p.setGravity(0.0, 0.0, -GRAVITY_MPS2, physicsClientId=cid)
        p.setPhysicsEngineParameter(
            fixedTimeStep=self.config.step_s, deterministicOverlappingPairs=1, physicsClientId=cid
        )
        self.ground_id = create_ground(cid)
        self.fence_ids = create_fence(cid, self.layout.fence)
        items: dict[str, Item] = {}
        for component in self.manifest.components:
            slot = self.layout.slots.get(component.guid)
            target = component.target_pose_world
            frame = (slot.position_m, slot.quat_xyzw) if slot else (target.position_m, target.quat_xyzw)
            model = component_model(component, self.build_dir)
            body = create_component_body(cid, component, model, frame, visual=self.config.visuals)
            # static until released: its groups keep it off the ground, and the release says whether the
            # ground carries it (.releasing). A ground pair filter per body here cost 2 ms a body on a
            # 5,743-component site (pybullet's pair filters grow with the bodies): 15 s of physics' start.
            items[component.guid] = Item(component, body, Phase.RESTING, frame)
        for component in self.manifest.in_place:  # cast in situ or built by others: static where they stand
            target = component.target_pose_world
            frame = (target.position_m, target.quat_xyzw)
            model = component_model(component, self.build_dir)
            body = create_component_body(cid, component, model, frame, visual=self.config.visuals)
            p.setCollisionFilterPair(self.ground_id, body.body_id, -1, -1, 0, physicsClientId=cid)
            self.in_place_bodies[component.guid] = body.body_id
        partners = joint_partners(self.manifest.joints)
        body_of = {guid: item.body.body_id for guid, item in items.items()} | self.in_place_bodies
        joined = let_joints_overlap(cid, partners, body_of)
        build_dir = self.build_dir
        pits = Pits(
            cid,
            self.manifest.components,
            filled=self._pit_filled,
            part_boxes=lambda component: collision_part_boxes(component, build_dir),
        )
        self.handling = Handling(
            cid,
            items,
            self.config.handling,
            self.layout.fence,
            ground_id=self.ground_id,
            pits=pits,
            settle=self.config.settle,
            connections=replace(self.config.connections, fit=self.config.tolerances),
            in_place={body: guid for guid, body in self.in_place_bodies.items()},
            joints=partners,
            framed=_with_trims(framed_ends(self.manifest.joints), trimmed_boards(self.manifest.components)),
            seed=self.config.seed,
        )
        self.in_place_work = InPlaceWork(cid, self.handling.state, self.build_dir, ground_id=self.ground_id)
        for item in items.values():
            if item.component.method in BUILT_IN_PLACE:  # built where it stands, never in the yard
                hide(cid, item)
        self._guids = list(items)
        self.robots = spawn_fleet(
            cid, self.robot_types, self.layout.robot_starts, self.config.robot, self.config.fleet
        )
        for index, (robot_id, robot) in enumerate(self.robots.items()):
            rng = np.random.default_rng([self.config.seed, index])
            self._odometry[robot_id] = Odometry(robot.start_xy_yaw, self.config.odom_noise, rng)
            if robot.drives:  # a machine standing fixed has no laser
                self._beam_starts[robot_id] = self._laser.beam_starts(robot.half_extents_xy_m)
        if self.config.compiled_laser:
            self._ray_scene = RayScene(cid)
        tolerances = self.config.tolerances
        _log.info(
            "placement tolerances in force: %g mm, %g°, drift %g mm (the site info serves them)",
            1000.0 * tolerances.position_m,
            math.degrees(tolerances.angle_rad),
            1000.0 * tolerances.drift_m,
        )
        _log.info(
            "scene: %d components in the yard, %d in place, %d joint(s), robots %s, fence %s–%s",
            len(items),
            len(self.in_place_bodies),
            joined,
            ", ".join(f"{robot_id} {robot.description.name}" for robot_id, robot in self.robots.items())
            or "none",
            self.layout.fence.min_xy,
            self.layout.fence.max_xy,
        )

    def _pit_filled(self, guid: str) -> bool:
        """A foundation's pit is filled once the foundation is placed in it (settling, placed or joined)."""
        return self.handling.items[guid].phase in (Phase.SETTLING, Phase.PLACED, Phase.JOINED)

    # --- state ---------------------------------------------------------------------------------------

    @property
    def sim_time_s(self) -> float:
        return self.step * self.config.control_period_s + self.skipped_s

    @property
    def robot_ids(self) -> list[str]:
        return list(self.robots)

    def info(self) -> SiteInfoMsg:
        return SiteInfoMsg(
            robot_ids=self.robot_ids,
            robot_starts_xy_yaw=[r.start_xy_yaw for r in self.robots.values()],
            step_s=self.config.step_s,
            control_period_s=self.config.control_period_s,
            lock_step=self.config.lock_step,
            command_latency_steps=self.config.command_latency_steps,
            robot_type_of={robot_id: robot.description.name for robot_id, robot in self.robots.items()},
            robot_types=types_on_site(self.robots),
            layout=self.layout,
            tolerances=self.config.tolerances,
        )

    def robot_pose(self, robot_id: str) -> tuple[float, float, float]:
        return self.robots[robot_id].pose_xy_yaw(self.client_id)

    def poses(self) -> SitePosesMsg:
        """Every component and robot now (ground truth), for ``physics/poses``."""
        now, cid = self.sim_time_s, self.client_id
        return SitePosesMsg(
            step=self.step,
            epoch=self.epoch,
            sim_time_s=now,
            components={
                guid: self.handling.pose_message(guid, now)
                for guid, item in self.handling.items.items()
                if item.phase is not Phase.UNBUILT
            },
            robots={
                robot_id: robot_pose_msg(
                    robot, robot.pose_xy_yaw(cid), now, self.handling.carrying.get(robot_id)
                )
                for robot_id, robot in self.robots.items()
            },
        )

    def component_frame(self, guid: str) -> tuple[tuple[float, ...], tuple[float, ...]]:
        return self.handling.items[guid].pose

    def busy_robots(self) -> set[str]:
        return self.handling.busy_robots()

    def known(self, robot_id: str) -> bool:
        if robot_id in self.robots:
            return True
        if robot_id not in self._unknown_logged:
            self._unknown_logged.add(robot_id)
            _log.warning(
                "robot %r was not spawned by physics (%s): ignored", robot_id, ", ".join(self.robots)
            )
        return False

    # --- inputs --------------------------------------------------------------------------------------

    def command(self, message: CmdVelMsg) -> bool:
        """Take a velocity command (False: unknown robot, ignored)."""
        if not self.known(message.robot_id):
            return False
        self.robots[message.robot_id].set_command(message.v_mps, message.w_radps)
        return True

    def set_alive(self, robot_id: str, alive: bool) -> list[Outgoing]:
        """A robot's liveliness changed; a lost robot stops and drops its load (its pose is returned)."""
        if not self.known(robot_id):
            return []
        if alive:
            self.alive.add(robot_id)
            return []
        self.alive.discard(robot_id)
        robot = self.robots[robot_id]
        robot.set_command(0.0, 0.0)
        guid = self.handling.drop(robot, self.sim_time_s)
        if guid is None:
            return []
        self.handling.changed.discard(guid)
        return [self._component_pose(guid)]

    def attach(self, request: AttachRequest) -> PhysicsReply:
        robot = self.robots.get(request.robot_id)
        if robot is None:
            return PhysicsReply(
                ok=False, reason=f"unknown robot {request.robot_id}", sim_time_s=self.sim_time_s
            )
        return self.handling.attach(robot, request.guid, self.sim_time_s)

    def drop(self, request: DropRequest) -> PhysicsReply:
        """A carrying robot puts its load down beside it (:meth:`.handling.Handling.drop_request`); the new
        pose goes out with the next period's messages."""
        robot = self.robots.get(request.robot_id)
        if robot is None:
            return PhysicsReply(
                ok=False, reason=f"unknown robot {request.robot_id}", sim_time_s=self.sim_time_s
            )
        return self.handling.drop_request(robot, request.guid, self.sim_time_s, request.near_xy_m)

    def place(self, request: PlaceRequest, tag: object = None) -> PhysicsReply | None:
        """A refusal now, or None: the reply comes with ``tag`` from the :meth:`advance` ending the motion."""
        robot = self.robots.get(request.robot_id)
        if robot is None:
            return PhysicsReply(
                ok=False, reason=f"unknown robot {request.robot_id}", sim_time_s=self.sim_time_s
            )
        waiting = self._landing_refusal(robot, request)
        if waiting is not None:
            return PhysicsReply(ok=False, reason=waiting, sim_time_s=self.sim_time_s, wait_s=ASK_AGAIN_S)
        return self.handling.place(
            robot,
            request.guid,
            request.pose,
            duration_s=request.duration_s,
            now_s=self.sim_time_s,
            tag=tag,
            believed_xy_yaw=request.believed_xy_yaw,
        )

    def _landing_refusal(self, robot: Robot, request: PlaceRequest) -> str | None:
        """Why the load ``robot`` carries may not be set down yet: another driving robot stands where it
        goes (:mod:`.landing_zone`); None when the zone is clear or the load has waited long enough."""
        item = self.handling.items.get(request.guid)
        if item is None or item.carrier != robot.robot_id or item.phase is Phase.ASSEMBLING:
            return None  # refused (or not) by the handling, as before
        frame, invalid = valid_frame(request.pose)
        if frame is None or invalid is not None:
            return None  # refused by the handling, with its reason
        footprint = posed_footprint(item.component, frame[0], frame[1])
        bystanders = []
        for other in self.robots.values():
            if other is robot or not other.drives:  # a robot whose service stopped still stands there
                continue
            (x, y, z), _ = other.frame(self.client_id)
            bystanders.append(
                Bystander(
                    other.robot_id,
                    (x, y),
                    other.description.radius_m,
                    z - other.base_height_m,
                    z + other.top_height_m,
                )
            )
        found = in_the_way(footprint, bystanders)
        name = item.component.name or request.guid
        return self._landing_waits.refusal(request.guid, name, found, self.sim_time_s)

    def build(self, request: BuildRequest) -> PhysicsReply:
        """Build a component where it stands, up to a fraction of its height (:mod:`.in_place_work`)."""
        robot = self.robots.get(request.robot_id)
        return self.in_place_work.build(robot, request.guid, request.height_fraction, self.sim_time_s)

    def relocate(self, request: SetUpRequest) -> PhysicsReply:
        """Move a truck-mounted machine to another of its set-up positions (:mod:`.relocation`)."""
        robot = self.robots.get(request.robot_id)
        setups = robot_setups(self.layout, list(self.robots.values()), request.robot_id) if robot else ()
        return relocate(self.client_id, robot, setups, request.pose_xy_yaw, self.sim_time_s)

    def quiet(self) -> str | None:
        """None when nothing moves on the site (no load carried or being placed, nothing settling, no
        robot commanded to move); else what moves, in words. A load at rest that its robot holds while
        its connection is made moves no more: it limits a skip (:meth:`held_until_s`) instead."""
        now = self.sim_time_s
        handling = self.handling
        for robot_id, guid in sorted(handling.carrying.items()):
            return f"{robot_id} carries {guid}"
        for guid, watch in sorted(handling.watch.items()):
            if not watch.settled:
                return f"{guid} is settling"
            if watch.tag is not None and now >= watch.hold_until_s:
                return f"{guid} is being set down"
        if self._late_replies:
            return "a placement is being answered"
        for robot_id, robot in self.robots.items():
            if robot.drives and max(abs(value) for value in robot.command) > 1e-6:
                return f"{robot_id} is driving"
        return None

    def held_until_s(self, robot_id: str | None = None) -> float | None:
        """The earliest end still ahead of a connection's hold (a robot holds a load at rest, set down, until
        its crew has made the connection): of ``robot_id``'s load, or of any; None when none is held."""
        now = self.sim_time_s
        ends = [
            watch.hold_until_s
            for watch in self.handling.watch.values()
            if watch.hold_until_s > now
            and (robot_id is None or (watch.tag is not None and watch.releaser == robot_id))
        ]
        return min(ends) if ends else None

    def skip(self, request: SkipRequest) -> PhysicsReply:
        """Jump the clock to ``request.to_sim_s`` over a quiet site (:meth:`quiet`), or say what moves. A
        connection's hold ends the jump early: its robot is answered there (:meth:`held_until_s`). Each
        robot of ``request.holding`` must hold a load so: one answered already acts on its answer next."""
        now = self.sim_time_s
        if request.to_sim_s <= now:
            return PhysicsReply(ok=True, sim_time_s=now)
        moving = self.quiet()
        if moving is None:
            moving = next(
                (
                    f"{robot_id} holds no load"
                    for robot_id in request.holding
                    if self.held_until_s(robot_id) is None
                ),
                None,
            )
        if moving is not None:
            return PhysicsReply(ok=False, reason=f"not quiet: {moving}", sim_time_s=now)
        to_sim_s, why = request.to_sim_s, request.why
        held_s = self.held_until_s()
        if held_s is not None and held_s < to_sim_s:
            to_sim_s, why = held_s, "to the end of a connection's hold"
        self.skipped_s += to_sim_s - now
        self.skips += 1
        _log.info(
            "skipped %.0f s of sim time over a quiet site, to t=%.0f s%s",
            to_sim_s - now,
            to_sim_s,
            f" ({why})" if why else "",
        )
        return PhysicsReply(ok=True, sim_time_s=self.sim_time_s)

    # --- stepping ------------------------------------------------------------------------------------

    def advance(self, real_time_factor: float | None = None) -> PeriodResult:
        """Simulate one control period; the messages of its end and the placements that finished in it."""
        cid = self.client_id
        busy = self.handling.busy_robots()
        for robot_id, robot in self.robots.items():
            robot.held = robot_id in busy
            robot.apply_motors(cid)
        replies, self._late_replies = self._late_replies, []
        start_s = self.sim_time_s
        step_s = self.config.step_s
        for index in range(1, self.config.substeps + 1):
            started = time.perf_counter()
            p.stepSimulation(physicsClientId=cid)
            self.stepping_wall_s += time.perf_counter() - started
            self.steps_taken += 1
            if self.handling.carrying:
                replies.extend(self.handling.follow(self.robots, start_s + index * step_s))
        self.step += 1
        replies.extend(self.handling.watch_placed(self.sim_time_s, self.robots))
        self.handling.pose_hooks(self.robots)
        self.handling.settle_separated()
        messages = self._period_messages(real_time_factor, odometry=True)
        return PeriodResult(messages, replies)

    def start_messages(self) -> list[Outgoing]:
        """Step 0: the clock, every robot's sensors and pose, and every component's pose."""
        messages = self._period_messages(None, odometry=False)
        listed = {m.message.guid for m in messages if hasattr(m.message, "guid")}
        messages.extend(
            self._component_pose(guid)
            for guid, item in self.handling.items.items()
            if guid not in listed and item.phase is not Phase.UNBUILT
        )
        return messages

    def _period_messages(self, real_time_factor: float | None, *, odometry: bool) -> list[Outgoing]:
        cid, now = self.client_id, self.sim_time_s
        rtf = self.config.real_time_factor if real_time_factor is None else real_time_factor
        out = [
            Outgoing(
                key(CLOCK_KEY, site=self.site),
                ClockMsg(
                    sim_time_s=now,
                    step=self.step,
                    real_time_factor=rtf,
                    lock_step=self.config.lock_step,
                    epoch=self.epoch,
                ),
            )
        ]
        if self._ray_scene is not None and any(robot.drives for robot in self.robots.values()):
            self._ray_scene.refresh()  # once a period, before the scans: what moved since the last
        for robot_id, robot in self.robots.items():
            if not robot.drives:  # it stands where it was set up: its odometry is that pose, exactly
                current = pose = robot.start_xy_yaw
                v = w = 0.0
            elif odometry:
                previous, current = robot.measure(cid, self.config.control_period_s)
                reading = self._odometry[robot_id].update(previous, current, self.config.control_period_s)
                pose, v, w = reading.pose_xy_yaw, reading.v_mps, reading.w_radps
            else:
                current, pose, v, w = robot.pose_xy_yaw(cid), self._odometry[robot_id].pose_xy_yaw, 0.0, 0.0
            out.append(
                Outgoing(
                    key(ROBOT_SENSORS_KEY, site=self.site, robot_id=robot_id),
                    OdomMsg(robot_id=robot_id, pose_xy_yaw=pose, v_mps=v, w_radps=w, sim_time_s=now),
                )
            )
            if robot.drives:
                out.append(self._scan(robot, now))
                if self._station is not None:
                    out.append(
                        Outgoing(
                            key(ROBOT_SENSORS_KEY, site=self.site, robot_id=robot_id),
                            self._station.fix(robot_id, current, robot.description.length_m, now),
                        )
                    )
            out.append(
                Outgoing(
                    key(ROBOT_POSE_KEY, site=self.site, robot_id=robot_id),
                    robot_pose_msg(robot, current, now, self.handling.carrying.get(robot_id)),
                )
            )
        items = self.handling.items
        changed = [guid for guid in self.handling.take_changed() if items[guid].phase is not Phase.UNBUILT]
        out.extend(self._component_pose(guid) for guid in changed)
        # in lock-step the repeats follow sim time, not the measured pace: which poses a period repeats
        # is then the same in every run (an agent may verify a placement on a repeated pose)
        pace = LOCK_STEP_REFRESH_RTF if self.config.lock_step else rtf
        out.extend(self._component_pose(guid) for guid in self._refresh_slice(set(changed), pace))
        return out

    def _scan(self, robot: Robot, now: float) -> Outgoing:
        started = time.perf_counter()
        mount = self._laser.mount(robot.frame(self.client_id), robot.base_height_m)
        ranges = self._laser.scan(
            self.client_id, mount, robot.group, self._beam_starts[robot.robot_id], self._ray_scene
        )
        self.scan_wall_s += time.perf_counter() - started
        self.scans_taken += 1
        return Outgoing(
            key(ROBOT_SENSORS_KEY, site=self.site, robot_id=robot.robot_id),
            ScanMsg(
                robot_id=robot.robot_id,
                angle_min_rad=self._laser.angle_min_rad,
                angle_increment_rad=self._laser.angle_increment_rad,
                range_max_m=self.config.laser.range_max_m,
                ranges_m=ranges,
                sim_time_s=now,
            ),
        )

    def _refresh_slice(self, skip: set[str], real_time_factor: float) -> list[str]:
        """The next few components in turn, so that each is repeated once per ``pose_refresh_s`` of wall
        time at ``real_time_factor`` (at most ``pose_refresh_max`` a period; a fraction carries over)."""
        guids = self._guids
        if not guids:
            return []
        cycle_sim_s = self.config.pose_refresh_s * max(1.0, real_time_factor)
        self._refresh_credit += len(guids) * self.config.control_period_s / cycle_sim_s
        per_period = min(int(self._refresh_credit), self.config.pose_refresh_max)
        self._refresh_credit = min(self._refresh_credit - per_period, 1.0)
        chosen = [guids[(self._refresh_cursor + i) % len(guids)] for i in range(min(per_period, len(guids)))]
        self._refresh_cursor = (self._refresh_cursor + len(chosen)) % len(guids)
        items = self.handling.items
        return [guid for guid in chosen if guid not in skip and items[guid].phase is not Phase.UNBUILT]

    def _component_pose(self, guid: str) -> Outgoing:
        component = self.handling.items[guid].component
        return Outgoing(
            key(COMPONENT_POSE_KEY, site=self.site, key=component.key or guid_to_key(guid)),
            self.handling.pose_message(guid, self.sim_time_s),
        )

    def set_odometry_pose(self, robot_id: str, xy_yaw: tuple[float, float, float]) -> None:
        """Continue ``robot_id``'s odometry from ``xy_yaw`` (a restart: the robot sees no jump)."""
        self._odometry[robot_id].pose_xy_yaw = xy_yaw

    def set_crane_joints(self, robot_id: str, joint_positions: dict[str, float]) -> None:
        """Put a crane's joints where a record says (a restart; names it lacks stay as they are)."""
        rig = self.robots[robot_id].rig
        if rig is None:
            return
        now = rig.joints.by_name()
        value = {name: float(joint_positions.get(name, now[name])) for name in now}
        rig.set(self.client_id, CraneJoints(value[SLEW], value[TROLLEY], value[HOIST]))

    # --- test helpers --------------------------------------------------------------------------------

    def teleport_robot(self, robot_id: str, xy_yaw: tuple[float, float, float]) -> None:
        """Put a robot somewhere (tests, benches): wheels on the ground, at rest; odometry follows. A crane
        stays where it was built (its base is fixed): asked to move, it is left in place (logged)."""
        robot = self.robots[robot_id]
        setups = (
            robot_setups(self.layout, list(self.robots.values()), robot_id) if robot.drive is None else ()
        )
        if robot.description.relocates and is_setup(xy_yaw, setups):  # a truck that relocates: at a set-up
            move_base(self.client_id, robot, xy_yaw)
            return
        if robot.drive is None:
            if max(abs(a - b) for a, b in zip(xy_yaw, robot.start_xy_yaw, strict=True)) > 1e-6:
                _log.warning("crane %s stands at %s: not moved to %s", robot_id, robot.start_xy_yaw, xy_yaw)
            return
        base = ((xy_yaw[0], xy_yaw[1], robot.base_height_m), yaw_quat(xy_yaw[2]))
        com = compose(base, robot.base_inertial)
        p.resetBasePositionAndOrientation(robot.body_id, com[0], com[1], physicsClientId=self.client_id)
        p.resetBaseVelocity(robot.body_id, [0, 0, 0], [0, 0, 0], physicsClientId=self.client_id)
        for wheels in (robot.drive.left, robot.drive.right):
            for joint, _ in wheels:
                angle = p.getJointState(robot.body_id, joint, physicsClientId=self.client_id)[0]
                p.resetJointState(robot.body_id, joint, angle, 0.0, physicsClientId=self.client_id)
        robot.reset_control()
        robot._last_xy_yaw = xy_yaw
        self._odometry[robot_id].pose_xy_yaw = xy_yaw
        if robot_id in self.handling.carrying:
            self._late_replies.extend(self.handling.follow(self.robots, self.sim_time_s))


def _with_trims(
    framed: dict[str, dict[str, float]], trims: dict[str, dict[str, float]]
) -> dict[str, dict[str, float]]:
    """The overlaps release lets stand: framed ends and boards trimmed to their neighbours (the deeper)."""
    merged = {guid: dict(others) for guid, others in framed.items()}
    for guid, others in trims.items():
        mine = merged.setdefault(guid, {})
        for other, depth_m in others.items():
            mine[other] = max(depth_m, mine.get(other, 0.0))
    return merged


def _erected(config: SimConfig, manifest: Manifest) -> SimConfig:
    """``config`` with its fleet's cranes erected as high as the build needs
    (:mod:`bimbot.shared.crane_erection`); said in the log when one is raised."""
    if config.fleet is None:
        return config
    fleet = erected_for(config.fleet, manifest.components)
    for words in erection_words(config.fleet, fleet):
        _log.info("%s", words)
    return config if fleet is config.fleet else replace(config, fleet=fleet)
