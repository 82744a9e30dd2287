"""The summary's robot lines: each robot's tasks by how they ended, the distance it drove, its busy time,
and where it was walled in.

A robot's task count is its busy intervals (:mod:`bimbot.shared.report.robots`); ``built`` and
``given_back`` count the ones that ended so. The rest (a placement caught off target or unstable and
retried, a failed last attempt, a task still going when the run ended, a failed body carried away) are
named, so "24 task(s): 23 built" never leaves the reader guessing which one and why. Pure: the report's
dictionaries in, text out; every duration through :func:`~bimbot.shared.report.durations.duration_text`.
"""

from __future__ import annotations

from collections import Counter
from typing import Any

from bimbot.shared.report.durations import TimeUnit, duration_text, in_unit_text, spoken_unit
from bimbot.shared.report.fleet import lane_label, robot_order
from bimbot.shared.report.totals import busy_within_s

MAX_OTHERS_NAMED = 3  # tasks named per robot line; report.json has every one


def busy_outside(robot: dict[str, Any], window: tuple[float, float] | None, unit: TimeUnit) -> str:
    """``, 3.3 min (198 s) of it after the last construction …`` (in the line's ``unit``): the utilisation
    counts a robot's busy time within the makespan only; without this a robot busy 360 s beside a 268 s
    makespan read as a contradiction."""
    if window is None:
        return ""
    outside = robot["busy_s"] - busy_within_s(robot, window)
    if outside < 1.0:
        return ""
    return (
        f", {in_unit_text(outside, unit)} of it after the last construction, on tasks that built nothing more"
    )


def _placements_by(robot_id: str, components: dict[str, dict[str, Any]]) -> dict[str, list[dict[str, Any]]]:
    """GUID → this robot's verdicts on it that did not construct it, in order."""
    out: dict[str, list[dict[str, Any]]] = {}
    for guid, component in components.items():
        caught = [
            placement
            for placement in component.get("placements") or []
            if placement.get("robot_id") == robot_id and placement.get("verdict") != "constructed"
        ]
        if caught:
            out[guid] = caught
    return out


def _what_became(task: dict[str, Any], component: dict[str, Any] | None, caught: list[dict[str, Any]]) -> str:
    """What one task that neither built nor gave back its component came to."""
    if task.get("kind") == "clear":
        return "carried out of the robots' way"
    if task.get("open"):
        return "still at it when the run ended"
    if caught:
        placement = caught.pop(0)
        how = "unstable" if placement.get("cause") == "unstable" else "off target"
        if placement.get("verdict") == "failed":
            return f"placed {how} on its last attempt: failed"
        return f"placed {how}, retried" + _built_after(component)
    if component is None:
        return "no component heard of"
    state = component.get("state") or "unknown"
    reason = (component.get("reason") or {}).get("code")
    return f"ended without a placement; the component is {state}" + (f" ({reason})" if reason else "")


def _built_after(component: dict[str, Any] | None) -> str:
    """``, then built by r3``: who built a component in the end (a trial user read a retried placement as
    a part left unbuilt); nothing while it is not constructed."""
    if component is None or component.get("state") != "constructed":
        return ""
    builders = [
        placement.get("robot_id")
        for placement in component.get("placements") or []
        if placement.get("verdict") == "constructed" and placement.get("robot_id")
    ]
    return f", then built by {builders[-1]}" if builders else ""


def _classified(
    robot_id: str, robot: dict[str, Any], components: dict[str, dict[str, Any]]
) -> tuple[int, int, list[tuple[int, str]], int]:
    """(built, given back, the others' (index, GUID), hand-offs given back) among the robot's tasks: a
    hand-off counts only when given back (on the Revit hub with three carriers a summary said "0 given
    back (L-Angle …: no_progress …)" of a hand-off given back); of the rest, each
    constructed placement by the robot and each give-back it made is matched to one of its tasks of that
    component, latest first (a component's last task by the robot is taken as the one that built it, its
    earlier ones as the retries), so the three add up to its tasks less its hand-offs. The others (a
    placement caught and retried, a last attempt failed, a task open at the end, a body cleared away) are
    named by :func:`_named_others`."""
    built: Counter[str] = Counter()
    for guid, component in components.items():
        built[guid] = sum(
            1
            for placement in component.get("placements") or []
            if placement.get("robot_id") == robot_id and placement.get("verdict") == "constructed"
        )
    given_back = Counter(
        guid
        for guid, component in components.items()
        for who in component.get("given_back_by") or []
        if who == robot_id
    )
    built_tasks = given_back_tasks = 0
    others: list[tuple[int, str]] = []
    handed_back: list[int] = []
    tasks = robot.get("tasks") or []
    for index in reversed(range(len(tasks))):
        task = tasks[index]
        guid = task.get("guid")
        if task.get("kind") == "hand_off":
            if guid is not None and given_back[guid] > 0:  # given back: a give-back, not a hand-off
                given_back[guid] -= 1
                given_back_tasks += 1
                handed_back.append(index)
            continue
        if task.get("kind") != "clear" and guid is not None and built[guid] > 0:
            built[guid] -= 1
            built_tasks += 1
            continue
        if task.get("kind") != "clear" and guid is not None and given_back[guid] > 0:
            given_back[guid] -= 1
            given_back_tasks += 1
            continue
        others.append((index, guid or ""))
    return built_tasks, given_back_tasks, others, len(handed_back)


def _named_others(
    robot_id: str, robot: dict[str, Any], components: dict[str, dict[str, Any]], others: list[tuple[int, str]]
) -> list[str]:
    """``T0017 Beam B1-B2: placed unstable, retried``: what each of ``others`` (:func:`_classified`)
    came to."""
    caught = _placements_by(robot_id, components)
    tasks = robot.get("tasks") or []
    lines = []
    for index, guid in sorted(others):
        entry = components.get(guid)
        name = (entry or {}).get("name") or guid or "no component"
        became = _what_became(tasks[index], entry, caught.get(guid, []))
        lines.append(f"{tasks[index].get('task_id') or '?'} {name}: {became}")
    return lines


REASON_WORDS_MAX = 60  # characters of a give-back's reason said on the robot's line


def _reason_words(reason: str, name: str, robot_id: str) -> str:
    """``no_approach_pose, would wall itself in setting it``: a give-back reason's code and its first words
    (up to the component's name, else its first clause), without the robot's id (a trial user read the code
    alone, "no_approach_pose", as something other than "r2 would wall itself in setting …")."""
    code, _, message = reason.partition(": ")
    in_name = bool(name) and name in message
    words = message.split(name)[0].strip() + " it" if in_name else message.split(": ")[0]
    words = words.strip().removeprefix(f"{robot_id} ").strip()
    if len(words) > REASON_WORDS_MAX:
        words = words[: REASON_WORDS_MAX - 1].rstrip() + "…"
    return (
        f"{code.strip() or 'no reason'}, {words}" if words and words != "it" else code.strip() or "no reason"
    )


def _given_back_named(robot_id: str, components: dict[str, dict[str, Any]]) -> str:
    """`` (Wall W1 panel 2/2: no_approach_pose, would wall itself in setting it; …)``: each component this
    robot gave back and the reason's code and first words (a trial user found the reasons only in
    report.json: its components' ``give_backs`` have the whole of each); nothing when it gave none back."""
    named = []
    for component in components.values():
        reasons = component.get("give_backs") or []
        for who, reason in zip(component.get("given_back_by") or [], reasons, strict=False):
            if who == robot_id:
                name = component.get("name") or component.get("guid") or ""
                named.append(f"{name}: {_reason_words(str(reason), name, robot_id)}")
    if not named:
        return ""
    more = f"; … and {len(named) - MAX_OTHERS_NAMED} more" if len(named) > MAX_OTHERS_NAMED else ""
    return f" ({'; '.join(named[:MAX_OTHERS_NAMED])}{more}; why: report.json, each component's give_backs)"


def tasks_text(robot_id: str, robot: dict[str, Any], components: dict[str, dict[str, Any]]) -> str:
    """``24 task(s): 20 built, 1 given back (Beam B3: no_approach_pose; why: …), 1 ended another way (T0017
    Beam B1-B2: placed unstable, retried, then built by r2), 2 hand-off(s) to a crane``: the parts add up
    to the tasks; a report without the counts: ``11 task(s)``."""
    tasks = f"{len(robot['tasks'])} task(s)"
    hand_offs = sum(1 for task in robot["tasks"] if task.get("kind") == "hand_off")
    if "built" not in robot:
        return tasks + (f" ({hand_offs} hand-off(s) to a crane)" if hand_offs else "")
    built, given_back, unnamed, handed_back = _classified(robot_id, robot, components)
    hand_offs -= handed_back
    handed = f", {hand_offs} hand-off(s) to a crane" if hand_offs else ""
    text = f"{tasks}: {built} built, {given_back} given back" + _given_back_named(robot_id, components)
    others = _named_others(robot_id, robot, components, unnamed)
    if not others:
        return text + handed
    named = "; ".join(others[:MAX_OTHERS_NAMED])
    more = (
        f"; … and {len(others) - MAX_OTHERS_NAMED} more (report.json)"
        if len(others) > MAX_OTHERS_NAMED
        else ""
    )
    # not "that built nothing": a trial user read that beside "then built by r3" of the same robot as a
    # contradiction (the task was a retry's first attempt; the component was built by a later one)
    return f"{text}, {len(others)} ended another way ({named}{more}){handed}"


def moved_text(robot: dict[str, Any]) -> str:
    """``, 412 m driven`` for a robot that drove; ``, 11 relocation(s) between set-ups`` for a machine that
    moved between its set-ups; nothing for one that never moved."""
    distance_m, relocations = float(robot.get("distance_m") or 0.0), int(robot.get("relocations") or 0)
    if distance_m >= 0.5:
        return f", {distance_m:,.0f} m driven"
    return f", {relocations} relocation(s) between set-ups" if relocations else ""


def robot_lines(report: dict[str, Any], window: tuple[float, float] | None) -> list[str]:
    """One line per robot, by type: its tasks, hand-offs, distance (a machine that stands fixed: its
    relocations between set-ups, not ``0 m driven``: a new user read a piling rig's ``0 m driven`` beside
    ``driven 216/216``) and busy time (every robot's in one unit, so they compare at a glance)."""
    robots = report.get("robots", {})
    components = {
        component["guid"]: component for component in report.get("components", []) if "guid" in component
    }
    order = robot_order(robots)
    unit = spoken_unit(max((robots[robot_id]["busy_s"] for robot_id in order), default=0.0))  # one for all
    lines = []
    for robot_id in order:
        robot = robots[robot_id]
        lines.append(
            f"{lane_label(robot_id, robot)}: {tasks_text(robot_id, robot, components)}"
            + moved_text(robot)
            + f", busy {in_unit_text(robot['busy_s'], unit)}"
            + busy_outside(robot, window, unit)
        )
    return lines


def walled_in_lines(robots: dict[str, Any]) -> list[str]:
    """``r1 at (1.43, -6.35) from 5.4 days round the clock (470,130 s) of sim time to the end of the run``:
    each time a robot said it had no way to its depot, where it stood and since when (and until when, if
    it got out)."""
    lines = []
    for robot_id in robot_order(robots):
        for spell in robots[robot_id].get("walled_in") or []:
            x, y = spell["xy_m"]
            until = spell.get("until_s")
            to = "to the end of the run" if until is None else f"to {duration_text(until)}"
            since = duration_text(spell["since_s"])
            lines.append(f"{robot_id} at ({x:.2f}, {y:.2f}) from {since} of sim time {to}")
    return lines


def walled_in_line(robots: dict[str, Any]) -> str | None:
    """The summary's line on robots walled in, with what it meant for the build; None when none was."""
    spells = walled_in_lines(robots)
    if not spells:
        return None
    return (
        "robots walled in by what was built round them (no way out to where they started; meanwhile each got "
        "no task another robot could take, and its log names what stands beside it): " + "; ".join(spells)
    )
