"""How the report tells what each component's construction method did: counts by method, the elements split
into panels (built when all their panels are, with the joints between them), the elements built into
their hosts (constructed with them), and the work in place. Pure, over the report's component entries
(:mod:`.collector`) and the messages it is fed.

Work in place: a footing cast in place takes hours of formwork and a pour, then days of curing in which
nothing may rest on it; a wall is laid course by course. Per component:

* ``forming_s``, ``pouring_s``, ``laying_s``: when its agent last entered ``forming``, ``pouring`` or
  ``laying`` (the attempt that went on to ``verifying``), so the formwork runs from ``forming_s`` to
  ``pouring_s``, the pour from ``pouring_s`` to ``placed_s``, the laying from ``laying_s`` to ``placed_s``;
* ``curing``: a cast component once constructed: ``from_s`` (constructed), ``until_s`` and its
  ``source``: the planner's curing holds when it held something on it (``holds``: what it held), else
  ``manifest`` (constructed + ``cast.cure_s``: nothing rested on it, it cured all the same).

Work in place is verified like a placement, but physics built it at its target, no hand set it down:
:func:`hand_placed` keeps it out of the placement statistics.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from bimbot.shared.construction_methods import ConstructionMethod
from bimbot.shared.manifest import Component, Manifest
from bimbot.shared.messages import ComponentState, ComponentStateMsg, ProgressMsg
from bimbot.shared.work_methods import BUILT_IN_PLACE

from .durations import duration_text
from .fleet import working_within_s

CONSTRUCTED = ComponentState.CONSTRUCTED.value
WORK_IN_PLACE = tuple(method.value for method in BUILT_IN_PLACE)
WORK_STATES = {  # state entered → the report's field of its time
    ComponentState.FORMING: "forming_s",
    ComponentState.POURING: "pouring_s",
    ComponentState.LAYING: "laying_s",
    ComponentState.DRIVING: "driving_s",
}


def methods_count(components: list[dict[str, Any]], manifest: Manifest) -> dict[str, dict[str, int]]:
    """Per method: how many components it has and how many were constructed (guests and in-place work
    counted apart, under ``with_host`` and ``in_place``)."""
    total: Counter[str] = Counter(c["method"] for c in components)
    built: Counter[str] = Counter(c["method"] for c in components if c["state"] == CONSTRUCTED)
    states = {c["guid"]: c["state"] for c in components}
    for component in manifest.components:
        for _ in component.guests:
            total[ConstructionMethod.WITH_HOST.value] += 1
            built[ConstructionMethod.WITH_HOST.value] += int(states.get(component.guid) == CONSTRUCTED)
    if manifest.in_place:
        total[ConstructionMethod.IN_PLACE.value] += len(manifest.in_place)
        built[ConstructionMethod.IN_PLACE.value] += len(manifest.in_place)
    return {method: {"components": total[method], "constructed": built[method]} for method in sorted(total)}


def panelised_elements(manifest: Manifest, components: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Each element split into panels or bays: constructed once every part is, when the last one was."""
    by_guid = {c["guid"]: c for c in components}
    elements = []
    for element in manifest.panelised:
        panels = [by_guid[guid] for guid in element.panel_guids if guid in by_guid]
        done = len(panels) == len(element.panel_guids) and all(p["state"] == CONSTRUCTED for p in panels)
        elements.append(
            {
                "guid": element.guid,
                "name": element.name,
                "ifc_class": element.ifc_class,
                "method": element.method.value,
                "mass_kg": element.mass_kg,
                "panels": list(element.panel_guids),
                "panels_constructed": sum(p["state"] == CONSTRUCTED for p in panels),
                "constructed": done,
                "constructed_s": max(p["constructed_s"] for p in panels) if done and panels else None,
                "joints": [joint.model_dump(mode="json") for joint in element.joints],
                "why": element.why,
            }
        )
    return elements


def with_host_elements(manifest: Manifest, components: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Each element built into its host, constructed with it."""
    by_guid = {c["guid"]: c for c in components}
    guests = []
    for host in manifest.components:
        entry = by_guid.get(host.guid, {})
        for guest in host.guests:
            guests.append(
                {
                    "guid": guest.guid,
                    "name": guest.name,
                    "ifc_class": guest.ifc_class,
                    "method": ConstructionMethod.WITH_HOST.value,
                    "host_guid": host.guid,
                    "relation": guest.relation,
                    "constructed": entry.get("state") == CONSTRUCTED,
                    "constructed_s": entry.get("constructed_s"),
                }
            )
    return guests


# --- work in place -------------------------------------------------------------------------------------


@dataclass
class WorkTimes:
    """A component's work in place: when its agent last entered each working state (sim s)."""

    forming_s: float | None = None
    pouring_s: float | None = None
    laying_s: float | None = None
    driving_s: float | None = None

    def take(self, msg: ComponentStateMsg, at_s: float) -> None:
        """A state change (``at_s``: its time as the report keeps it, never going backwards)."""
        name = WORK_STATES.get(msg.state)
        if name is not None and msg.previous is not None:
            setattr(self, name, at_s)


@dataclass
class CuringSeen:
    """What the planner's progress said of one cast component's curing: until when, and what it held."""

    until_s: float
    holds: list[str]


def take_curing(seen: dict[str, CuringSeen], progress: ProgressMsg) -> None:
    """Remember every curing hold of ``progress`` (a hold leaves the progress once it has ended)."""
    for hold in progress.curing:
        entry = seen.setdefault(hold.cast_guid, CuringSeen(hold.until_s, []))
        entry.until_s = max(entry.until_s, hold.until_s)
        if hold.guid not in entry.holds:
            entry.holds.append(hold.guid)


def curing_entry(
    component: Component, constructed_s: float | None, seen: CuringSeen | None
) -> dict[str, Any] | None:
    """A cast component's curing once constructed (see the module), else None."""
    if component.method is not ConstructionMethod.CAST_IN_PLACE or constructed_s is None:
        return None
    if seen is not None:
        return {"from_s": constructed_s, "until_s": seen.until_s, "source": "planner", "holds": seen.holds}
    cure_s = component.cast.cure_s if component.cast is not None else 0.0
    if cure_s <= 0.0:
        return None
    return {"from_s": constructed_s, "until_s": constructed_s + cure_s, "source": "manifest", "holds": []}


def work_fields(work: WorkTimes, curing: dict[str, Any] | None) -> dict[str, Any]:
    """A component's work in place in ``report.json`` (see the module)."""
    return {
        "forming_s": work.forming_s,
        "pouring_s": work.pouring_s,
        "laying_s": work.laying_s,
        "driving_s": work.driving_s,
        "curing": curing,
    }


def hand_placed(component: Mapping[str, Any]) -> bool:
    """Whether a report component was set down by a hand (lifted, a panel): not built in place."""
    return component.get("method") not in WORK_IN_PLACE


def method_word(method: str) -> str:
    """``cast in place`` for ``cast_in_place``: a method as a person writes it."""
    return method.replace("_", " ")


def curing_line(report: Mapping[str, Any]) -> str | None:
    """``cured: 2 cast components, the longest 72.0 h (259,200 s) (1 component that rests on one waited for
    its cure, and what rests on it in turn)``, in the summary's duration format; None when nothing was cast.
    The count is of the planner's holds: what the cure held directly, not all it delayed. A cure that ends
    after the last construction (the makespan's end: a roof slab poured last) says how much later, and when
    that is from the first release."""
    cured = [c["curing"] for c in report.get("components", []) if c.get("curing")]
    if not cured:
        return None
    longest_s = max(entry["until_s"] - entry["from_s"] for entry in cured)
    held = sum(len(entry["holds"]) for entry in cured)
    components = f"{len(cured)} cast component{'' if len(cured) == 1 else 's'}"
    line = f"cured: {components}, the longest {duration_text(longest_s)}"
    if held:
        which = "component" if held == 1 else "components"
        it = "it" if held == 1 else "them"
        rests = "rests" if held == 1 else "rest"
        line += f" ({held} {which} that {rests} on one waited for its cure, and what rests on {it} in turn)"
    last_s = report.get("totals", {}).get("last_constructed_s")
    cured_s = max(entry["until_s"] for entry in cured)
    if last_s is not None and cured_s > last_s:  # the makespan ends at the last pour, the building later
        line += (
            "; the makespan ends with the last construction, and the concrete reaches its strength "
            f"{duration_text(cured_s - last_s)} later, when the last cure ends"
        )
        first_s = report.get("totals", {}).get("first_release_s")
        if first_s is not None:  # a builder's date: when the building stands at strength (a new user's ask)
            line += f": {duration_text(cured_s - first_s)} from the first release"
    return line


LIFTING_SETS_IT = 0.25  # the robots that lift at work for less of the makespan than this: say what set it


def set_by_line(report: Mapping[str, Any]) -> str | None:
    """``what set the makespan: work in place … and waits …; one robot that lifts or more was at work …``,
    when the work in place (forming, pouring, laying) and the waits with nothing at work (cures) took most of
    the makespan and the lifting little of it; else None. A new user saw husky, carrier and crane at 1 %
    each on the Revit house, three carriers change its makespan by 0.1 %, and nothing said why. The
    lifting time is the time at least one of them worked (their tasks' spans merged, not summed: a trial
    user took "the robots were at work" for a sum)."""
    totals = report.get("totals") or {}
    makespan_s, first_s = totals.get("makespan_s"), totals.get("first_release_s")
    working_s = totals.get("working_s")
    if not makespan_s or first_s is None or working_s is None:
        return None
    in_place = {c["guid"] for c in report.get("components", []) if c.get("method") in WORK_IN_PLACE}
    tasks = [task for robot in (report.get("robots") or {}).values() for task in robot.get("tasks", [])]
    window = (float(first_s), float(first_s) + float(makespan_s))
    in_place_s = working_within_s([{"tasks": [t for t in tasks if t["guid"] in in_place]}], window)
    lifting_s = working_within_s([{"tasks": [t for t in tasks if t["guid"] not in in_place]}], window)
    waiting_s = max(0.0, float(makespan_s) - float(working_s))
    if not in_place or lifting_s >= LIFTING_SETS_IT * makespan_s or in_place_s + waiting_s < 0.5 * makespan_s:
        return None
    return (
        f"what set the makespan: work in place {duration_text(in_place_s)} (summed over its components, "
        f"which may overlap: {_phases(report)}) and "
        f"waits with nothing at work (cures, holds) {duration_text(waiting_s)}; one robot that lifts or more "
        f"was at work {duration_text(lifting_s)} of it, so more of them would not make it much shorter"
        f"{_in_place_lever(report, in_place)}"
    )


def _in_place_lever(report: Mapping[str, Any], in_place: set[str]) -> str:
    """``; the work in place was r5 (concrete_pump)'s, while r6 (line_pump) stood idle: …``: who did the
    work in place, which machines did nothing, and what changes it. A new user read the line as advice on
    lifting robots alone; then, told "more pumps share it", saw the run's second pump idle (the house's
    two pours wait on each other's cure): another machine helps only where work in place can run side by
    side, and the rates and cures are the methods file's, read at conversion. Empty when no robot's task
    was work in place."""
    robots = sorted((report.get("robots") or {}).items())
    doers = [
        f"{robot_id} ({robot.get('type', '?')})"
        for robot_id, robot in robots
        if any(task.get("guid") in in_place for task in robot.get("tasks", []))
    ]
    if not doers:
        return ""
    idle = [
        f"{robot_id} ({robot.get('type', '?')})"
        for robot_id, robot in robots
        if not robot.get("tasks") and not robot.get("distance_m")
    ]
    whose = f"{doers[0]}'s" if len(doers) == 1 else f"that of {', '.join(doers)}"
    stood = f", while {', '.join(idle)} stood idle" if idle else ""
    return (
        f"; the work in place was {whose}{stood}: it waits on cures and on what it stands on, so another "
        "machine for it shortens it only where that work can run side by side; the forming rates and cure "
        "times are the methods file's (bimbot convert MODEL --methods FILE, then run again)"
    )


def _phases(report: Mapping[str, Any]) -> str:
    """``forming 77.6 h, pouring 4.8 h``: the work in place's phases summed over its components (from each
    one's phase start to the next phase or its construction), in the summary's units; ``forming, pouring,
    laying`` when the report has none of them. A new user asked what took a slab 77.6 h."""
    sums = {field.removesuffix("_s"): 0.0 for field in WORK_STATES.values()}  # forming, pouring, …
    for component in report.get("components", []):
        end = component.get("constructed_s")
        starts = [(phase, component.get(f"{phase}_s")) for phase in sums]
        stamps = sorted((float(at), phase) for phase, at in starts if at is not None)
        if not stamps:
            continue
        for (at, phase), following in zip(stamps, [*[t for t, _ in stamps[1:]], end], strict=True):
            if following is not None:
                sums[phase] += max(0.0, float(following) - at)
    said = [f"{phase} {duration_text(total_s)}" for phase, total_s in sums.items() if total_s > 0.0]
    return ", ".join(said) or "forming, pouring, laying"
