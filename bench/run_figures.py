"""What a finished run says about itself, for the benches: its logs and its report, read back.

* ``physics stepping: N steps in S s wall`` (physics' log): the bare ``stepSimulation`` time of the run,
  the reference of the loop's overhead (wall time of the whole build over it, in the same run);
* ``peak memory X MB…; CPU Y s`` (every service's log, as it ends);
* the report's placements: errors per robot type, drift after release (of every attempt, and of the
  placements that held and were joined), retries by cause.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

STEPPING = re.compile(r"physics stepping: (\d+) steps in ([0-9.]+) s wall")
PEAK = re.compile(r"peak memory (\d+) MB")
CPU = re.compile(r"peak memory \d+ MB.*; CPU ([0-9.]+) s")


@dataclass(frozen=True)
class RunFigures:
    stepping_s: float | None  # wall seconds in stepSimulation alone
    steps: int | None
    peak_mb: dict[str, float] = field(default_factory=dict)  # service log name → peak memory
    cpu_s: dict[str, float] = field(default_factory=dict)  # service log name → CPU seconds (user + system)


def read_figures(run_dir: Path | None) -> RunFigures:
    if run_dir is None:
        return RunFigures(None, None)
    logs = Path(run_dir) / "logs"
    stepping_s = steps = None
    physics = logs / "physics.log"
    if physics.is_file():
        found = STEPPING.findall(physics.read_text(errors="replace"))
        if found:  # one line per physics process that ended normally (a restarted one logs its own)
            steps = sum(int(n) for n, _ in found)
            stepping_s = sum(float(s) for _, s in found)
    peaks, cpu = {}, {}
    for log in sorted(logs.glob("*.log")):
        text = log.read_text(errors="replace")
        if found := PEAK.findall(text):
            peaks[log.stem] = float(found[-1])
        if used := CPU.findall(text):  # a restarted service logs once per process: all of them
            cpu[log.stem] = sum(float(seconds) for seconds in used)
    return RunFigures(stepping_s, steps, peaks, cpu)


def placement_lines(report: dict[str, Any]) -> list[str]:
    """Placement errors per robot type, the largest drift after release, retries by cause."""
    totals = report.get("totals", {})
    by_type = totals.get("placement_error_mm_by_type") or {}
    lines = [
        f"  placement error, {name}: mean {row['mean']:.1f} / p95 {row['p95']:.1f} / max {row['max']:.1f} mm "
        f"over {row['placements']} placement(s), {row['out_of_tolerance']} out of tolerance"
        for name, row in by_type.items()
        if row.get("placements")
    ]
    retries = totals.get("retries_by_cause") or {}
    drift = totals.get("max_drift_mm")
    joined = joined_drift_mm(report)
    lines.append(
        f"  retries by cause: {', '.join(f'{k} {v}' for k, v in retries.items()) or 'none'}; largest drift "
        f"after release {'n/a' if drift is None else f'{drift:.1f}'} mm; of the joined components "
        f"{'n/a' if joined is None else f'{joined:.1f}'} mm (target ≤ 5 mm: joined, they are static where "
        "they came to rest)"
    )
    return lines


def joined_drift_mm(report: dict[str, Any]) -> float | None:
    """The largest drift after release of a component that was joined to the structure (its constructed
    attempt): how far a placement that held moved before it was joined."""
    drifts = [
        placement["drift_mm"]
        for component in report.get("components", [])
        if component.get("state") == "constructed"
        for placement in component.get("placements", [])
        if placement.get("verdict") == "constructed" and placement.get("drift_mm") is not None
    ]
    return max(drifts) if drifts else None
