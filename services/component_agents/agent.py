"""One smart component as a plain model object: its state machine, its own placement check, its twin record.

A :class:`ComponentAgent` knows its manifest :class:`~bimbot.shared.manifest.Component` (semantics and
BIM target pose), its construction state, the number of placement attempts, the robot handling it, its
latest pose on the bus and the history of its transitions. It has no bus, no files and no threads: the
host feeds it validated messages and publishes what it returns (one
:class:`~bimbot.shared.messages.ComponentStateMsg` per state change, with the sim time, the wall time and
the cause).

Protocol (docs/architecture.md, "Construction protocol"):

* external events follow :mod:`.state_table`; an illegal event is rejected and logged, never applied;
* each ``event_id`` is applied once (delivery is at least once), a repeat is ignored;
* each ``place`` is one attempt. In ``verifying`` the agent needs a pose of itself from the placement: one
  stamped at or after the ``place`` event's sim time, or one marked ``fixed`` (fixed to the structure by
  physics) stamped at or after the ``arrive`` event (``pour``, ``lay`` for work in place), since physics
  fixes the component before the robot
  reports ``place``. It compares that pose with its BIM target (:mod:`.verification`). When none
  arrives within ``verify_timeout_s`` wall seconds it verifies the latest pose it has, or, with no pose at
  all, judges the placement a failure ("no pose on the bus"). A failure with attempts left is
  ``misplaced`` (the planner sends ``retry``); with none left it is ``failed``.

One ``transitions`` machine serves every agent of a process (:class:`.state_table.ComponentMachine`,
built by :class:`bimbot.shared.table_machine.TableMachine`).
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

from bimbot.shared.manifest import Component
from bimbot.shared.messages import (
    ComponentEvent,
    ComponentEventMsg,
    ComponentPoseMsg,
    ComponentState,
    ComponentStateMsg,
    PoseMsg,
    TwinMsg,
)
from bimbot.shared.reasons import BESIDE_IT, CLASH_ADVICE, Reason, ReasonCode, clash_clause
from bimbot.shared.robot_description import RobotDescription
from bimbot.shared.state_table import INITIAL, ComponentMachine, Verdict
from bimbot.shared.verification import (
    PlacementCheck,
    Tolerances,
    is_valid_pose,
    verify,
)

from .advice import SetAgainst, misplaced_hint

_log = logging.getLogger(__name__)
# What a user can do about a component that would not stand: its failed reason ends with this.
UNSTABLE_HINT = (
    "no connection held it: a component is connected to the structure only when set down within the "
    f"tolerances of its target with a component already built beside it ({BESIDE_IT}), and "
    "never in a run with --no-connections; props or braces hold it only where its build says it needs them "
    "(the manifest's temporary_support), set wherever it was put; else it stands only on what was placed "
    "before it: `bimbot run BUILD --check-stability` shows which steps of the sequence stand"
)

BUMPED_HINT = (
    "a robot drove into it before it was joined to the structure: its route passed too close (see that "
    "robot's log), or its laser did not see the component"
)


def clash_hint(guid: str, clash_depth_m: dict[str, float]) -> str:
    """The advice for a component the model draws into others: leave one out, the command with the
    GlobalIds filled in (the one it is drawn deepest into, or its own: a new user had to look them up)."""
    other = max(sorted(clash_depth_m), key=lambda key: clash_depth_m[key])
    return f"{CLASH_ADVICE}: bimbot convert MODEL.ifc -o OUT/ --exclude {other} (or --exclude {guid})"


PLANNER_SOURCE = "planner"  # ComponentEventMsg.source of the planner's events; a robot's is its id
PLANNER_EVENTS = frozenset(
    {ComponentEvent.RELEASE, ComponentEvent.RETRY, ComponentEvent.FAIL, ComponentEvent.BLOCK}
)
ROBOT_EVENTS = frozenset(
    {
        ComponentEvent.PICK,
        ComponentEvent.ATTACH,
        ComponentEvent.ARRIVE,
        ComponentEvent.PLACE,
        ComponentEvent.HAND_OFF,
        ComponentEvent.FORM,
        ComponentEvent.POUR,
        ComponentEvent.LAY,
        ComponentEvent.DRIVE,
    }
)
# events after which physics may fix the component where it stands before the robot says place: a lifted
# component at its target (connected), a cast one poured, a laid one's last course, a pile driven
FIXED_AFTER = frozenset(
    {ComponentEvent.ARRIVE, ComponentEvent.POUR, ComponentEvent.LAY, ComponentEvent.DRIVE}
)


@dataclass(frozen=True)
class AgentConfig:
    """Settings shared by every agent of a host."""

    tolerances: Tolerances = field(default_factory=Tolerances)
    max_attempts: int = 3
    verify_timeout_s: float = 5.0
    # False until the site's tolerances are known (physics' site info): a placement then waits for them,
    # up to its verification timeout, rather than be judged by another tolerance than the site's
    tolerances_known: bool = True
    # the verification timeout in sim seconds (lock-step: the wait ends at the same step in every run)
    sim_deadlines: bool = False
    # robot id → its type's description (physics' site info): a failed placement's advice names what
    # placed it (a crane's hook, a ground robot's localisation) and its type's precision
    robots: Mapping[str, RobotDescription] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.max_attempts < 1:
            raise ValueError(f"max_attempts must be ≥ 1, got {self.max_attempts}")
        if not (math.isfinite(self.verify_timeout_s) and self.verify_timeout_s > 0):
            raise ValueError(f"verify_timeout_s must be a finite number > 0, got {self.verify_timeout_s}")


def clip(text: object, limit: int = 60) -> str:
    """A received value for a log line: its repr, cut to ``limit`` characters (payloads can be huge)."""
    shown = repr(text)
    return shown if len(shown) <= limit else f"{shown[: limit - 12]}…({len(shown)} chars)"


class SimClock:
    """The latest simulated time heard on ``bimbot/<site>/clock``, shared by the agents of a host."""

    __slots__ = ("heard", "sim_time_s")

    def __init__(self) -> None:
        self.sim_time_s = 0.0
        self.heard = False

    def observe(self, sim_time_s: float) -> None:
        if math.isfinite(sim_time_s):
            self.sim_time_s = sim_time_s
            self.heard = True

    def now(self, stamp_s: float | None = None) -> float:
        """The sim time of a change: the clock, or the cause's own stamp when that is later (clock not heard
        yet, or lagging behind the sender)."""
        if stamp_s is None or not math.isfinite(stamp_s):
            return self.sim_time_s
        return max(self.sim_time_s, stamp_s)


class ComponentAgent:
    """One component's state, placement check and twin record (no bus; see the module docstring)."""

    __slots__ = (
        "_clock",
        "_config",
        "_machine",
        "arrive_sim_time_s",
        "attempt",
        "bumped",
        "clash_depth_m",
        "component",
        "drift_m",
        "event_ids",
        "fitted_target",
        "guid",
        "history",
        "key",
        "open_pits",
        "place_note",
        "place_sim_time_s",
        "pose",
        "pose_fixed",
        "pose_sim_time_s",
        "reason",
        "robot_id",
        "set_against",
        "state",
        "supports",
        "verify_deadline_wall_s",
    )

    def __init__(
        self,
        component: Component,
        config: AgentConfig | None = None,
        machine: ComponentMachine | None = None,
        clock: SimClock | None = None,
    ) -> None:
        self.component = component
        self.guid = component.guid
        self.key = component.key
        self._config = config or AgentConfig()
        self._clock = clock or SimClock()
        self._machine = machine or ComponentMachine()
        self.state: ComponentState = INITIAL
        self.attempt = 0
        self.robot_id: str | None = None
        self.pose: PoseMsg | None = None
        self.pose_sim_time_s: float | None = None
        self.pose_fixed = False
        self.drift_m: float | None = None  # how far it moved since physics released it (its latest pose)
        self.supports: tuple[str, ...] = ()  # what it rested on then
        self.set_against: SetAgainst | None = None  # the neighbours its release moved it out of, how far
        self.open_pits: tuple[str, ...] = ()  # released over the open pit of these foundations
        self.clash_depth_m: dict[str, float] = {}  # the model put it into these components (GUID → m)
        # physics fitted its target to the structure as built (None: its BIM target): judged there
        self.fitted_target: PoseMsg | None = None
        self.bumped: tuple[str, float] | None = None  # the robot that touched it since its release, when
        self.arrive_sim_time_s: float | None = None
        self.place_sim_time_s: float | None = None
        self.place_note = ""  # what the placing robot said with its place event (e.g. placed unaligned)
        self.verify_deadline_wall_s: float | None = None
        self.history: list[ComponentStateMsg] = []  # every transition, as published
        self.event_ids: set[str] = set()
        self.reason: Reason | None = None  # why it failed or is blocked; else why it was last given back
        self._machine.start(self)

    # --- inputs --------------------------------------------------------------------------------------------

    def _sender_refusal(self, msg: ComponentEventMsg) -> str | None:
        """Who may say what (None: this sender may): the planner releases, retries, fails and blocks; a
        robot picks, attaches, arrives, places and hands off, and once a robot has picked the component up,
        only that robot until the task is given back, handed off or retried; either may abandon."""
        robot = msg.source != PLANNER_SOURCE
        if msg.event in PLANNER_EVENTS and robot:
            return f"{msg.event.value} comes from the planner only, not {clip(msg.source)}"
        if msg.event in ROBOT_EVENTS and not robot:
            return f"{msg.event.value} comes from a robot, not the planner"
        if robot and msg.robot_id not in (None, msg.source):
            return f"sent by {clip(msg.source)} on behalf of {clip(msg.robot_id)}"
        if robot and self.robot_id is not None and msg.source != self.robot_id:
            return f"{clip(self.robot_id)} works on it, not {clip(msg.source)}"
        return None

    def apply_event(self, msg: ComponentEventMsg, now_wall_s: float | None = None) -> list[ComponentStateMsg]:
        """Apply a planner/robot event once; the state messages to publish (none: rejected or a repeat)."""
        now = time.time() if now_wall_s is None else now_wall_s
        if msg.guid != self.guid:
            _log.warning("%s: rejected %s addressed to %s", self.guid, msg.event.value, clip(msg.guid))
            return []
        if msg.event_id in self.event_ids:
            _log.debug(
                "%s: %s event_id %s already applied; ignored", self.guid, msg.event.value, clip(msg.event_id)
            )
            return []
        if not math.isfinite(msg.sim_time_s):
            _log.warning("%s: rejected %s with sim time %r", self.guid, msg.event.value, msg.sim_time_s)
            return []
        refusal = self._sender_refusal(msg)
        if refusal is not None:
            _log.warning("%s: rejected %s: %s", self.guid, msg.event.value, refusal)
            return []
        source = self.state
        if not self._machine.fire(self, msg.event.value):
            _log.info(
                "%s: rejected %s from %s in state %s (event_id %s)",
                self.guid,
                msg.event.value,
                clip(msg.source),
                source.value,
                clip(msg.event_id),
            )
            return []
        self.event_ids.add(msg.event_id)
        if msg.event in (ComponentEvent.RETRY, ComponentEvent.ABANDON, ComponentEvent.HAND_OFF):
            self.robot_id = None
            self.arrive_sim_time_s = None
            self.place_sim_time_s = None
            self.verify_deadline_wall_s = None
        elif msg.robot_id:
            self.robot_id = msg.robot_id
        if msg.reason is not None:
            self.reason = msg.reason
        if msg.event in FIXED_AFTER:
            self.arrive_sim_time_s = msg.sim_time_s
        if msg.event is ComponentEvent.PLACE:
            self.attempt += 1
            self.place_sim_time_s = msg.sim_time_s
            self.place_note = msg.note
            self.verify_deadline_wall_s = self._deadline_clock(now) + self._config.verify_timeout_s
        cause = f"{msg.event.value} from {msg.source}" + (f" (task {msg.task_id})" if msg.task_id else "")
        out = [
            self._record(
                source,
                event=msg.event.value,
                cause=cause,
                sim_time_s=self._clock.now(msg.sim_time_s),
                now=now,
            )
        ]
        out.extend(self.try_verify(now))
        return out

    def observe_pose(self, msg: ComponentPoseMsg, now_wall_s: float | None = None) -> list[ComponentStateMsg]:
        """Remember the latest pose of this component; in ``verifying`` a fresh one triggers the check."""
        if msg.guid != self.guid:
            _log.warning("%s: ignored a pose of %s", self.guid, clip(msg.guid))
            return []
        if not (math.isfinite(msg.sim_time_s) and is_valid_pose(msg.pose.position_m, msg.pose.quat_xyzw)):
            _log.warning("%s: ignored an invalid pose %s at sim %r", self.guid, msg.pose, msg.sim_time_s)
            return []
        self.pose = msg.pose
        self.pose_sim_time_s = msg.sim_time_s
        self.pose_fixed = msg.fixed
        self.drift_m, self.supports, self.open_pits = msg.drift_m, tuple(msg.supports), tuple(msg.open_pits)
        self.clash_depth_m = dict(msg.clash_depth_m)
        self.fitted_target = msg.fitted_target
        shift = msg.set_against_shift_m
        self.set_against = SetAgainst(tuple(msg.set_against), shift) if msg.set_against and shift else None
        bumped_at_s = msg.bumped_at_s if msg.bumped_at_s is not None else msg.sim_time_s
        self.bumped = (msg.bumped_by, bumped_at_s) if msg.bumped_by else None
        return self.try_verify(now_wall_s)

    def use_config(self, config: AgentConfig) -> None:
        """Settings shared by the host's agents, changed (the site's tolerances became known)."""
        self._config = config

    def try_verify(self, now_wall_s: float | None = None) -> list[ComponentStateMsg]:
        """In ``verifying``: decide when a fresh pose is known or the wait timed out; else nothing."""
        if self.state is not ComponentState.VERIFYING:
            return []
        now = time.time() if now_wall_s is None else now_wall_s
        fresh = self._has_placement_pose()
        deadline_now = self._deadline_clock(now)
        timed_out = self.verify_deadline_wall_s is not None and deadline_now >= self.verify_deadline_wall_s
        if not self._config.tolerances_known and not timed_out:
            return []  # judged with the site's tolerances once physics says them (or after the timeout)
        if fresh:
            cause = f"pose at sim {self.pose_sim_time_s:.3f} s"
        elif timed_out:
            if self.pose is None:
                cause = "no pose on the bus"
            else:
                cause = (
                    f"no pose after the place event within {self._config.verify_timeout_s:g} s; "
                    f"verified the latest (sim {self.pose_sim_time_s:.3f} s)"
                )
        else:
            return []
        check = None
        if self.pose is not None:
            drift = self.drift_m if fresh else None
            target = self.fitted_target or self.component.target_pose_world
            centre = self.component.com_local_m
            check = verify(self.pose, target, self._config.tolerances, drift, reference_local_m=centre)
        stamp = self.pose_sim_time_s if fresh else None
        return [self._decide(check, cause, self._clock.now(stamp), now)]

    def _deadline_clock(self, now_wall_s: float) -> float:
        """The clock the verification timeout runs on: sim time with ``sim_deadlines``, else wall time."""
        return self._clock.sim_time_s if self._config.sim_deadlines else now_wall_s

    def _has_placement_pose(self) -> bool:
        """A pose stamped after ``place``, or a fixed pose stamped after ``arrive``."""
        if self.pose is None or self.pose_sim_time_s is None:
            return False
        if self.place_sim_time_s is not None and self.pose_sim_time_s >= self.place_sim_time_s:
            return True
        return (
            self.pose_fixed
            and self.arrive_sim_time_s is not None
            and self.pose_sim_time_s >= self.arrive_sim_time_s
        )

    # --- restart -------------------------------------------------------------------------------------------

    def restore(
        self,
        state: ComponentState,
        *,
        attempt: int,
        robot_id: str | None,
        place_sim_time_s: float | None,
        history: Iterable[ComponentStateMsg],
        event_ids: Iterable[str],
        reason: Reason | None = None,
        now_wall_s: float | None = None,
    ) -> None:
        """Resume from a journal: the last state and what led there. A resumed ``verifying`` waits anew."""
        now = time.time() if now_wall_s is None else now_wall_s
        self._machine.start(self, state)
        self.attempt = attempt
        self.robot_id = robot_id
        self.place_sim_time_s = None
        self.verify_deadline_wall_s = None
        if state is ComponentState.VERIFYING:
            self.place_sim_time_s = 0.0 if place_sim_time_s is None else place_sim_time_s
            self.verify_deadline_wall_s = self._deadline_clock(now) + self._config.verify_timeout_s
        self.history = list(history)
        self.event_ids = set(event_ids)
        self.reason = reason

    def announce(self, event: str, cause: str, now_wall_s: float | None = None) -> ComponentStateMsg:
        """The current state as a message without a transition (process start: ``start`` or ``resume``)."""
        now = time.time() if now_wall_s is None else now_wall_s
        return self._message(None, event=event, cause=cause, sim_time_s=self._clock.now(), now=now)

    # --- outputs -------------------------------------------------------------------------------------------

    def twin(self) -> TwinMsg:
        """The digital-twin record answered by the ``components/<key>/twin`` queryable."""
        target = self.component.target_pose_world
        return TwinMsg(
            guid=self.guid,
            key=self.key,
            ifc_class=self.component.ifc_class,
            name=self.component.name,
            storey=self.component.storey,
            material=self.component.material,
            mass_kg=self.component.mass_kg,
            target_pose=PoseMsg(position_m=target.position_m, quat_xyzw=target.quat_xyzw),
            current_pose=self.pose,
            current_pose_sim_time_s=self.pose_sim_time_s,
            state=self.state,
            attempt=self.attempt,
            robot_id=self.robot_id,
            history=list(self.history),
            reason=self.reason,
        )

    # --- internals -----------------------------------------------------------------------------------------

    def _decide(
        self, check: PlacementCheck | None, cause: str, sim_time_s: float, now: float
    ) -> ComponentStateMsg:
        tol = self._config.tolerances
        if check is not None and check.ok:
            verdict = Verdict.VERIFIED
            why = "within tolerances"
        else:
            verdict = Verdict.MISPLACED if self.attempt < self._config.max_attempts else Verdict.FAILED
            why = f"attempt {self.attempt} of {self._config.max_attempts}"
            if check is not None:
                why = (
                    f"out of tolerance ({tol.position_m * 1000:g} mm, {math.degrees(tol.angle_rad):g}°), "
                    + why
                )
        source = self.state
        if not self._machine.fire(self, verdict.value):  # pragma: no cover - verifying allows all three
            raise RuntimeError(f"{self.guid}: {verdict.value} refused in state {source}")
        self.verify_deadline_wall_s = None
        errors = (check.position_error_m, check.angle_error_rad) if check else (None, None)
        if check is not None:
            why += f": {check.position_error_m * 1000:.1f} mm, {math.degrees(check.angle_error_rad):.2f}°"
        miss: Reason | None = None
        if check is not None and check.unstable:
            rested = ", ".join(self.supports) or (
                f"the floor of the open pit of {', '.join(self.open_pits)}, not placed yet"
                if self.open_pits
                else "the ground or nothing"
            )
            how = (
                f"robot {self.bumped[0]} touched it at t={self.bumped[1]:.1f} s"
                if self.bumped is not None
                else "slid, tipped or fell"
            )
            clash = clash_clause(list(self.clash_depth_m.items()))
            miss = Reason(
                code=ReasonCode.UNSTABLE,
                message=f"it moved {check.drift_m or 0.0:.3f} m after it was released ({how}; tolerance "
                f"{tol.drift_m * 1000:g} mm) and came to rest on {rested}{clash}; {why}",
                robot_id=self.robot_id,
            )
        elif verdict is not Verdict.VERIFIED:
            note = f"; {self.place_note}" if self.place_note else ""
            miss = Reason(code=ReasonCode.MISPLACED, message=f"{why}; {cause}{note}", robot_id=self.robot_id)
        if verdict is Verdict.FAILED and miss is not None and miss.code is ReasonCode.UNSTABLE:
            hint = (
                clash_hint(self.guid, self.clash_depth_m)
                if self.clash_depth_m
                else BUMPED_HINT
                if self.bumped is not None
                else UNSTABLE_HINT
            )
            miss = miss.model_copy(update={"message": f"{miss.message}; {hint}"})
        elif verdict is Verdict.FAILED and miss is not None and not self.place_note:
            # (a place note already says why: the robot could not align before placing)
            hint = misplaced_hint(
                self.robot_id,
                self._config.robots.get(self.robot_id or ""),
                position_error_m=check.position_error_m if check is not None else None,
                tolerance_m=tol.position_m,
                set_against=self.set_against if self._has_placement_pose() else None,
            )
            miss = miss.model_copy(update={"message": f"{miss.message}; {hint}"})
        if verdict is Verdict.FAILED:
            self.reason = miss
        return self._record(
            source,
            event=verdict.value,
            cause=f"{why}; {cause}" if miss is None or miss.code is ReasonCode.MISPLACED else miss.message,
            sim_time_s=sim_time_s,
            now=now,
            errors=errors,
            drift_m=check.drift_m if check is not None else None,
            reason=miss,
        )

    def _record(
        self,
        source: ComponentState,
        *,
        event: str,
        cause: str,
        sim_time_s: float,
        now: float,
        errors: tuple[float | None, float | None] = (None, None),
        drift_m: float | None = None,
        reason: Reason | None = None,
    ) -> ComponentStateMsg:
        message = self._message(
            source, event=event, cause=cause, sim_time_s=sim_time_s, now=now, errors=errors
        )
        if drift_m is not None or reason is not None:  # a verdict: its drift, and why it missed
            message = message.model_copy(update={"drift_m": drift_m, "reason": reason or message.reason})
        self.history.append(message)
        _log.debug("%s: %s → %s (%s; %s)", self.guid, source.value, self.state.value, event, cause)
        return message

    def _message(
        self,
        previous: ComponentState | None,
        *,
        event: str,
        cause: str,
        sim_time_s: float,
        now: float,
        errors: tuple[float | None, float | None] = (None, None),
    ) -> ComponentStateMsg:
        return ComponentStateMsg(
            guid=self.guid,
            state=self.state,
            previous=previous,
            event=event,
            cause=cause,
            attempt=self.attempt,
            robot_id=self.robot_id,
            sim_time_s=sim_time_s,
            wall_time_s=now,
            position_error_m=errors[0],
            angle_error_rad=errors[1],
            reason=self.reason,
        )
