"""The summary ``bimbot run`` prints as it ends: what was built, how well, by whom, and what was not and why.

Pure: a :class:`RunOutcome` (the run's counts, its report and where its files are) in, text out. Every
duration is said by :func:`~bimbot.shared.report.durations.duration_text` (one format, the unit a person
says it in: ``396.0 s``, ``36.6 min (2,197 s)``, ``5.0 days round the clock (432,000 s)``). The figures are
the report's (:mod:`bimbot.shared.report.collector` and its ``report_*`` helpers), so the summary and
``report.json`` cannot disagree.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from bimbot.run.as_built import as_built_line
from bimbot.run.restarts import Restart
from bimbot.run.robot_summary import robot_lines, walled_in_line
from bimbot.run.table import not_built_table
from bimbot.shared.report.collector import RunEnding
from bimbot.shared.report.durations import ROUND_THE_CLOCK, duration_text
from bimbot.shared.report.fleet import robot_order, utilisation_line
from bimbot.shared.report.methods import curing_line, set_by_line
from bimbot.shared.report.placements import caught_on_last_attempt, placement_line
from bimbot.shared.report.totals import makespan_window
from bimbot.shared.run_folder import RunFolder

MAX_PLAN_WARNINGS_SHOWN = 5
MIN_CHAIN = 3  # this many components built one after another before the summary calls it a chain


@dataclass
class RunOutcome:
    exit_code: int
    constructed: int
    total: int
    failed: list[str] = field(default_factory=list)
    misplacements: int = 0
    sim_time_s: float = 0.0
    wall_time_s: float = 0.0
    report: dict[str, Any] = field(default_factory=dict)
    report_dir: Path | None = None
    run_dir: Path | None = None
    plan_warnings: list[str] = field(default_factory=list)  # what the planner found wrong with its input
    rrd_path: Path | None = None
    viewer_url: str | None = None
    summary_announced: bool = False  # the summary went out through ``announce`` already (--live)
    ending: RunEnding | None = None
    # of wall_time_s: before the services ran (input check, loading the libraries), and with them running
    # until the build ended (the progress lines' and the ending's "wall"); None: not measured
    startup_wall_s: float | None = None
    build_wall_s: float | None = None


def _makespan(totals: dict[str, Any], *, finished: bool = True) -> str:
    """``, makespan 17.7 min (1,061 s)``: the report's and report.png's figure (first release to last
    construction), which a user otherwise cannot tell from the run's sim time; of a run stopped before
    its end, ``so far`` (a trial user read a stopped run's makespan as a finished build's)."""
    makespan = totals.get("makespan_s")
    if not makespan:
        return ""
    so_far = "" if finished else " so far"
    return f", makespan{so_far} {duration_text(makespan)} from the first release to the last construction"


def wall_line(outcome: RunOutcome) -> str:
    """``wall time 34.2 s: 9.3 s start-up, 21.0 s building, 3.9 s closing``: what the command
    took, and of it the part the progress lines and the run's ending (its ``ENDED`` file, ``bimbot runs``)
    count as "wall": from the services' start to the build's end. Start-up is the input check and the
    first load of the simulation libraries; closing the audit, the report and stopping the services. A
    run that did not get to its build says the whole only."""
    total = f"wall time {duration_text(outcome.wall_time_s)}"
    if outcome.startup_wall_s is None or outcome.build_wall_s is None:
        return total
    rest_s = max(0.0, outcome.wall_time_s - outcome.startup_wall_s - outcome.build_wall_s)
    return (
        f"{total}: {duration_text(outcome.startup_wall_s)} start-up, {duration_text(outcome.build_wall_s)} "
        f"building (the planner's preparation and the build, as the progress lines count it), "
        f"{duration_text(rest_s)} "
        "closing (the as-built audit, the report, stopping the services)"
    )


def _caught(outcome: RunOutcome) -> str:
    """The placements the agents caught off target or unstable: the retried ones, and those on a component's
    last attempt (verdict ``failed``: not retried, the component fails with its reason)."""
    last = caught_on_last_attempt(outcome.report)
    if not last:
        return f"{outcome.misplacements} placement(s) caught off target or unstable and retried"
    return (
        f"{outcome.misplacements + last} placement(s) caught off target or unstable: {outcome.misplacements} "
        f"retried, {last} on its component's last attempt (failed, with its reason below)"
    )


APART = ("with_host", "in_place")  # counted beside the components: guests built into a host, existing work


def method_line(totals: dict) -> str | None:
    """``by method (constructed/components): cast_in_place 9/9, lifted 33/33; besides them: with_host 2/2
    (built into their hosts)``, unless all are lifted. The components' methods add up to the run's
    components; the guests and existing work are counted apart, after them."""
    by_method = totals.get("by_method") or {}
    if set(by_method) <= {"lifted"}:
        return None
    parts = [
        f"{method} {entry['constructed']}/{entry['components']}"
        for method, entry in by_method.items()
        if method not in APART
    ]
    why = {"with_host": "built into their hosts", "in_place": "existing work"}
    apart = [
        f"{method} {by_method[method]['constructed']}/{by_method[method]['components']} ({why[method]})"
        for method in APART
        if method in by_method
    ]
    line = "by method (constructed/components): " + ", ".join(parts)
    return f"{line}; besides them: {', '.join(apart)}" if apart else line


def _seed(outcome: RunOutcome) -> str:
    settings = outcome.report.get("settings") or {}
    seed, fidelity = settings.get("seed"), settings.get("fidelity")
    said = [f"seed {seed}" if seed is not None else "", f"fidelity {fidelity}" if fidelity else ""]
    return f" ({', '.join(part for part in said if part)})" if any(said) else ""


def _give_backs(totals: dict[str, Any], robots: dict[str, Any]) -> str:
    """``20 give-back(s) by robots (r1 10, r3 10)``: how many, and which robots gave them back."""
    by_robot = [
        f"{robot_id} {robots[robot_id]['given_back']}"
        for robot_id in robot_order(robots)
        if robots[robot_id].get("given_back")
    ]
    return f"{totals.get('give_backs', 0)} give-back(s) by robots" + (
        f" ({', '.join(by_robot)})" if by_robot else ""
    )


def clear_away_line(components: list[dict[str, Any]]) -> str | None:
    """``cleared out of the robots' way: Ledger L1 by r2 at 3157400 s (took 412 s); …``: the failed bodies
    carried to the yard, and those left in the way with why (None: no failed body lay in the way)."""
    parts = []
    for component in components:
        entry = component.get("cleared_away")
        if not entry:
            continue
        name = component.get("name") or component["guid"]
        if entry.get("cleared"):
            at, took = duration_text(entry["cleared_s"]), duration_text(entry["took_s"])
            parts.append(f"{name} by {entry['robot_id']} at {at} (took {took})")
        elif entry.get("cleared") is False:
            why = (entry.get("reason") or {}).get("message", "")
            parts.append(f"{name} NOT cleared: {why}")
    return "failed bodies cleared out of the robots' way: " + "; ".join(parts) if parts else None


def summary_text(outcome: RunOutcome) -> str:
    totals = outcome.report.get("totals", {})
    ending = outcome.ending
    early = []  # first: why the numbers below are what they are
    if ending is not None and ending.how != "done":
        early = [f"the run ended early: {ending.message}", *(f"  {detail}" for detail in ending.details)]
    # the report's clock: built after the last message, which the run's own monitor may not have heard
    sim_time_s = max(outcome.sim_time_s, float(outcome.report.get("sim_time_s") or 0.0))
    lines = [
        *early,
        f"constructed {outcome.constructed}/{outcome.total} components in {duration_text(sim_time_s)} of "
        f"sim time{_makespan(totals, finished=_finished(outcome))}; {_caught(outcome)}, "
        f"{_give_backs(totals, outcome.report.get('robots', {}))}{_seed(outcome)}",
        wall_line(outcome),
    ]
    walled_in = walled_in_line(outcome.report.get("robots", {}))
    if walled_in is not None:
        lines.append(walled_in)
    cleared = clear_away_line(outcome.report.get("components", []))
    if cleared is not None:
        lines.append(cleared)
    methods = method_line(totals)
    if methods:
        lines.append(methods)
    curing = curing_line(outcome.report)
    if curing is not None:
        lines.append(curing)
    if totals.get("in_place"):
        lines.append(
            f"in place before the run (existing work the IFC marks, or convert --in-place): "
            f"{totals['in_place']} component(s), not built by the robots and not counted above"
        )
    if (outcome.report.get("settings") or {}).get("connections") is False:
        lines.append(
            "without connections (--no-connections): every component had to stand by itself, none was "
            "connected to what was built beside it"
        )
    if totals.get("max_position_error_mm") is not None:
        lines.append(
            "placement error of the constructed components at most "
            f"{totals['max_position_error_mm']:.2f} mm and {totals['max_angle_error_deg']:.2f}°"
        )
    placements = placement_line(outcome.report)
    if placements is not None:
        lines.append(placements)
    as_built = as_built_line(outcome.report)
    if as_built is not None:
        lines.append(as_built)
    lines += robot_lines(outcome.report, makespan_window(outcome.report.get("components", [])))
    utilisation = utilisation_line(outcome.report)
    if utilisation is not None:
        lines.append(utilisation)
    set_by = set_by_line(outcome.report)
    if set_by is not None:
        lines.append(set_by)
    one_at_a_time = one_at_a_time_line(outcome.report)
    if one_at_a_time is not None:
        lines.append(one_at_a_time)
    restarts = outcome.report.get("restarts", [])
    if restarts:
        lines.append(f"services that died during the run ({len(restarts)}):")
        lines += [f"  {Restart(**record).line()}" for record in restarts]
    if outcome.plan_warnings:
        lines.append(f"the planner warned about its plan ({len(outcome.plan_warnings)}):")
        lines += [f"  {warning}" for warning in outcome.plan_warnings[:MAX_PLAN_WARNINGS_SHOWN]]
        if len(outcome.plan_warnings) > MAX_PLAN_WARNINGS_SHOWN:
            lines.append(
                f"  … and {len(outcome.plan_warnings) - MAX_PLAN_WARNINGS_SHOWN} more (logs/planner.log)"
            )
    table = not_built_table(outcome.report)
    if table:
        lines.append(table.rstrip("\n"))
    if outcome.report_dir is not None:
        lines.append(f"report: {outcome.report_dir / 'report.json'} and {outcome.report_dir / 'report.png'}")
    if outcome.run_dir is not None:
        lines.append(f"logs: {RunFolder(outcome.run_dir).logs_dir}/ (one per service)")
    if outcome.rrd_path is not None:
        viewer = Path(sys.executable).with_name("rerun")  # the venv's own viewer, wherever the user stands
        lines.append(f"recording: {outcome.rrd_path} (open it with: {viewer} {outcome.rrd_path})")
    exit_why = exit_line(outcome)
    if exit_why is not None:
        lines.append(exit_why)
    return said_once("\n".join(lines) + "\n", ROUND_THE_CLOCK)


def said_once(text: str, words: str) -> str:
    """``text`` with ``words`` kept at their first place only: a trial user of the house read "round the
    clock" eight times in one summary; once, at the first time in days, says how every later one is meant."""
    first = text.find(words)
    if first < 0:
        return text
    cut = first + len(words)
    return text[:cut] + text[cut:].replace(words, "")


def _finished(outcome: RunOutcome) -> bool:
    """Whether the run went on until nothing more could happen (done, or stalled): not stopped by a
    signal, a timeout or a service gone."""
    return outcome.ending is None or outcome.ending.how in ("done", "stalled")


def one_at_a_time_line(report: dict[str, Any]) -> str | None:
    """``one component at a time: …``, when each constructed component was released only once the one
    before it was built, with several robots on site and a sequence the run did not derive; else None.
    A new user ran a 361-part frame with seven robots on the sample's 4D schedule (one chain): 14.7 h,
    six robots idle, and nothing said why; ``--derive`` built it in 2.3 h."""
    settings = report.get("settings") or {}
    sequence = str(settings.get("sequence") or "")
    if "derive" in sequence or len(report.get("robots") or {}) < 2:
        return None
    spans = sorted(
        (component["released_s"], component["constructed_s"])
        for component in report.get("components", [])
        if component.get("state") == "constructed"
        and component.get("released_s") is not None
        and component.get("constructed_s") is not None
    )
    if len(spans) < MIN_CHAIN:
        return None
    built_s = spans[0][1]
    for released_s, constructed_s in spans[1:]:
        if released_s < built_s - 1e-6:
            return None  # two were at work at once
        built_s = max(built_s, constructed_s)
    return (
        f"one component at a time: each of the {len(spans)} was released only once the one before it was "
        f"built, so the other robots waited: the sequence ({sequence}) released them one after another. "
        "--derive releases each component once what it rests on is built, and the robots work at once"
    )


def exit_line(outcome: RunOutcome) -> str | None:
    """``exit 1: 3 component(s) not built (the table above says why)``: why the command's exit code is not
    0, as its last line (a script or a user sees a failure without reading the report); None for 0."""
    code = outcome.exit_code
    if code == 0:
        return None
    if code >= 128:
        return f"exit {code}: stopped by a signal; the report covers the run up to then"
    why = []
    if outcome.constructed < outcome.total:
        why.append(f"{outcome.total - outcome.constructed} component(s) not built (the table above says why)")
    if (outcome.report.get("as_built") or {}).get("errors"):
        why.append("the as-built audit found components away from their BIM targets (the as-built line)")
    return f"exit {code}: " + (" and ".join(why) or "the planner did not finish (logs/planner.log)")
