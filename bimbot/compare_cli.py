"""``bimbot compare RUN_A RUN_B …``: runs side by side by construction method, as a markdown table.

A run is named by its run folder, its ``report.json`` or a build folder: its latest run with a report,
under ``BUILD/runs/`` or given elsewhere with ``--run-dir`` (``BUILD/runs/elsewhere``). For each run:
constructed of all, makespan, and for each method the components it built, the time its work took and
its longest cure (:mod:`bimbot.shared.report.compare`); then each run's makespan against the first's. Runs
of another building or fidelity than the first are warned of, one line each, and marked in the table.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
from pathlib import Path
from typing import Any

from bimbot.shared.errors import UserError
from bimbot.shared.report.compare import (
    MethodFigures,
    RunColumn,
    TypeFigures,
    methods_in,
    mismatches,
    run_column,
    same_building,
    same_fidelity,
)
from bimbot.shared.report.durations import duration_text
from bimbot.shared.run_folder import RunFolder, latest_run_folder, run_folders, runs_elsewhere

_log = logging.getLogger(__name__)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "runs",
        type=Path,
        nargs="+",
        help="run folders, report.json files, build folders (latest run)",
    )


def report_path(path: Path) -> Path:
    """The ``report.json`` a path names; one clear line when it names none."""
    if path.is_file():
        return path
    if (path / "manifest.json").is_file():
        latest = latest_report(path)
        if latest is None:
            raise UserError(f"{path}: a build with no runs yet (bimbot run {path})")
        return latest
    if not path.exists():
        raise UserError(f"{path}: no such file or folder (a run folder, its report.json or a build folder)")
    report = RunFolder(path).report_dir / "report.json"
    if not report.is_file():
        raise UserError(f"{path}: no report.json there (a run folder, its report.json or a build folder)")
    return report


def latest_report(build: Path) -> Path | None:
    """The newest ``report.json`` of a build's runs (its ``runs/latest`` and the run folders given
    elsewhere with ``--run-dir``) by when it was written, of a run that has ended when one has: a run
    still going writes a report too, and is not the one to compare; None when no run has a report."""
    latest = latest_run_folder(build)
    runs = [RunFolder(folder) for folder in ([latest.root] if latest is not None else [])]
    # every run of BUILD/runs/ too: while one is going, ``latest`` names it, and the last ended run is the
    # one to compare (a new user's compare said "a build with no runs yet" beside a finished run)
    runs += [RunFolder(folder) for folder in run_folders(build)]
    runs += [RunFolder(folder) for folder in runs_elsewhere(build)]
    written = [run for run in runs if (run.report_dir / "report.json").is_file()]
    candidates = [run for run in written if run.ended] or written
    newest = max(
        candidates, key=lambda run: (run.report_dir / "report.json").stat().st_mtime_ns, default=None
    )
    return None if newest is None else newest.report_dir / "report.json"


def _read(path: Path) -> dict[str, Any]:
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as error:
        raise UserError(f"{path}: not a readable report ({error})") from None
    if not isinstance(data, dict):
        raise UserError(f"{path}: not a report (no JSON object)")
    return data


def _cell(figures: MethodFigures | None) -> str:
    if figures is None or not figures.components:
        return "–"
    text = f"{figures.constructed}/{figures.components} built, work {duration_text(figures.work_s)}"
    return text + (f", cure up to {duration_text(figures.cure_s)}" if figures.cure_s else "")


def _type_cell(figures: TypeFigures | None) -> str:
    if figures is None:
        return "–"
    driven = f", {figures.distance_m:,.0f} m driven" if figures.distance_m else ""
    return f"{figures.robots} robot(s), {figures.built} built, busy {duration_text(figures.busy_s)}{driven}"


WORK_LEGEND = (
    "work: a method's own work summed over the components it built (a lift from pick to placement, formwork "
    "and pour, laying); cure: its longest curing"
)
DIFFERS = " ⚠ differs"  # a run's cell that does not match the first run's (building, fidelity)


def table(columns: list[RunColumn]) -> list[str]:
    """The comparison as markdown lines: what each run built and at which fidelity first, a cell unlike
    the first run's marked (:data:`DIFFERS`), then the figures."""
    first = columns[0]
    lines = ["| | " + " | ".join(column.label for column in columns) + " |"]
    lines.append("|---|" + "---|" * len(columns))
    lines.append(
        "| building | "
        + " | ".join(c.building + ("" if same_building(first, c) else DIFFERS) for c in columns)
        + " |"
    )
    lines.append(
        "| fidelity | "
        + " | ".join(
            (c.fidelity or "unknown") + ("" if same_fidelity(first, c) else DIFFERS) for c in columns
        )
        + " |"
    )
    lines.append("| robots | " + " | ".join(c.fleet or "unknown" for c in columns) + " |")
    lines.append("| seed | " + " | ".join("–" if c.seed is None else str(c.seed) for c in columns) + " |")
    lines.append(
        "| constructed | "
        + " | ".join(
            f"{c.constructed}/{c.components}" + (f" ⚠ {c.ending}" if c.ended_early else "") for c in columns
        )
        + " |"
    )
    lines.append(
        "| makespan | "
        + " | ".join(duration_text(c.makespan_s) if c.makespan_s is not None else "–" for c in columns)
        + " |"
    )
    lines.append(
        "| retries, give-backs | "
        + " | ".join(f"{c.retries} retried, {c.give_backs} given back" for c in columns)
        + " |"
    )
    lines.append(
        "| walled in | "
        + " | ".join(
            ", ".join(f"{robot} {duration_text(s)}" for robot, s in sorted(c.walled_in_s.items())) or "none"
            for c in columns
        )
        + " |"
    )
    for kind in sorted({kind for column in columns for kind in column.by_type}):
        lines.append(f"| {kind} | " + " | ".join(_type_cell(c.by_type.get(kind)) for c in columns) + " |")
    methods = methods_in(columns)
    for method in methods:
        lines.append(f"| {method} | " + " | ".join(_cell(c.methods.get(method)) for c in columns) + " |")
    if methods:
        lines.append(f"\n{WORK_LEGEND}")
    first_s = columns[0].makespan_s
    for column in columns[1:]:
        if first_s and column.makespan_s is not None:
            change = column.makespan_s - first_s
            sign = "+" if change >= 0 else "−"
            lines.append(
                f"\n{column.label}: makespan {sign}{duration_text(abs(change))} "
                f"({sign}{100.0 * abs(change) / first_s:.1f} %) against {columns[0].label}"
            )
    return lines


def run(args: argparse.Namespace) -> int:
    columns = []
    for path in args.runs:
        report = report_path(path)
        data = _read(report)
        going = (data.get("ending") or {}).get("how") == "running"
        columns.append(run_column(f"{path} (still running)" if going else str(path), data))
    said = mismatches(columns)
    for sentence in said:
        _log.warning("%s", sentence)
    lines = table(columns)
    if said:
        lines.append(f"\nnote: these runs do not all compare ({len(said)} difference(s), marked ⚠ above)")
    sys.stdout.write("\n".join(lines) + "\n")
    return 0
