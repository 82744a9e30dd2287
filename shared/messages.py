"""Bus messages: one frozen, versioned pydantic model per message, beside its key expression.

Key space (``<site>`` is the manifest's site slug, ``<key>`` a component's bus key, see
:mod:`bimbot.shared.identifiers`); this table is :data:`KEY_SPACE` rendered by
:func:`bimbot.shared.keyspace.key_table` (a test keeps the two equal)::

    bimbot/<site>/components/<key>/state      ComponentStateMsg   agent → all (every state change)
    bimbot/<site>/components/<key>/event      ComponentEventMsg   planner/robot → agent (what happened to it)
    bimbot/<site>/components/<key>/pose       ComponentPoseMsg    physics → all (moving or just placed)
    bimbot/<site>/components/<key>/twin       (queryable)         agent answers TwinMsg
    bimbot/<site>/tasks/<task_id>             TaskMsg             planner → robots, observer
    bimbot/<site>/robots/<robot_id>/state     RobotStateMsg       robot → planner, observer
    bimbot/<site>/robots/<robot_id>/cmd_vel   CmdVelMsg           robot → physics
    bimbot/<site>/robots/<robot_id>/sensors   SensorsMsg          physics → robot, observer (binary odom+scan)
    bimbot/<site>/robots/<robot_id>/plan      PlanMsg             robot → observer
    bimbot/<site>/robots/<robot_id>/pose      RobotPoseMsg        physics → observer, run (ground truth)
    bimbot/<site>/physics/info                (queryable)         physics answers SiteInfoMsg
    bimbot/<site>/physics/attach              (queryable)         physics answers AttachRequest → PhysicsReply
    bimbot/<site>/physics/place               (queryable)         physics answers PlaceRequest → PhysicsReply
    bimbot/<site>/physics/drop                (queryable)         physics answers DropRequest → PhysicsReply
    bimbot/<site>/physics/build               (queryable)         physics answers BuildRequest → PhysicsReply
    bimbot/<site>/physics/skip                (queryable)         physics answers SkipRequest → PhysicsReply
    bimbot/<site>/physics/relocate            (queryable)         physics answers SetUpRequest → PhysicsReply
    bimbot/<site>/physics/poses               (queryable)         physics answers SitePosesMsg
    bimbot/<site>/planner/plan                (queryable)         planner answers PlannedSequenceMsg
    bimbot/<site>/planner/preparing           PreparingMsg        planner → run, physics (before it is ready)
    bimbot/<site>/clock                       ClockMsg            physics → all
    bimbot/<site>/progress                    ProgressMsg         planner → all
    bimbot/<site>/steps/<participant>         StepDoneMsg         planner/agent → physics (lock-step answers)
    bimbot/<site>/alive/<kind>/<id>           (liveliness)        token of every running service

A state change has one record, :class:`ComponentStateMsg`: the agent publishes it, keeps it in its twin's
``history`` (so an observer that joins late sees each change with its robot, placement error and reason)
and journals it (:mod:`bimbot.services.component_agents.journal`).

Times: ``sim_time_s`` is simulated time from the physics clock; ``wall_time_s`` is Unix time, only for
latency measurements. Poses are in the simulation world frame (see :mod:`bimbot.shared.manifest`).

Bounds: every number is declared with a bounded type of :mod:`bimbot.shared.message_bounds` (finite, sim
times in [0, 1e8] s, steps below 1e9, positions within 1e5 m, unit quaternions, …), so schema-valid nonsense
is rejected by :func:`bimbot.shared.bus.decode` like any invalid payload.
"""

from __future__ import annotations

from enum import StrEnum
from typing import Final, Literal

from pydantic import BaseModel, ConfigDict, Field

from .construction_methods import ConstructionMethod
from .keyspace import Entry, Liveliness, Queryable, Topic
from .message_bounds import (
    Angle,
    Count,
    FixStd,
    JointValue,
    NonNegative,
    Percent,
    Period,
    PointXY,
    PoseXYYaw,
    Position,
    Range,
    RangeMax,
    SimDuration,
    SimTime,
    Speed,
    Step,
    TurnRate,
    UnitQuat,
    WallTime,
)
from .reasons import Reason
from .robot_description import RobotDescription
from .site_plan import SiteLayout
from .verification import Tolerances

MESSAGE_SCHEMA_VERSION: Final = 2  # 2: TwinMsg.history holds ComponentStateMsg records (was TransitionRecord)


class _Message(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")
    schema_version: Literal[2] = MESSAGE_SCHEMA_VERSION


def site_root(site: str) -> str:
    return f"bimbot/{site}"


# --- components ------------------------------------------------------------------------------------------

COMPONENT_STATE_KEY = "bimbot/{site}/components/{key}/state"
COMPONENT_EVENT_KEY = "bimbot/{site}/components/{key}/event"
COMPONENT_POSE_KEY = "bimbot/{site}/components/{key}/pose"
COMPONENT_TWIN_KEY = "bimbot/{site}/components/{key}/twin"


class ComponentState(StrEnum):
    """A smart component's construction state (paper Fig. 12, with a failure path)."""

    PLANNED = "planned"
    RELEASED = "released"
    PICKING = "picking"
    TRANSPORTING = "transporting"
    ASSEMBLING = "assembling"
    FORMING = "forming"  # cast in place: formwork and reinforcement being set
    POURING = "pouring"  # cast in place: concrete being placed
    LAYING = "laying"  # laid: courses being laid
    DRIVING = "driving"  # driven: a pile being pitched and driven
    VERIFYING = "verifying"
    CONSTRUCTED = "constructed"
    MISPLACED = "misplaced"
    FAILED = "failed"  # not built: ``reason`` says why (terminal)
    BLOCKED = "blocked"  # never released: a predecessor failed (terminal, reason ``blocked_by``)


class ComponentEvent(StrEnum):
    """What the planner or a robot tells a component; the agent's state table decides what it means."""

    RELEASE = "release"  # planner: all predecessors constructed
    PICK = "pick"  # robot: on its way to pick the component up
    ATTACH = "attach"  # robot: component attached, transport begins
    ARRIVE = "arrive"  # robot: at the target, assembly begins
    PLACE = "place"  # robot: component placed; the agent verifies its own pose
    RETRY = "retry"  # planner: a misplaced component is released again
    ABANDON = "abandon"  # robot/planner: the task was given up (robot lost, or ``reason``); back to released
    FAIL = "fail"  # planner: the component cannot be built (``reason``: too heavy, give-backs exhausted…)
    BLOCK = "block"  # planner: a predecessor failed (``reason`` blocked_by); never released
    HAND_OFF = "hand_off"  # robot: put down at a crane's staging spot (a hand-off task); released again
    FORM = "form"  # crew: formwork begins (cast in place)
    POUR = "pour"  # crew: the pour begins (cast in place)
    LAY = "lay"  # block layer: laying begins (laid)
    DRIVE = "drive"  # piling rig: pitching and driving begin (driven)


class PoseMsg(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")
    position_m: Position
    quat_xyzw: UnitQuat


class ComponentStateMsg(_Message):
    """One state change of a component (or, with ``previous`` None, an agent announcing its state): the one
    record of it, on the bus, in the twin's history and in the agents' journal."""

    guid: str
    state: ComponentState
    previous: ComponentState | None = None
    event: str = Field(description="the event or internal decision that caused the change")
    cause: str = ""
    attempt: Count = 0
    robot_id: str | None = None
    sim_time_s: SimTime
    wall_time_s: WallTime
    position_error_m: NonNegative | None = None
    angle_error_rad: NonNegative | None = None
    reason: Reason | None = None  # failed/blocked: why; released after an abandon: why it was given back
    # a verdict: how far the component moved after physics released it (slid, tipped, fell); a misplaced
    # verdict whose cause is that motion carries reason ``unstable``, else ``misplaced``
    drift_m: NonNegative | None = None


class ComponentEventMsg(_Message):
    guid: str
    event: ComponentEvent
    source: str = Field(description="who sent it: 'planner' or a robot id")
    event_id: str = Field(description="unique per event, so a repeated delivery is applied once")
    task_id: str | None = None
    robot_id: str | None = None
    sim_time_s: SimTime
    wall_time_s: WallTime
    reason: Reason | None = None  # abandon, fail, block: why
    # place: what the agent's verdict should add if the placement misses (a robot that could not align to
    # its laser says so: the user's fix is on the site, not in the robot's precision)
    note: str = Field(default="", max_length=500)


class ComponentPoseMsg(_Message):
    guid: str
    pose: PoseMsg
    sim_time_s: SimTime
    attached_to: str | None = None  # robot id while carried
    fixed: bool = False  # placed: released and settled, or joined to the structure (``joined``)
    joined: bool = False  # joined to the structure (its agent verified it): it no longer moves
    # placed and not joined yet: how far it moved since physics released it (slid, tipped, fell), and
    # the components it rested on when released (the ground has no GUID: an empty list means only it)
    drift_m: NonNegative | None = None
    supports: list[str] = []
    open_pits: list[str] = []  # the foundations (not placed yet) whose open pit it was released over
    # placed and not joined yet: the components the model puts where it was released, GUID → how deep it
    # went into each (m; deeper than a contact: a clash in the IFC, which physics pushes apart)
    clash_depth_m: dict[str, NonNegative] = {}
    # placed and not joined yet: the first robot that touched it since its release, and when (sim s)
    bumped_by: str | None = None
    bumped_at_s: SimTime | None = None
    # placed: the built components it was connected to as it was set down at its target (bolted, welded,
    # fixed at its side; physics' connections), which hold it where it was put
    connected_to: list[str] = []
    # placed and not joined yet: the components its robot set it into, which the release moved it out of
    # (a robot stops at the contact), and how far that moved its centre from where the robot set it (m): a
    # neighbour standing off its own target, within tolerance, pushes it off by as much (tolerance stack-up)
    set_against: list[str] = []
    set_against_shift_m: NonNegative | None = None
    # placed: the built neighbours it was connected to, GUID → kind (shared/connection_kinds.py: bolted_base,
    # pinned_end, fixed_end, bearing, grouted, fastened), and the temporary supports standing on it now
    # (props, braces)
    connection_kinds: dict[str, str] = {}
    temporary_supports: Count = 0
    # placed or joined by a robot: its target fitted to the structure as built (physics' support_fit.py: on
    # its supports' seats, drawn up to the built member in its way; within the tolerances of its BIM target);
    # None: its BIM target. Its agent, its connections and the run's as-built audit judge it there
    fitted_target: PoseMsg | None = None


class TwinMsg(_Message):
    """A component's digital-twin record, answered by its agent's queryable."""

    guid: str
    key: str
    ifc_class: str
    name: str | None
    storey: str | None
    material: str | None
    mass_kg: NonNegative
    target_pose: PoseMsg
    current_pose: PoseMsg | None
    current_pose_sim_time_s: SimTime | None
    state: ComponentState
    attempt: Count
    robot_id: str | None
    history: list[ComponentStateMsg]  # every transition (``previous`` set), oldest first
    reason: Reason | None = None  # failed/blocked: why; else the last give-back's reason, if any


# --- tasks -----------------------------------------------------------------------------------------------

TASK_KEY = "bimbot/{site}/tasks/{task_id}"


class TaskStatus(StrEnum):
    RELEASED = "released"  # ready, waiting for a robot
    ASSIGNED = "assigned"  # given to robot_id
    DONE = "done"  # component constructed
    FAILED = "failed"  # component failed after its retries
    BLOCKED = "blocked"  # a predecessor failed; never released


class TaskKind(StrEnum):
    BUILD = "build"  # pick the component up and place it at its BIM target
    HAND_OFF = "hand_off"  # carry it to ``put_down_xy_m`` (a crane's staging spot) and put it down there
    # a failed component's body lies in the robots' way: carry it from where it lies to ``put_down_xy_m``
    # (its yard slot) and put it down there; its state and reason stay failed (it is still not built)
    CLEAR = "clear"


class TaskMsg(_Message):
    task_id: str
    guid: str
    component_key: str
    status: TaskStatus
    robot_id: str | None = None
    attempt: Count = 0
    target_pose: PoseMsg
    sim_time_s: SimTime
    wall_time_s: WallTime
    reason: Reason | None = None  # failed/blocked tasks: why
    kind: TaskKind = TaskKind.BUILD
    put_down_xy_m: PointXY | None = None  # hand-off tasks: where the load goes down
    method: ConstructionMethod = ConstructionMethod.LIFTED  # how it is built (the manifest's method)


# --- robots ----------------------------------------------------------------------------------------------

ROBOT_STATE_KEY = "bimbot/{site}/robots/{robot_id}/state"
ROBOT_CMD_VEL_KEY = "bimbot/{site}/robots/{robot_id}/cmd_vel"
ROBOT_SENSORS_KEY = "bimbot/{site}/robots/{robot_id}/sensors"
ROBOT_PLAN_KEY = "bimbot/{site}/robots/{robot_id}/plan"
ROBOT_POSE_KEY = "bimbot/{site}/robots/{robot_id}/pose"


class RobotState(StrEnum):
    """Robot task states as in the paper (§5.2)."""

    IDLE = "idle"
    DETECT_COMPONENT_POSITION = "detect_component_position"
    PICK_UP = "pick_up"
    IDENTIFY_TARGET_LOCATION = "identify_target_location"
    ASSEMBLE = "assemble"
    WORK_IN_PLACE = "work_in_place"  # cast in place or laid: timed work at the component's target


class ClearOutcome(_Message):
    """How a robot's clear-away task ended (``TaskKind.CLEAR``): the load put down where it was to go
    (``ok``), or given back with ``reason``. Repeated on the robot's state messages until its next task
    starts: the planner applies each ``task_id`` once."""

    task_id: str
    guid: str
    ok: bool
    sim_time_s: SimTime  # when it ended (put down, or given up)
    reason: Reason | None = None  # not ok: why


class RobotStateMsg(_Message):
    robot_id: str
    state: RobotState
    task_id: str | None = None
    guid: str | None = None
    pose_xy_yaw: PoseXYYaw
    sim_time_s: SimTime
    wall_time_s: WallTime
    distance_m: NonNegative = 0.0
    activity: str = ""  # what the robot is doing, in words (a stall report and the live progress show it)
    # timed work in place (formwork, pour, a course): nothing of this robot changes before this sim time,
    # so a site where nothing else moves may skip to it (``physics/skip``)
    busy_until_s: SimTime | None = None
    relocations: Count = 0  # a machine that relocates: how often it moved to another set-up so far
    # a ground robot walled in (no way to its depot start, where ``pose_xy_yaw`` says): since this sim time;
    # None again once it drove out. The planner gives it no new task meanwhile.
    walled_in_since_s: SimTime | None = None
    cleared: ClearOutcome | None = None  # the last clear-away task's end, until the next task starts


class CmdVelMsg(_Message):
    robot_id: str
    v_mps: Speed
    w_radps: TurnRate
    sim_time_s: SimTime
    step: Step | None = None  # the clock step this command answers (lock-step mode)
    # physics requests the robot sent before this command, answering the same step: a query travels apart
    # from the command and may come after it, and physics must not step past it (reproducible runs)
    requests: Count = 0
    # the robot is idle and sleeps after this step: it answers no step until a task message wakes it (the
    # planner's answer says so, ``StepDoneMsg.wakes``); nobody waits for it meanwhile (shared/step_gate.py)
    sleeps: bool = False
    # with ``sleeps``: it also wakes at the first step whose sim time reaches this (a kinematic robot's
    # drive ends there; shared/step_gate.py); None: only a task message wakes it
    wakes_at_s: float | None = None


class RobotPoseMsg(_Message):
    """Ground truth from physics (robots localise from odometry and laser, not from this)."""

    robot_id: str
    pose_xy_yaw: PoseXYYaw
    sim_time_s: SimTime
    carrying: str | None = None  # GUID of the attached component
    # a crane's joints (slew rad, trolley m, hoist m) by URDF joint name; empty for ground robots
    joint_positions: dict[str, JointValue] = {}


class OdomMsg(_Message):
    robot_id: str
    pose_xy_yaw: PoseXYYaw
    v_mps: Speed
    w_radps: TurnRate
    sim_time_s: SimTime


class ScanMsg(_Message):
    # +inf ("no return") goes on the bus as JSON ``Infinity`` and comes back (pydantic's default writes null)
    model_config = ConfigDict(frozen=True, extra="forbid", ser_json_inf_nan="constants")
    robot_id: str
    angle_min_rad: Angle
    angle_increment_rad: Angle
    range_max_m: RangeMax
    ranges_m: list[Range]  # physics publishes range_max_m for a beam that hits nothing
    sim_time_s: SimTime


class PositionFixMsg(_Message):
    """A positioning sensor's fix of a robot (a robotic total station tracking two prisms on it, as site
    layout robots use): where its base frame's origin is on the site and which way it faces, with the
    sensor's standard deviations. Physics sends one each control period when the site has such a sensor
    (``--total-station-mm``)."""

    robot_id: str
    position_xy_m: PointXY
    std_m: FixStd
    yaw_rad: Angle
    yaw_std_rad: FixStd
    sim_time_s: SimTime


class PlanMsg(_Message):
    robot_id: str
    path_xy_m: list[PointXY]
    goal_xy_m: PointXY
    sim_time_s: SimTime


# --- physics requests ----------------------------------------------------------------------------------

PHYSICS_INFO_KEY = "bimbot/{site}/physics/info"
PHYSICS_ATTACH_KEY = "bimbot/{site}/physics/attach"
PHYSICS_PLACE_KEY = "bimbot/{site}/physics/place"
PHYSICS_DROP_KEY = "bimbot/{site}/physics/drop"
PHYSICS_POSES_KEY = "bimbot/{site}/physics/poses"
PHYSICS_BUILD_KEY = "bimbot/{site}/physics/build"
PHYSICS_SKIP_KEY = "bimbot/{site}/physics/skip"
PHYSICS_RELOCATE_KEY = "bimbot/{site}/physics/relocate"


class SiteInfoMsg(_Message):
    """What a robot (or the planner) needs from physics: who is on site, of which type, the clock's pace."""

    robot_ids: list[str]
    robot_starts_xy_yaw: list[PoseXYYaw]
    robot_type_of: dict[str, str]  # robot id → type name (a key of robot_types)
    robot_types: dict[str, RobotDescription]  # the one description of each type on site
    step_s: Period
    control_period_s: Period
    lock_step: bool
    layout: SiteLayout  # the one site plan (yard slots, depot, fence): physics owns it, the rest ask
    # control periods between a robot's sensing and its command acting: a robot plans from where it will
    # be when its command acts (its last command carries it there meanwhile)
    command_latency_steps: Count = 0
    # the placement tolerances in force: the agents verify with them, physics connects with them, the
    # run's audit and report judge with them (one override: ``bimbot run --position-tolerance-m``)
    tolerances: Tolerances = Field(default_factory=Tolerances)
    # lock-step participants besides the robots (physics --step-with): who answers every clock step, so a
    # service that takes its inputs at defined steps knows whose answers to wait for from the first step
    lock_step_participants: list[str] = []
    fidelity: str | None = None  # what physics simulates at: "physics" or "plan" (None: it does not say)


PLANNER_PLAN_KEY = "bimbot/{site}/planner/plan"


PLANNER_PREPARING_KEY = "bimbot/{site}/planner/preparing"


class PreparingMsg(_Message):
    """The planner still prepares its plan (the access check of a large building takes minutes): what it
    does and how far it is. Published at least every few seconds until it is ready; the run's watchdog and
    physics, which hold the clock at 0 for it, take each as a sign of life, not as a hang."""

    stage: str = Field(min_length=1, max_length=200)  # e.g. "access check, round 3 of at most 8"
    done: Count  # steps of the stage done, of ``total``
    total: Count


class PlannedSequenceMsg(_Message):
    """The plan the planner builds by (after its access check): reports and the run ask it, so a run with
    ``--derive`` or ``--sequence`` reports the order it really followed, not the build's sequence.xml."""

    source: str  # e.g. "sequence.xml (ifc_schedule)", "derived from the support graph"
    order: list[str]  # GUIDs in release priority
    predecessors: dict[str, list[str]]  # GUID → GUIDs that must be constructed first
    warnings: list[str] = []  # what the planner found wrong with its input (sequence, access)


class AttachRequest(_Message):
    robot_id: str
    guid: str
    step: Step | None = None  # the clock step the robot answered as it asked (physics acts on it in turn)


class PlaceRequest(_Message):
    robot_id: str
    guid: str
    pose: PoseMsg  # where the robot means to put it, world frame, as the robot believes the world is
    duration_s: SimDuration = 2.0  # sim seconds of the assembly motion
    # where the robot believes it stands (its localisation): physics places the component where that
    # belief puts it relative to the robot's true pose, so a localisation error is a placement error
    # (None: the robot's pose is known exactly, a crane's fixed base)
    believed_xy_yaw: PoseXYYaw | None = None
    step: Step | None = None  # the clock step the robot answered as it asked (physics acts on it in turn)


class DropRequest(_Message):
    """A carrying robot puts its load down beside it (it cannot deliver it): the component rests there,
    flat on the ground, and may be picked up again by any robot."""

    robot_id: str
    guid: str
    near_xy_m: PointXY | None = None  # a hand-off: put it down as near this staging spot as is free
    step: Step | None = None  # the clock step the robot answered as it asked (physics acts on it in turn)


class BuildRequest(_Message):
    """A component built where it stands (cast in place, laid): physics makes it stand at its BIM target,
    static, up to ``height_fraction`` of its height from its bottom (a laid wall grows course by course;
    1.0: the whole component, a pour)."""

    robot_id: str
    guid: str
    height_fraction: float = Field(default=1.0, gt=0.0, le=1.0)
    step: Step | None = None  # the clock step the robot answered as it asked (physics acts on it in turn)


class SetUpRequest(_Message):
    """A truck-mounted machine that stands fixed has stowed, driven to another of its set-up positions
    (the site plan's ``SiteLayout.setups``) and set up again: physics moves its body there (the time it
    took is the robot's, spent before it asks)."""

    robot_id: str
    pose_xy_yaw: PoseXYYaw
    step: Step | None = None  # the clock step the robot answered as it asked (physics acts on it in turn)


class SkipRequest(_Message):
    """The planner sees a site where nothing moves until ``to_sim_s`` (curing, timed work in place): physics
    jumps its clock there if nothing moves indeed (no load carried or settling, every robot standing still),
    else it refuses and says why."""

    to_sim_s: SimTime
    why: str = Field(default="", max_length=500)
    step: Step | None = None  # the clock step the planner answered as it asked (lock-step: acted on after)
    # lock-step: the participant that asked, whose StepDoneMsg for ``step`` counted this request
    participant: str | None = Field(default=None, max_length=64)
    # robots the planner sees placing a load: physics skips only while each holds one at rest until its
    # connection is made, and no further than the earliest such hold's end
    holding: list[str] = Field(default_factory=list, max_length=256)


class SitePosesMsg(_Message):
    """Where everything is now, by physics (the one truth of poses): every component and every robot, at
    clock ``step`` of ``epoch``. A robot that restarts takes its pose from here, the run's as-built audit
    compares the components with their BIM targets."""

    step: Step
    epoch: Step
    sim_time_s: SimTime
    components: dict[str, ComponentPoseMsg]  # GUID → pose
    robots: dict[str, RobotPoseMsg]  # robot id → ground-truth pose


class PhysicsReply(_Message):
    ok: bool
    reason: str = ""
    sim_time_s: SimTime
    pose: PoseMsg | None = None  # the component's pose after the request (a placement: once settled)
    distance_m: NonNegative | None = None  # a reach refusal: the robot's true distance to the footprint (m)
    # a refusal for now (another robot stands where the load goes): ask again after this many sim s; no try
    wait_s: NonNegative | None = None


# --- site-wide -------------------------------------------------------------------------------------------

CLOCK_KEY = "bimbot/{site}/clock"
PROGRESS_KEY = "bimbot/{site}/progress"
ALIVE_KEY = "bimbot/{site}/alive/{kind}/{id}"


class ClockMsg(_Message):
    sim_time_s: SimTime
    step: Step  # control step (one per control period), the unit of lock-step
    real_time_factor: NonNegative
    lock_step: bool = False
    epoch: Step = 0  # physics starts of this run - 1: a new epoch is a restart, not a jump in time
    # lock-step with participants (shared/step_gate.py): every participant's output stamped up to here has
    # been sent before this clock (the sim time of step - 2); and the latest step at or before this one at
    # which the sleeping robots woke (None: no wake yet)
    inputs_to_s: SimTime | None = None
    last_wake_step: Step | None = None


class SensorsMsg(_Message):
    """What physics tells one robot each control period, in one message: the clock step it answers, its
    odometry, its laser scan (None for a robot without a laser, a crane) and a position fix (None without a
    positioning sensor on site). One message instead of three
    wakes the robot once a period; it travels in the compact binary layout of :mod:`bimbot.shared.wire`."""

    robot_id: str
    clock: ClockMsg
    odom: OdomMsg
    scan: ScanMsg | None = None
    fix: PositionFixMsg | None = None  # without a positioning sensor on site: None


class CuringHold(BaseModel):
    """In the progress: ``guid`` waits for the cast element ``cast_guid`` to cure, until ``until_s``."""

    model_config = ConfigDict(frozen=True, extra="forbid")
    guid: str
    cast_guid: str
    until_s: SimTime


class ProgressMsg(_Message):
    total: Count
    counts: dict[str, Count]  # by ComponentState value
    percent_constructed: Percent
    sim_time_s: SimTime
    estimated_finish_sim_time_s: NonNegative | None  # an estimate, not a clock: not held to MAX_SIM_TIME_S
    failed: list[str] = []
    blocked: list[str] = []
    reasons: dict[str, Reason] = {}  # GUID → why, for every failed and blocked component
    done: bool = False
    curing: list[CuringHold] = []  # what is ready but for the curing of a cast element it rests on


STEP_DONE_KEY = "bimbot/{site}/steps/{participant}"


PLANNER_PARTICIPANT = "planner"  # the planner's name as a lock-step participant (``StepDoneMsg.participant``)


class StepDoneMsg(_Message):
    """A lock-step participant that is not a robot (the planner, each agents shard) answered clock step
    ``step``: what it had to say up to that step has been sent (see :mod:`bimbot.shared.step_gate`).
    ``done``: it stops answering (physics no longer waits for it)."""

    participant: str = Field(min_length=1, max_length=64)
    step: Step
    sim_time_s: SimTime
    done: bool = False
    # physics requests (a skip) the participant sent before this answer: a query travels apart from the
    # answer and may come after it, and physics must not step past it (as ``CmdVelMsg.requests``)
    requests: Count = 0
    # the earliest sim time after this step at which the participant acts of its own accord, with nothing
    # heard (the planner: a curing's end releases a task): the plan fidelity's clock jumps no further
    next_event_s: SimTime | None = None
    # the planner sent a task message at this step: every sleeping robot wakes at ``step + DELAY_STEPS``,
    # the step that takes it (shared/step_gate.py)
    wakes: bool = False


def key(template: str, **parts: str) -> str:
    """Fill a key template (``key(COMPONENT_STATE_KEY, site=s, key=k)``)."""
    return template.format(**parts)


# --- the registry: every key, what travels on it and who speaks ---------------------------------------

COMPONENT_STATE = Topic(COMPONENT_STATE_KEY, ComponentStateMsg, "agent", "all", "every state change")
COMPONENT_EVENT = Topic(
    COMPONENT_EVENT_KEY, ComponentEventMsg, "planner/robot", "agent", "what happened to it"
)
COMPONENT_POSE = Topic(COMPONENT_POSE_KEY, ComponentPoseMsg, "physics", "all", "moving or just placed")
COMPONENT_TWIN = Queryable(COMPONENT_TWIN_KEY, None, TwinMsg, "agent")
TASK = Topic(TASK_KEY, TaskMsg, "planner", "robots, observer")
ROBOT_STATE = Topic(ROBOT_STATE_KEY, RobotStateMsg, "robot", "planner, observer")
ROBOT_CMD_VEL = Topic(ROBOT_CMD_VEL_KEY, CmdVelMsg, "robot", "physics")
ROBOT_SENSORS = Topic(ROBOT_SENSORS_KEY, SensorsMsg, "physics", "robot, observer", "odom+scan", True)
ROBOT_PLAN = Topic(ROBOT_PLAN_KEY, PlanMsg, "robot", "observer")
ROBOT_POSE = Topic(ROBOT_POSE_KEY, RobotPoseMsg, "physics", "observer, run", "ground truth")
PHYSICS_INFO = Queryable(PHYSICS_INFO_KEY, None, SiteInfoMsg, "physics")
PHYSICS_ATTACH = Queryable(PHYSICS_ATTACH_KEY, AttachRequest, PhysicsReply, "physics")
PHYSICS_PLACE = Queryable(PHYSICS_PLACE_KEY, PlaceRequest, PhysicsReply, "physics")
PHYSICS_DROP = Queryable(PHYSICS_DROP_KEY, DropRequest, PhysicsReply, "physics")
PHYSICS_POSES = Queryable(PHYSICS_POSES_KEY, None, SitePosesMsg, "physics")
PHYSICS_BUILD = Queryable(PHYSICS_BUILD_KEY, BuildRequest, PhysicsReply, "physics")
PHYSICS_SKIP = Queryable(PHYSICS_SKIP_KEY, SkipRequest, PhysicsReply, "physics")
PHYSICS_RELOCATE = Queryable(PHYSICS_RELOCATE_KEY, SetUpRequest, PhysicsReply, "physics")
PLANNER_PLAN = Queryable(PLANNER_PLAN_KEY, None, PlannedSequenceMsg, "planner")
CLOCK = Topic(CLOCK_KEY, ClockMsg, "physics", "all")
PROGRESS = Topic(PROGRESS_KEY, ProgressMsg, "planner", "all")
PLANNER_PREPARING = Topic(
    PLANNER_PREPARING_KEY, PreparingMsg, "planner", "run, physics", "before it is ready"
)
STEP_DONE = Topic(STEP_DONE_KEY, StepDoneMsg, "planner/agent", "physics", "lock-step answers")
# kind: component, robot, planner, physics, observer
ALIVE = Liveliness(ALIVE_KEY, "every running service")

KEY_SPACE: tuple[Entry, ...] = (
    COMPONENT_STATE,
    COMPONENT_EVENT,
    COMPONENT_POSE,
    COMPONENT_TWIN,
    TASK,
    ROBOT_STATE,
    ROBOT_CMD_VEL,
    ROBOT_SENSORS,
    ROBOT_PLAN,
    ROBOT_POSE,
    PHYSICS_INFO,
    PHYSICS_ATTACH,
    PHYSICS_PLACE,
    PHYSICS_DROP,
    PHYSICS_BUILD,
    PHYSICS_SKIP,
    PHYSICS_RELOCATE,
    PHYSICS_POSES,
    PLANNER_PLAN,
    PLANNER_PREPARING,
    CLOCK,
    PROGRESS,
    STEP_DONE,
    ALIVE,
)
TOPICS: dict[str, Topic] = {entry.template: entry for entry in KEY_SPACE if isinstance(entry, Topic)}
QUERYABLES: dict[str, Queryable] = {
    entry.template: entry for entry in KEY_SPACE if isinstance(entry, Queryable)
}


def topic_of(site: str, key_expr: str) -> Topic | None:
    """The topic a concrete key belongs to on ``site`` (None: not a published key of bimbot)."""
    return next((topic for topic in TOPICS.values() if topic.matches(site, key_expr)), None)
