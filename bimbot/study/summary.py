"""What a study's rows say: ``study.csv``, a markdown table per scenario and a plot of the spread.

A scenario is a fleet with a sequence and a fidelity; its runs are its seeds. The table gives, per
scenario, how many runs built everything, the makespan's mean, standard deviation and range, the mean
utilisation of each robot type, the distance driven and the cost; the figures are over the runs that
wrote a report (``failed`` rows only count). The plot (``study.png``) shows the makespan of every run
per scenario with its mean and range, and the mean utilisation per robot type beside it.
"""

from __future__ import annotations

import csv
import math
import statistics
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from .rows import FAILED, UTILISATION_PREFIX, columns

LEGEND_COLUMNS = 3  # robot types a row of the utilisation legend names
LEGEND_ROW_PERCENT = 9.0  # the axis' height above 100 % a legend row takes

Row = Mapping[str, Any]


def write_csv(rows: Sequence[Row], path: Path) -> None:
    """``rows`` as CSV (empty cells for missing figures), one column per :func:`.rows.columns`."""
    with path.open("w", newline="", encoding="utf-8") as file:
        writer = csv.DictWriter(file, fieldnames=columns(rows), restval="")
        writer.writeheader()
        for row in rows:
            writer.writerow({key: "" if value is None else value for key, value in row.items()})


def read_csv(path: Path) -> list[dict[str, str]]:
    """A ``study.csv`` as it was written (every cell a string)."""
    with path.open(newline="", encoding="utf-8") as file:
        return list(csv.DictReader(file))


def scenario(row: Row) -> str:
    """``carriers`` (``carriers / derive`` when sequences differ, `` / plan`` for another fidelity)."""
    parts = [str(row["fleet"])]
    if row.get("sequence") not in (None, "", "build"):
        parts.append(str(row["sequence"]))
    if row.get("fidelity") not in (None, "", "physics"):
        parts.append(str(row["fidelity"]))
    return " / ".join(parts)


def by_scenario(rows: Sequence[Row]) -> dict[str, list[Row]]:
    """Rows grouped by :func:`scenario`, in the order scenarios first appear."""
    groups: dict[str, list[Row]] = {}
    for row in rows:
        groups.setdefault(scenario(row), []).append(row)
    return groups


def _numbers(rows: Sequence[Row], key: str) -> list[float]:
    return [float(row[key]) for row in rows if row.get(key) not in (None, "")]


def _mean(values: Sequence[float], digits: int = 0, scale: float = 1.0, unit: str = "") -> str:
    return f"{statistics.fmean(values) * scale:.{digits}f}{unit}" if values else "–"


def _spread(values: Sequence[float]) -> str:
    """``812 ± 31 (780–850)``; one value alone, ``–`` for none."""
    if not values:
        return "–"
    if len(values) == 1:
        return f"{values[0]:.0f}"
    sd = statistics.stdev(values)
    return f"{statistics.fmean(values):.0f} ± {sd:.0f} ({min(values):.0f}–{max(values):.0f})"


def robot_types(rows: Sequence[Row]) -> list[str]:
    """The robot types with a utilisation column, sorted."""
    keys = {key for row in rows for key in row if key.startswith(UTILISATION_PREFIX)}
    return sorted(key.removeprefix(UTILISATION_PREFIX) for key in keys)


def markdown_table(rows: Sequence[Row]) -> str:
    """One line per scenario: runs built, makespan spread (sim s), utilisation per type, distance, cost."""
    types = robot_types(rows)
    head = ["scenario", "runs built", "makespan s (mean ± sd, range)", *(f"util. {t}" for t in types)]
    head += ["distance m", "cost", "cost on site"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for name, group in by_scenario(rows).items():
        reported = [row for row in group if row.get("status") != FAILED]
        built = sum(1 for row in group if row.get("status") == "built")
        cells = [name, f"{built}/{len(group)}", _spread(_numbers(reported, "makespan_s"))]
        cells += [_mean(_numbers(reported, UTILISATION_PREFIX + t), 0, 100.0, " %") for t in types]
        cells += [_mean(_numbers(reported, "distance_m")), _mean(_numbers(reported, "cost"), 2)]
        cells.append(_mean(_numbers(reported, "cost_on_site"), 2))
        lines.append("| " + " | ".join(cells) + " |")
    failures = [row for row in rows if row.get("status") != "built"]
    if failures:
        lines += ["", "Runs that did not build everything:", ""]
        lines += [
            f"- {scenario(row)}, seed {row['seed']} ({row['status']}): {row['reason']}" for row in failures
        ]
    return "\n".join(lines) + "\n"


def write_plot(rows: Sequence[Row], path: Path) -> tuple[float, float]:
    """``study.png``: makespan per scenario (every run, mean and range) and mean utilisation per type; the
    makespan axis's limits (s)."""
    from matplotlib.figure import Figure

    groups = by_scenario(rows)
    names = list(groups)
    types = robot_types(rows)
    figure = Figure(figsize=(max(7.0, 2.2 * len(names) + 3.0), 4.2), layout="constrained")
    makespan_axes, utilisation_axes = figure.subplots(1, 2, width_ratios=[1.2, 1.0])
    highest_s = 0.0
    for x, name in enumerate(names):
        values = _numbers([row for row in groups[name] if row.get("status") != FAILED], "makespan_s")
        if not values:
            continue
        highest_s = max(highest_s, *values)
        mean = statistics.fmean(values)
        makespan_axes.scatter([x] * len(values), values, color="tab:blue", alpha=0.6, zorder=3)
        makespan_axes.errorbar(
            [x + 0.15],
            [mean],
            yerr=[[mean - min(values)], [max(values) - mean]],
            fmt="D",
            color="black",
            capsize=5,
            zorder=4,
        )
    makespan_axes.set_xticks(range(len(names)), names, rotation=15)
    makespan_axes.set_xlim(-0.6, len(names) - 0.4)
    # from zero: a spread of seconds on 2,600 s must look like one; room above the highest run
    makespan_axes.set_ylim(0, 1.1 * highest_s if highest_s > 0 else 1.0)
    makespan_axes.set_ylabel("makespan (sim s)")
    makespan_axes.set_title("makespan per scenario: runs, mean and range")
    makespan_axes.grid(axis="y", alpha=0.3)
    width = 0.8 / max(1, len(types))
    for index, robot_type in enumerate(types):
        means = [
            statistics.fmean(values) * 100.0
            if (values := _numbers(groups[n], UTILISATION_PREFIX + robot_type))
            else 0.0
            for n in names
        ]
        offsets = [x - 0.4 + width * (index + 0.5) for x in range(len(names))]
        utilisation_axes.bar(offsets, means, width=width, label=robot_type)
    utilisation_axes.set_xticks(range(len(names)), names, rotation=15)
    # the legend in a band of its own above 100 %, so that it covers no bar (a husky's 84 % was hidden)
    legend_rows = math.ceil(len(types) / LEGEND_COLUMNS)
    utilisation_axes.set_ylim(0, 100 + LEGEND_ROW_PERCENT * legend_rows)
    utilisation_axes.set_yticks(range(0, 101, 20))
    utilisation_axes.set_ylabel("utilisation (% of the makespan)")
    utilisation_axes.set_title("mean utilisation per robot type")
    if types:
        utilisation_axes.legend(fontsize="small", loc="upper center", ncol=LEGEND_COLUMNS, frameon=False)
    utilisation_axes.grid(axis="y", alpha=0.3)
    figure.savefig(path, dpi=110)
    low, high = makespan_axes.get_ylim()
    return float(low), float(high)
