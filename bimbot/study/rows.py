"""One row of ``study.csv`` per run: from the run's ``report.json``, or the reason there is none.

Pure: a :class:`~.grid.StudyRun`, how the process ended and the report (a dict) in, a flat dict out. The
figures are the report's totals (constructed, makespan, utilisation per robot type, distance driven);
cost is each type's hourly rate (``cost_per_h`` in the fleet file) times its robots' busy hours, and
``cost_on_site`` the rate times its robots times the makespan (what a site pays while the robots wait);
both are empty when a type on site has no rate. ``seed_reached_run`` says whether the run's report names
the study's seed (``settings.seed``): without it the runs of a fleet are repeats, not seeded draws.

``status``: ``built`` (every component constructed), ``incomplete`` (a report, not everything built: its
ending says why), ``failed`` (no report: the process could not run, crashed or ran out of time).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

from .grid import StudyRun

BUILT, INCOMPLETE, FAILED = "built", "incomplete", "failed"
UTILISATION_PREFIX = "utilisation_"
HEAD_COLUMNS = ["fleet", "sequence", "seed", "seed_reached_run", "fidelity", "status", "reason", "exit_code"]
FIGURE_COLUMNS = [
    "constructed",
    "components",
    "makespan_s",
    "sim_time_s",
    "utilisation",
    "distance_m",
    "busy_h",
    "cost",
    "cost_on_site",
]
TAIL_COLUMNS = ["wall_s", "run_dir"]
#: what differs between two studies of the same grid on different machines or schedulers
RUN_SPECIFIC_COLUMNS = frozenset({"wall_s"})
SECONDS_PER_HOUR = 3600.0


def columns(rows: Iterable[Mapping[str, Any]]) -> list[str]:
    """The CSV's columns: the fixed ones, with one ``utilisation_<type>`` per robot type seen, sorted."""
    types = sorted({key for row in rows for key in row if key.startswith(UTILISATION_PREFIX)})
    return [*HEAD_COLUMNS, *FIGURE_COLUMNS[:5], *types, *FIGURE_COLUMNS[5:], *TAIL_COLUMNS]


def _head(run: StudyRun, status: str, reason: str, exit_code: int | None) -> dict[str, Any]:
    return {
        "fleet": run.fleet_label,
        "sequence": run.sequence_label,
        "seed": run.seed,
        "seed_reached_run": False,
        "fidelity": run.fidelity,
        "status": status,
        "reason": reason,
        "exit_code": exit_code,
    }


def failed_row(
    run: StudyRun, reason: str, exit_code: int | None, wall_s: float, run_dir: str
) -> dict[str, Any]:
    """The row of a run that left no report: its reason, no figures."""
    return {
        **_head(run, FAILED, reason, exit_code),
        **dict.fromkeys(FIGURE_COLUMNS),
        "wall_s": round(wall_s, 1),
        "run_dir": run_dir,
    }


def cost(by_type: Mapping[str, Mapping[str, Any]], rates: Mapping[str, float | None]) -> float | None:
    """Σ rate × busy hours over the robot types that worked, or None when one of them has no rate."""
    total = 0.0
    for name, entry in by_type.items():
        rate = rates.get(name)
        if rate is None:
            return None
        total += rate * float(entry.get("busy_s") or 0.0) / SECONDS_PER_HOUR
    return total


def cost_on_site(
    by_type: Mapping[str, Mapping[str, Any]], rates: Mapping[str, float | None], makespan_s: float | None
) -> float | None:
    """Σ rate × robots × makespan hours: the robots on site for the whole build, busy or not."""
    if makespan_s is None:
        return None
    total = 0.0
    for name, entry in by_type.items():
        rate = rates.get(name)
        if rate is None:
            return None
        total += rate * len(entry.get("robots") or ()) * makespan_s / SECONDS_PER_HOUR
    return total


def _rounded(value: float | None, digits: int) -> float | None:
    return None if value is None else round(float(value), digits)


def report_row(
    run: StudyRun,
    report: Mapping[str, Any],
    exit_code: int | None,
    rates: Mapping[str, float | None],
    *,
    wall_s: float,
    run_dir: str,
) -> dict[str, Any]:
    """The row of a run that wrote ``report``: ``built`` when every component is constructed and the run
    exited 0, else ``incomplete`` with the report's ending as its reason."""
    totals = report.get("totals") or {}
    by_type = totals.get("by_type") or {}
    ending = report.get("ending") or {}
    components = int(totals.get("components") or 0)
    constructed = int(totals.get("constructed") or 0)
    done = exit_code == 0 and constructed == components
    reason = "" if done else str(ending.get("message") or f"{components - constructed} not constructed")
    row = _head(run, BUILT if done else INCOMPLETE, reason, exit_code)
    row["seed_reached_run"] = (report.get("settings") or {}).get("seed") == run.seed
    makespan = totals.get("makespan_s")
    busy_s = float(totals.get("busy_s") or 0.0)
    row |= {
        "constructed": constructed,
        "components": components,
        "makespan_s": _rounded(makespan, 1),
        "sim_time_s": _rounded(report.get("sim_time_s"), 1),
        "utilisation": _rounded(totals.get("utilisation"), 4),
        **{
            f"{UTILISATION_PREFIX}{name}": _rounded(entry.get("utilisation"), 4)
            for name, entry in by_type.items()
        },
        "distance_m": _rounded(totals.get("distance_m"), 1),
        "busy_h": round(busy_s / SECONDS_PER_HOUR, 4),
        "cost": _rounded(cost(by_type, rates), 2),
        "cost_on_site": _rounded(cost_on_site(by_type, rates, makespan), 2),
        "wall_s": round(wall_s, 1),
        "run_dir": run_dir,
    }
    return row
