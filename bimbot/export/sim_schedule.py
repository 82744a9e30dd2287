"""The simulated schedule of a run: one task per component with its method's steps, in sim time.

Pure: the manifest, the run's report (``report.json`` as a dict), the agents' journal (each component's
state entries in order) and the plan (order, precedences, task ids and names) in; a :class:`SimSchedule`
out, which every writer of :mod:`bimbot.export` reads. All times are sim seconds from the run's start.

A component's task spans its work: from the first state a robot or crew worked on it in (picking, or
whatever its method's first state is) to constructed, failed, or the last state it reached. Its steps
come from its construction method (:mod:`bimbot.shared.construction_methods`):

* ``lifted`` / ``panelised``: pick (picking → transporting), carry (→ the last assembling), place (→ the
  last verifying), connect (→ constructed), from the journal's state entries;
* ``cast_in_place``: formwork (forming → pouring), pour (→ verifying), cure (from constructed, for
  ``Component.cast.cure_s``: what rests on it waits for it, so the task ends there); without those states in
  the journal, the durations of ``Component.cast`` fitted into the task's span;
* ``laid``: lay (laying → constructed);
* ``driven``: drive (driving → constructed).

A component the run never started has no times (a task without dates); one without a journal has no steps.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from bimbot.shared.construction_methods import ConstructionMethod
from bimbot.shared.manifest import Component, Manifest

LIFTED_STEPS = ("pick", "carry", "place", "connect")
CAST_STEPS = ("formwork", "pour", "cure")
LAID_STEPS = ("lay",)
WORK_STATES = frozenset(
    {
        "picking",
        "transporting",
        "assembling",
        "forming",
        "pouring",
        "laying",
        "driving",
        "verifying",
        "misplaced",
    }
)
END_STATES = frozenset({"constructed", "failed"})

StateEntries = Sequence[tuple[str, float]]
"""A component's journal: (state entered, sim time s), in order."""


@dataclass(frozen=True)
class Step:
    """One step of a component's work (pick, carry, …), sim seconds."""

    name: str
    start_s: float
    finish_s: float


@dataclass(frozen=True)
class ComponentWork:
    """One component's task in the simulated schedule, with its as-built results."""

    guid: str
    name: str
    ifc_class: str
    method: ConstructionMethod
    task_id: str
    task_name: str
    state: str  # final state in the run
    start_s: float | None  # None: never started
    finish_s: float | None
    steps: tuple[Step, ...]
    robot_ids: tuple[str, ...]
    predecessors: tuple[str, ...]  # GUIDs the planner made it wait for
    attempts: int
    final_position_error_mm: float | None
    final_angle_error_deg: float | None
    reason: str | None  # why it was not built: "code: sentence"
    parent_guid: str | None  # a panel: the element it was cut from

    @property
    def timed(self) -> bool:
        return self.start_s is not None and self.finish_s is not None


@dataclass(frozen=True)
class SimSchedule:
    """A run's simulated schedule: components in plan order, the robots on site and their types."""

    site: str
    name: str
    components: tuple[ComponentWork, ...]
    robot_types: Mapping[str, str]  # robot id → type name
    end_s: float

    def component(self, guid: str) -> ComponentWork:
        for work in self.components:
            if work.guid == guid:
                return work
        raise KeyError(guid)


@dataclass(frozen=True)
class PlanView:
    """What the exporter needs of the planner's plan (:class:`bimbot.services.planner.sources.Plan`)."""

    order: tuple[str, ...]
    predecessors: Mapping[str, frozenset[str]]
    task_ids: Mapping[str, str]
    names: Mapping[str, str]


def sim_schedule(
    manifest: Manifest,
    report: Mapping[str, Any],
    journal: Mapping[str, StateEntries],
    plan: PlanView,
) -> SimSchedule:
    """The simulated schedule of one run (see the module docstring)."""
    entries = {entry["guid"]: entry for entry in report.get("components", [])}
    by_guid = {component.guid: component for component in manifest.components}
    order = [guid for guid in plan.order if guid in by_guid]
    order += [component.guid for component in manifest.components if component.guid not in set(order)]
    works = tuple(
        _work(by_guid[guid], entries.get(guid, {}), journal.get(guid, ()), plan, index)
        for index, guid in enumerate(order, start=1)
    )
    robots = report.get("robots", {}) or {}
    robot_types = {robot_id: str(robot.get("type") or "robot") for robot_id, robot in sorted(robots.items())}
    for work in works:
        for robot_id in work.robot_ids:
            robot_types.setdefault(robot_id, "robot")
    finishes = [work.finish_s for work in works if work.finish_s is not None]
    end_s = max([float(report.get("sim_time_s") or 0.0), *finishes])
    return SimSchedule(
        site=manifest.site,
        name=manifest.site_name or manifest.site,
        components=works,
        robot_types=robot_types,
        end_s=end_s,
    )


def _work(
    component: Component, entry: Mapping[str, Any], states: StateEntries, plan: PlanView, index: int
) -> ComponentWork:
    start_s, finish_s = _span(entry, states)
    steps = method_steps(component, states, start_s, finish_s)
    if steps and finish_s is not None:
        finish_s = max(finish_s, steps[-1].finish_s)  # a cast component's task ends when it has cured
    reason = entry.get("reason")
    return ComponentWork(
        guid=component.guid,
        name=component.name or component.ifc_class,
        ifc_class=component.ifc_class,
        method=component.method,
        task_id=plan.task_ids.get(component.guid) or f"T{index:04d}",
        task_name=plan.names.get(component.guid) or f"Erect {component.name or component.ifc_class}",
        state=str(entry.get("state") or (states[-1][0] if states else "planned")),
        start_s=start_s,
        finish_s=finish_s,
        steps=steps,
        robot_ids=tuple(entry.get("robot_ids") or ()),
        predecessors=tuple(sorted(plan.predecessors.get(component.guid, frozenset()))),
        attempts=int(entry.get("attempts") or 0),
        final_position_error_mm=entry.get("final_position_error_mm"),
        final_angle_error_deg=entry.get("final_angle_error_deg"),
        reason=f"{reason.get('code')}: {reason.get('message')}" if isinstance(reason, Mapping) else None,
        parent_guid=component.parent_guid,
    )


def _span(entry: Mapping[str, Any], states: StateEntries) -> tuple[float | None, float | None]:
    """(start, finish) of a component's work: the journal first, the report's times where it has none."""
    worked = [time_s for state, time_s in states if state in WORK_STATES]
    start_s = min(worked) if worked else entry.get("picked_s")
    ended = [time_s for state, time_s in states if state in END_STATES]
    finish_s = ended[-1] if ended else entry.get("constructed_s") or entry.get("failed_s")
    if start_s is None:
        return None, None
    if finish_s is None:  # started, never finished: until the last state it reached
        finish_s = max([time_s for _, time_s in states] or [start_s])
    return float(start_s), max(float(finish_s), float(start_s))


def method_steps(
    component: Component, states: StateEntries, start_s: float | None, finish_s: float | None
) -> tuple[Step, ...]:
    """The steps of ``component``'s work in its task's span (empty when the run did not time it)."""
    if start_s is None or finish_s is None:
        return ()
    if component.method is ConstructionMethod.CAST_IN_PLACE and component.cast is not None:
        cast = component.cast
        marks = _marks(states, ("forming", "pouring"), ("verifying",), finish_s)
        if marks is None:
            return _fitted(CAST_STEPS, (cast.formwork_s, cast.pour_s, cast.cure_s), start_s, finish_s)
        formed, poured, placed = marks
        built = next((time_s for state, time_s in states if state == "constructed"), None)
        steps = [Step("formwork", formed, poured), Step("pour", poured, placed)]
        return (*steps, Step("cure", built, built + cast.cure_s)) if built is not None else tuple(steps)
    if component.method is ConstructionMethod.LAID:
        laying = next((time_s for state, time_s in states if state == "laying"), start_s)
        return (Step("lay", laying, max(finish_s, laying)),)
    if component.method is ConstructionMethod.DRIVEN:
        driving = next((time_s for state, time_s in states if state == "driving"), start_s)
        return (Step("drive", driving, max(finish_s, driving)),)
    return _lifted_steps(states, finish_s)


def _marks(
    states: StateEntries, firsts: Sequence[str], lasts: Sequence[str], finish_s: float
) -> tuple[float, ...] | None:
    """The first entry of each of ``firsts`` and the last of each of ``lasts`` (else ``finish_s``); None
    when a state of ``firsts`` was never entered."""
    marks: list[float] = []
    for state in firsts:
        found = next((time_s for name, time_s in states if name == state), None)
        if found is None:
            return None
        marks.append(found)
    for state in lasts:
        marks.append(next((time_s for name, time_s in reversed(states) if name == state), finish_s))
    return tuple(marks)


def _fitted(
    names: Sequence[str], durations_s: Sequence[float], start_s: float, finish_s: float
) -> tuple[Step, ...]:
    """Steps one after the other from ``start_s``, scaled to end at ``finish_s`` when the span is longer
    than zero (the durations' proportions kept), else at their own durations."""
    total_s = sum(durations_s)
    scale = (finish_s - start_s) / total_s if total_s > 0 and finish_s > start_s else 1.0
    steps, time_s = [], start_s
    for name, duration_s in zip(names, durations_s, strict=True):
        steps.append(Step(name, time_s, time_s + duration_s * scale))
        time_s += duration_s * scale
    return tuple(steps)


def _lifted_steps(states: StateEntries, finish_s: float) -> tuple[Step, ...]:
    """pick, carry, place, connect from the state entries (retries: from the first pick to the last place)."""

    def first(state: str) -> float | None:
        return next((time_s for name, time_s in states if name == state), None)

    def last(state: str) -> float | None:
        return next((time_s for name, time_s in reversed(states) if name == state), None)

    marks = [first("picking"), first("transporting"), last("assembling"), last("verifying"), finish_s]
    steps: list[Step] = []
    for name, start_s, end_s in zip(LIFTED_STEPS, marks, marks[1:], strict=False):
        if start_s is None:
            break
        steps.append(Step(name, start_s, max(end_s if end_s is not None else finish_s, start_s)))
        if end_s is None:  # the work stopped in this step
            break
    return tuple(steps)
