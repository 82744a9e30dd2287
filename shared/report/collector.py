"""The construction report: a run's messages collected into per-component and per-robot timelines.

:class:`ReportCollector` is fed every message the observer receives (in arrival order) and builds the
``report.json`` dictionary with :meth:`ReportCollector.report`. Pure: no bus, no files. All times are sim
time (``*_s``, seconds on the physics clock), distances in metres.

Per component (state changes of its agent; start-up announcements carry no times):
``released_s`` (first release), ``picked_s`` (first ``picking``), ``placed_s`` (the last ``place``, i.e.
entering ``verifying``), ``constructed_s``, ``failed_s``, ``retries`` (misplacements, at ``misplaced_s``),
``give_backs`` (why a robot gave the task back, each time), ``handed_off_s`` (when a ground robot put it
down at a crane's staging spot, each hand-off), ``attempts``, the robots that handled it, its final
state, its position in the planned sequence and the placement error of its last verdict
(``position_error_mm``, ``angle_error_deg``, as its agent measured them against the BIM pose);
``placements``, every verified attempt in order (robot and its type, errors, drift after release, verdict
and cause), and ``max_drift_mm`` (:mod:`.placements`); how it was built: ``method`` and why,
``resources`` (the robot types that worked on it), the times of its formwork, pour or laying and a cast
component's ``curing`` (:mod:`.methods`); ``connections`` (neighbour → kind) and
``temporary_supports`` (:mod:`.connections`); ``cleared_away``, a failed body carried out of the
robots' way (who, when, how long) or why it was not (:mod:`.clear_aways`).

Per robot: ``type`` (its robot type, from physics' site info, ``SiteInfoMsg``; robots on site that never
reported are listed too), ``busy_s``, ``tasks`` (``build``, or ``hand_off``: a ground robot carried it to
a crane's staging spot), ``distance_m``, ``built`` (its placements judged constructed), ``given_back`` (the
give-backs that name it) and ``walled_in`` (:mod:`.robots`). ``totals.walled_in`` lists the robots that
were walled in at some time.

:func:`twin_messages` turns a component's twin (its agent's answer to ``components/<key>/twin``) back into
the state changes it went through, for an observer that joined a run late;
:meth:`ReportCollector.replace_from_twin` rebuilds a component's timeline from its twin alone (the run
trusts a twin over any state message, :mod:`bimbot.shared.trusted_states`).

Totals: components by final state, retries, makespan (first release → last constructed), busy time,
distance, robot utilisation (busy time within the makespan / (robots × makespan)), ``by_type`` (per robot
type: robots, busy time, build and hand-off tasks, utilisation), the number of hand-off tasks, the largest
placement errors of the constructed components; ``placement_error_mm_by_type`` (the distribution of every
attempt's position error per robot type; work in place, built at its target by physics, is left out),
``retries_by_cause`` and ``max_drift_mm``; ``by_method`` and ``work_in_place_verdicts``. The elements
split into panels (``panelised``) and built into their hosts (``with_host``) are listed.

Reasons: every component that is not constructed gets a ``reason`` object (``code``, ``message``,
``guid``, ``robot_id``; :class:`bimbot.shared.reasons.Reason`). A failed or blocked component has its own
(from its agent's state message, else the planner's ``ProgressMsg.reasons``). Any other (planned, or
still in progress) was not built because the run ended first: it gets the code and sentence of the run's
:class:`RunEnding` (``interrupted`` by a signal or the time limit, ``stalled`` by the watchdog), with its
state and its last give-back reason. The ending itself is ``report["ending"]``; a report written while
the run goes on (or by an observer that stops before the end) says so with the default ending.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from pydantic import BaseModel

from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import (
    ComponentEvent,
    ComponentPoseMsg,
    ComponentState,
    ComponentStateMsg,
    OdomMsg,
    ProgressMsg,
    RobotPoseMsg,
    RobotStateMsg,
    SensorsMsg,
    SiteInfoMsg,
    TaskKind,
    TaskMsg,
    TwinMsg,
)
from bimbot.shared.reasons import Reason, ReasonCode

from .clear_aways import ClearSeen, clear_entry, clear_totals, take_clear, with_clear_note
from .connections import SupportsSeen
from .fleet import by_type, working_within_s
from .methods import (
    CuringSeen,
    WorkTimes,
    curing_entry,
    hand_placed,
    methods_count,
    panelised_elements,
    take_curing,
    with_host_elements,
    work_fields,
)
from .placements import (
    PLACEMENT_REASON_CODES,
    Placement,
    max_or_none,
    placement_entry,
    placement_of,
    placement_totals,
)
from .robots import RobotTimeline, robot_entry, tasks_by_end
from .totals import count_reasons, difference, dump_reason, makespan_window, scaled, totals_of

REPORT_SCHEMA_VERSION = 1
_OWN_REASON_STATES = (ComponentState.FAILED, ComponentState.BLOCKED)
MAX_REASON_CHARS = 2000  # Reason.message's bound


@dataclass(frozen=True)
class RunEnding:
    """How a run ended: ``how`` (``done``, ``stalled``, ``interrupted``, ``timeout``, ``service_stopped``,
    ``running``), the reason code and sentence given to every component it left unbuilt without a reason
    of its own, and detail lines (what each robot and open task was doing)."""

    how: str
    code: ReasonCode | None  # None: the run ended as it should (done), nothing left unbuilt because of it
    message: str
    details: tuple[str, ...] = ()

    def as_dict(self) -> dict[str, Any]:
        return {
            "how": self.how,
            "code": self.code.value if self.code is not None else None,
            "message": self.message,
            "details": list(self.details),
        }


UNFINISHED = RunEnding("running", ReasonCode.INTERRUPTED, "the report was written before the run ended")
PLANNER_DONE = RunEnding("done", None, "the planner reported every task settled")


@dataclass
class ComponentTimeline:
    released_s: float | None = None
    picked_s: float | None = None
    placed_s: float | None = None
    constructed_s: float | None = None
    failed_s: float | None = None
    retries: int = 0
    misplaced_s: list[float] = field(default_factory=list)
    handed_off_s: list[float] = field(default_factory=list)  # put down at a crane's staging spot, each time
    give_backs: list[str] = field(default_factory=list)  # why a robot gave it back, each time
    given_back_by: list[str | None] = field(default_factory=list)  # which robot, each time (None: unknown)
    attempts: int = 0
    state: ComponentState = ComponentState.PLANNED
    position_error_m: float | None = None  # of the last verdict (constructed or misplaced)
    angle_error_rad: float | None = None
    robot_ids: list[str] = field(default_factory=list)
    last_s: float = 0.0  # latest sim time seen for this component
    reason: Reason | None = None  # failed/blocked: why (from its agent)
    last_give_back: Reason | None = None  # the latest reason a robot gave its task back for
    placements: list[Placement] = field(default_factory=list)  # every verdict, in order
    work: WorkTimes = field(default_factory=WorkTimes)  # forming, pouring, laying (:mod:`.methods`)


def twin_messages(twin: TwinMsg) -> list[ComponentStateMsg | ComponentPoseMsg]:
    """A twin's history (the state messages its agent published, each with its robot, placement error
    and reason) and its current pose (if any)."""
    messages: list[ComponentStateMsg | ComponentPoseMsg] = list(twin.history)
    if twin.current_pose is not None and twin.current_pose_sim_time_s is not None:
        fixed = twin.state == ComponentState.CONSTRUCTED
        pose = ComponentPoseMsg(
            guid=twin.guid, pose=twin.current_pose, sim_time_s=twin.current_pose_sim_time_s, fixed=fixed
        )
        messages.append(pose)
    return messages


class ReportCollector:
    """Collects timelines from messages; :meth:`report` may be called any number of times."""

    def __init__(self, manifest: Manifest, sequence_guids: list[str] | None = None) -> None:
        self.manifest = manifest
        self.sequence_guids = list(sequence_guids or [])
        self.components: dict[str, ComponentTimeline] = {
            c.guid: ComponentTimeline() for c in manifest.components
        }
        self.robots: dict[str, RobotTimeline] = {}
        self.robot_type_of: dict[str, str] = {}  # robot id → type name (physics' site info)
        self.fidelity: str | None = None  # physics' site info says it (bimbot run's settings say more)
        self.task_kinds: dict[str, TaskKind] = {}
        self.put_downs: dict[str, tuple[float, float]] = {}  # hand-off task id → where the load went down
        self.clears: dict[str, ClearSeen] = {}  # failed GUID → its clear-away out of the robots' way
        self.progress: ProgressMsg | None = None
        self.curing: dict[str, CuringSeen] = {}  # cast GUID → the planner's curing holds on it, as seen
        self.supports = SupportsSeen()  # connections made and temporary supports, from physics' poses
        self.last_sim_time_s = 0.0
        self.messages = 0
        self.min_separation_m = math.inf  # between two robots at one sim time (ground truth)
        self._robot_at: dict[str, tuple[float, float, float]] = {}  # robot → (x, y, sim s) last seen

    # --- input ---

    def add(self, message: BaseModel) -> None:
        """Take any bus message; the ones the report does not use are ignored."""
        self.messages += 1
        sim_time_s = getattr(message, "sim_time_s", None)
        if isinstance(sim_time_s, float):
            self.last_sim_time_s = max(self.last_sim_time_s, sim_time_s)
        if isinstance(message, ComponentStateMsg):
            self._component_state(message)
        elif isinstance(message, ComponentPoseMsg):
            self.supports.take(message)
        elif isinstance(message, RobotStateMsg):
            self._robot(message.robot_id).take_state(message)
        elif isinstance(message, RobotPoseMsg):
            self._robot(message.robot_id).travel("ground_truth", message.pose_xy_yaw)
            self._separation(message)
        elif isinstance(message, SensorsMsg):
            self._robot(message.robot_id).travel("odom", message.odom.pose_xy_yaw)
        elif isinstance(message, OdomMsg):
            self._robot(message.robot_id).travel("odom", message.pose_xy_yaw)
        elif isinstance(message, TaskMsg):
            self.task_kinds[message.task_id] = message.kind
            if message.put_down_xy_m is not None:
                self.put_downs[message.task_id] = (message.put_down_xy_m[0], message.put_down_xy_m[1])
            take_clear(self.clears, message)
        elif isinstance(message, SiteInfoMsg):
            self.robot_type_of.update(message.robot_type_of)
            self.fidelity = message.fidelity or self.fidelity
            for robot_id in message.robot_ids:
                self.robots.setdefault(robot_id, RobotTimeline())
        elif isinstance(message, ProgressMsg):
            take_curing(self.curing, message)  # every hold, though the latest progress has none left
            if self.progress is None or message.sim_time_s >= self.progress.sim_time_s:
                self.progress = message

    def replace_from_twin(self, twin: TwinMsg) -> None:
        """Rebuild a component's timeline from its twin alone (its agent's own record): what the bus said
        of it before is dropped, so a forged state message leaves no trace in the report."""
        if twin.guid not in self.components:
            return
        self.components[twin.guid] = ComponentTimeline()
        for message in twin.history:
            self.add(message)
        timeline = self.components[twin.guid]
        timeline.state = twin.state
        if twin.state in _OWN_REASON_STATES and twin.reason is not None:
            timeline.reason = twin.reason

    def _component_state(self, msg: ComponentStateMsg) -> None:
        timeline = self.components.setdefault(msg.guid, ComponentTimeline())
        timeline.state = msg.state
        timeline.attempts = max(timeline.attempts, msg.attempt)
        if msg.robot_id and msg.robot_id not in timeline.robot_ids:
            timeline.robot_ids.append(msg.robot_id)
        if msg.reason is not None:
            if msg.state in _OWN_REASON_STATES:
                timeline.reason = msg.reason
            elif msg.reason.code not in PLACEMENT_REASON_CODES:  # a verdict's cause is not a give-back
                timeline.last_give_back = msg.reason
        # Senders stamp sim time from their own view of the clock (a verdict may be stamped a little
        # before the placement it judges): a component's times never go backwards.
        t = timeline.last_s = max(msg.sim_time_s, timeline.last_s)
        if msg.previous is None:  # an announcement (agent start or resume), not a transition
            return
        timeline.work.take(msg, t)
        if msg.position_error_m is not None:
            timeline.position_error_m, timeline.angle_error_rad = msg.position_error_m, msg.angle_error_rad
        placement = placement_of(msg)
        if placement is not None and placement not in timeline.placements:  # a verdict heard twice: once
            timeline.placements.append(placement)
        if msg.state == ComponentState.RELEASED and msg.event == ComponentEvent.ABANDON:
            timeline.give_backs.append(msg.reason.line() if msg.reason is not None else "given back")
            timeline.given_back_by.append(msg.robot_id or (msg.reason.robot_id if msg.reason else None))
        if msg.state == ComponentState.RELEASED and msg.event == ComponentEvent.HAND_OFF:
            timeline.handed_off_s.append(t)
        if msg.state == ComponentState.RELEASED and timeline.released_s is None:
            timeline.released_s = t
        elif msg.state == ComponentState.PICKING and timeline.picked_s is None:
            timeline.picked_s = t
        elif msg.state == ComponentState.VERIFYING:
            timeline.placed_s = t
        elif msg.state == ComponentState.CONSTRUCTED:
            timeline.constructed_s = t
            if timeline.placed_s is None:  # verified at once, without a separate verifying message
                timeline.placed_s = t
        elif msg.state == ComponentState.MISPLACED:
            timeline.retries += 1
            timeline.misplaced_s.append(t)
        elif msg.state == ComponentState.FAILED:
            timeline.failed_s = t

    def _robot(self, robot_id: str) -> RobotTimeline:
        return self.robots.setdefault(robot_id, RobotTimeline())

    def _separation(self, msg: RobotPoseMsg) -> None:
        """The smallest ground-truth distance between two robots' base frames at one sim time (how close
        the traffic rules let them come; a metric, never used for control)."""
        x, y, _ = msg.pose_xy_yaw
        self._robot_at[msg.robot_id] = (x, y, msg.sim_time_s)
        for other, (ox, oy, at_s) in self._robot_at.items():
            if other != msg.robot_id and at_s == msg.sim_time_s:
                self.min_separation_m = min(self.min_separation_m, math.hypot(ox - x, oy - y))

    # --- output ---

    def report(self, ending: RunEnding = UNFINISHED) -> dict[str, Any]:
        """The report dictionary (``report.json``); ``ending`` says how the run ended (see the module;
        without one, the planner's last progress says whether it was done)."""
        if ending is UNFINISHED and self.progress is not None and self.progress.done:
            ending = PLANNER_DONE
        end_s = self.last_sim_time_s
        order = {guid: index for index, guid in enumerate(self.sequence_guids)}
        components = []
        for component in self.manifest.components:
            timeline = self.components[component.guid]
            cycle = difference(timeline.constructed_s, timeline.released_s)
            placements = [
                placement_entry(p, self.robot_type_of.get(p.robot_id or "")) for p in timeline.placements
            ]
            components.append(
                {
                    "guid": component.guid,
                    "name": component.name,
                    "ifc_class": component.ifc_class,
                    "method": component.method.value,
                    "method_source": component.method_source.value,
                    "method_note": component.method_note,
                    "parent_guid": component.parent_guid,
                    "guests": [guest.guid for guest in component.guests],
                    "resources": sorted(
                        {self.robot_type_of[r] for r in timeline.robot_ids if r in self.robot_type_of}
                    ),
                    "sequence_index": order.get(component.guid),
                    "state": timeline.state.value,
                    "released_s": timeline.released_s,
                    "picked_s": timeline.picked_s,
                    "placed_s": timeline.placed_s,
                    "constructed_s": timeline.constructed_s,
                    "failed_s": timeline.failed_s,
                    "cycle_time_s": cycle,
                    "retries": timeline.retries,
                    "give_backs": list(timeline.give_backs),
                    "given_back_by": list(timeline.given_back_by),
                    "misplaced_s": list(timeline.misplaced_s),
                    "handed_off_s": list(timeline.handed_off_s),
                    "attempts": timeline.attempts,
                    "robot_ids": list(timeline.robot_ids),
                    "position_error_mm": scaled(timeline.position_error_m, 1000.0),
                    "angle_error_deg": scaled(timeline.angle_error_rad, 180.0 / math.pi),
                    "reason": dump_reason(self._reason(component.guid, timeline, ending)),
                    "cleared_away": clear_entry(self.clears.get(component.guid)),
                    "placements": placements,
                    "max_drift_mm": max_or_none(p["drift_mm"] for p in placements),
                    **work_fields(
                        timeline.work,
                        curing_entry(component, timeline.constructed_s, self.curing.get(component.guid)),
                    ),
                    **self.supports.entry(component.guid, end_s),
                }
            )
        built, given_back = tasks_by_end(components)
        robots = {
            robot_id: robot_entry(
                robot,
                self.robot_type_of.get(robot_id),
                self.task_kinds,
                self.put_downs,
                end_s,
                built=built.get(robot_id, 0),
                given_back=given_back.get(robot_id, 0),
            )
            for robot_id, robot in sorted(self.robots.items())
        }
        totals = totals_of(components, robots)
        totals["walled_in"] = [robot_id for robot_id, robot in robots.items() if robot["walled_in"]]
        window = makespan_window(components)
        totals["by_type"] = by_type(robots, window)
        totals["working_s"] = working_within_s(robots.values(), window) if window is not None else None
        totals["hand_off_tasks"] = sum(entry["hand_off_tasks"] for entry in totals["by_type"].values())
        totals["blocked"] = len(self.progress.blocked) if self.progress else 0
        totals["done"] = bool(self.progress and self.progress.done)
        totals["not_constructed"] = totals["components"] - totals["constructed"]
        totals["by_reason"] = count_reasons(components)
        # work in place is verified like a placement, but no hand set it down (:mod:`.methods`)
        placed_by_hand = [component for component in components if hand_placed(component)]
        totals.update(placement_totals(placed_by_hand, list(totals["by_type"])))
        totals["work_in_place_verdicts"] = sum(
            len(component["placements"]) for component in components if not hand_placed(component)
        )
        separation = self.min_separation_m
        totals["min_robot_separation_m"] = None if math.isinf(separation) else separation
        totals["in_place"] = len(self.manifest.in_place)
        totals["by_method"] = methods_count(components, self.manifest)
        totals.update(self.supports.totals(end_s))
        totals.update(clear_totals(self.clears))
        elements = panelised_elements(self.manifest, components)
        return {
            "schema_version": REPORT_SCHEMA_VERSION,
            "site": self.manifest.site,
            "sim_time_s": end_s,
            "ending": ending.as_dict(),
            "progress": self.progress.model_dump(mode="json") if self.progress else None,
            "totals": totals,
            "components": components,
            # in place before the run (existing work, --in-place): not built by the robots, not in the totals
            "in_place": [
                {"guid": c.guid, "name": c.name, "ifc_class": c.ifc_class, "method": "in_place"}
                for c in self.manifest.in_place
            ],
            # elements split into precast panels: each built when all its panels are; the joints between
            "panelised": elements,
            # built into their hosts (anchor bolts cast into a footing, a base plate welded to its column)
            "with_host": with_host_elements(self.manifest, components),
            "robots": robots,
            # what made it, as far as the bus says (bimbot run replaces it with its own settings)
            "settings": {"fidelity": self.fidelity} if self.fidelity else {},
        }

    def _reason(self, guid: str, timeline: ComponentTimeline, ending: RunEnding) -> Reason | None:
        """Why ``guid`` is not constructed (None when it is): its own reason when it failed or is
        blocked, else the run's ending, with its state and its last give-back."""
        if timeline.state == ComponentState.CONSTRUCTED:
            return None
        planner_reason = self.progress.reasons.get(guid) if self.progress is not None else None
        if timeline.state in _OWN_REASON_STATES:
            own = timeline.reason or planner_reason
            if own is not None:
                return with_clear_note(own, self.clears.get(guid), MAX_REASON_CHARS)
            if timeline.state == ComponentState.FAILED and timeline.retries:
                return Reason(
                    code=ReasonCode.MISPLACED,
                    message=f"failed after {timeline.attempts} placement attempt(s) out of tolerance",
                )
        robot_id = timeline.robot_ids[-1] if timeline.robot_ids else None
        state = f"it was {timeline.state.value}"
        if timeline.state not in (ComponentState.PLANNED, *_OWN_REASON_STATES) and robot_id:
            state += f" (robot {robot_id})"
        if timeline.last_give_back is not None:
            state += f"; last given back: {timeline.last_give_back.line()}"
        message = f"{ending.message}; {state}"[:MAX_REASON_CHARS]
        return Reason(code=ending.code or ReasonCode.INTERRUPTED, message=message, robot_id=robot_id)
