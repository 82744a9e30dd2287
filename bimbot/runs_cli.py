"""``bimbot runs BUILD [--new]``: the runs of a build, newest last, or a new run folder.

Lists ``BUILD/runs/*`` (see :mod:`bimbot.shared.run_folder`), then the runs given a ``--run-dir``
elsewhere, with what each run's report says: components constructed, how the run ended, sim time.
``--new`` makes a new run folder, points ``BUILD/runs/latest`` at it and prints its path: services started
without ``--run-dir`` (by hand, or ``docker compose``) then write there, so a new ``up`` never resumes the
journal of the last one.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from bimbot.shared.errors import UserError
from bimbot.shared.manifest import load_manifest
from bimbot.shared.report.compare import fleet_of
from bimbot.shared.report.durations import time_unit
from bimbot.shared.run_folder import (
    RunFolder,
    latest_run_folder,
    new_run_folder,
    run_folders,
    runs_elsewhere,
)

LONG_RUN_S = 2 * 3600.0  # beyond this a run's sim time is said in hours or days too


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("build", type=Path, help="a converted build folder")
    parser.add_argument(
        "--new", action="store_true", help="make a new run folder, link it as latest and print its path"
    )


def run(args: argparse.Namespace) -> int:
    build = args.build.parent if args.build.is_file() else args.build  # BUILD/ or BUILD/manifest.json
    load_manifest(build)  # one clear line when it is not a build
    if args.new:
        sys.stdout.write(f"{new_run_folder(build).root}\n")
        return 0
    folders = run_folders(build)
    elsewhere = runs_elsewhere(build)
    if not folders and not elsewhere:
        raise UserError(f"{build}: no runs yet (bimbot run {build})")
    latest = latest_run_folder(build)
    for folder in folders:
        mark = " (latest)" if latest is not None and latest.root == folder.resolve() else ""
        sys.stdout.write(f"{folder.name}{mark}  {run_summary(RunFolder(folder))}\n")
    for folder in elsewhere:  # given with --run-dir
        sys.stdout.write(f"{folder}  {run_summary(RunFolder(folder))}\n")
    return 0


def run_summary(run: RunFolder) -> str:
    """One line from the run's report: constructed/total, how it ended, sim time and, when some were not
    constructed, the count per reason (a run that ended by itself as ``done`` may have built 3 of 115: the
    reasons say why without opening the report); or why there is none."""
    path = run.report_dir / "report.json"
    try:
        report = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        return "no report"
    except (OSError, ValueError) as error:
        return f"unreadable report ({error})"
    totals = report.get("totals", {})
    ending = report.get("ending") or {}
    sim_s = report.get("sim_time_s", totals.get("makespan_s"))
    sim = f", {sim_s:,.0f} s sim" if isinstance(sim_s, int | float) else ""
    if isinstance(sim_s, int | float) and sim_s > LONG_RUN_S:  # curing: say it in hours or days too
        unit = time_unit(sim_s)
        sim += f" ({sim_s / unit.seconds:.1f} {unit.name})"
    by_reason = totals.get("by_reason") or {}
    reasons = ", ".join(
        f"{count} {reason}"
        for reason, count in sorted(by_reason.items(), key=lambda item: (-item[1], item[0]))
        if isinstance(count, int) and count > 0
    )
    return (
        f"constructed {totals.get('constructed', '?')}/{totals.get('components', '?')}, "
        f"{ending.get('how', 'unfinished')}{sim}{_with(report)}"
        + (f"; not constructed: {reasons}" if reasons else "")
    )


def _with(report: dict) -> str:
    """``, 3 robots, 9 in place, without connections``: what tells two runs of one build apart (a trial
    could not tell a ``--robots 1`` run from one of the default fleet, nor one with ``--no-connections``)."""
    settings = report.get("settings") or {}
    parts = [fleet_of(settings, report.get("robots")) or ""]
    if settings.get("fidelity"):
        parts.append(f"fidelity {settings['fidelity']}")
    in_place = (report.get("totals") or {}).get("in_place")
    if in_place:
        parts.append(f"{in_place} in place")
    if settings.get("connections") is False:
        parts.append("without connections")
    by_method = (report.get("totals") or {}).get("by_method") or {}
    unbuilt = {m for m, e in by_method.items() if (e.get("constructed") or 0) < (e.get("components") or 0)}
    if unbuilt:  # not all built: what was, by method ("54 lifted" read as 54 built)
        built = [f"{method} {e.get('constructed') or 0}/{e['components']}" for method, e in by_method.items()]
        parts.append("built by method: " + ", ".join(built))
    elif set(by_method) - {"lifted"}:
        parts.append(" ".join(f"{entry['components']} {method}" for method, entry in by_method.items()))
    return "".join(f", {part}" for part in parts if part)
