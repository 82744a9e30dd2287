"""``report.png``'s placement panels, under the Gantt chart: how far each placement attempt landed from its
BIM target, per robot type, and how far components moved after they were released.

Left, *placement position error per robot type*: one row per robot type (the order of
``totals.placement_error_mm_by_type``: the Gantt's lane order), a grey box from the quartiles with a black
median and whiskers to the farthest attempts within the 5th–95th percentiles, and every attempt
as a point, jittered across its row (deterministically), shaped and coloured by its cause: a green dot
within tolerance, a red cross released off target (``misplaced``), an orange triangle that moved after
release (``unstable``). A dashed line marks the position tolerance in force (10 mm by default); each row's
label gives its count and p95. Right, *drift after release*: the same rows and markers, each attempt whose
drift was measured, with the largest drift and the retries by cause in the title. The markers, counted
per cause, join the figure's legend under both panels (:func:`placement_handles`). Both x axes are
symmetric-log in mm (linear below 1 mm), since a good placement is a few mm and a fallen one hundreds.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from matplotlib.axes import Axes
from matplotlib.lines import Line2D
from matplotlib.ticker import FuncFormatter

from bimbot.shared.verification import Tolerances

from .methods import hand_placed
from .placements import MISPLACED, UNSTABLE, WITHIN_TOLERANCE, type_of

TOLERANCE_MM = Tolerances().position_m * 1000.0  # the default; a report says the one in force


def tolerance_mm(report: Mapping[str, Any]) -> float:
    """The position tolerance the run judged with (its audit's, else its settings', else the default)."""
    audited = (report.get("as_built") or {}).get("tolerance_mm")
    if audited is not None:
        return float(audited)
    settings = (report.get("settings") or {}).get("tolerances") or {}
    return float(settings.get("position_mm", TOLERANCE_MM))


LINEAR_BELOW_MM = 1.0  # the symmetric-log axis is linear from 0 to here
CAUSE_STYLES: dict[str, dict[str, Any]] = {
    WITHIN_TOLERANCE: {"marker": "o", "color": "tab:green", "label": "within tolerance"},
    MISPLACED: {"marker": "x", "color": "red", "label": "misplaced (released off target)"},
    UNSTABLE: {"marker": "v", "color": "darkorange", "label": "unstable (moved after release)"},
}
_GOLDEN = 0.6180339887498949
Point = tuple[float, str]  # (value in mm, cause)


def rows_by_type(report: Mapping[str, Any]) -> dict[str, list[Mapping[str, Any]]]:
    """Every placement by a hand in ``report`` (work in place left out), grouped by robot type in the
    report's order (see the module)."""
    order = list((report.get("totals") or {}).get("placement_error_mm_by_type") or {})
    rows: dict[str, list[Mapping[str, Any]]] = {name: [] for name in order}
    for component in report.get("components", []):
        if not hand_placed(component):
            continue
        for placement in component.get("placements", []):
            rows.setdefault(type_of(placement), []).append(placement)
    return rows


def work_in_place_note(report: Mapping[str, Any]) -> str | None:
    """What the panels leave out: the verdicts on work in place (poured or laid at its target by physics,
    no hand set it down, so it says nothing of a robot's precision); None when there are none."""
    count = (report.get("totals") or {}).get("work_in_place_verdicts") or 0
    if not count:
        return None
    verdicts = f"{count} verdict{'' if count == 1 else 's'}"
    return f"left out: {verdicts} on work in place (cast, laid or driven: built at its target, not set down)"


def _note(ax: Axes, report: Mapping[str, Any]) -> None:
    note = work_in_place_note(report)
    if note is not None:
        ax.text(0.99, 0.02, note, transform=ax.transAxes, ha="right", va="bottom", fontsize=7, color="0.3")


def _jitter(index: int) -> float:
    """A deterministic offset in [-0.25, 0.25) for the ``index``-th point of a row."""
    return ((index * _GOLDEN) % 1.0 - 0.5) * 0.5


def _points(placements: Sequence[Mapping[str, Any]], field: str) -> list[Point]:
    return [(float(p[field]), p["cause"]) for p in placements if p.get(field) is not None]


def _strip(ax: Axes, rows: Sequence[Sequence[Point]], *, box: bool, tolerance: float = TOLERANCE_MM) -> None:
    """Points of each row (row 0 at the top), a box per row if ``box``."""
    for row, points in enumerate(rows):
        boxed = [value for value, cause in points if cause != UNSTABLE]  # as the distribution (totals)
        if box and boxed:
            ax.boxplot(
                boxed,
                positions=[row],
                orientation="horizontal",
                widths=0.6,
                whis=(5.0, 95.0),
                showfliers=False,
                patch_artist=True,
                boxprops={"facecolor": "0.9", "edgecolor": "0.5"},
                whiskerprops={"color": "0.5"},
                capprops={"color": "0.5"},
                medianprops={"color": "black", "linewidth": 1.5},
            )
        for index, (value, cause) in enumerate(points):
            style = CAUSE_STYLES.get(cause, CAUSE_STYLES[MISPLACED])
            ax.plot(
                [value],
                [row + _jitter(index)],
                linestyle="none",
                marker=style["marker"],
                color=style["color"],
                markersize=5,
                alpha=0.8,
            )
    values = [value for points in rows for value, _ in points]
    ax.set_xscale("symlog", linthresh=LINEAR_BELOW_MM, linscale=0.5)
    ax.xaxis.set_major_formatter(FuncFormatter(lambda value, _: f"{value:g}"))  # 100, not 10²
    ax.set_xlim(-0.1 * LINEAR_BELOW_MM, max([*values, 2.0 * tolerance]) * 1.5)  # 0 mm off the frame
    ax.set_ylim(len(rows) - 0.5, -0.5)  # the first row at the top
    ax.grid(axis="x", alpha=0.3, which="both")


def placement_handles(report: Mapping[str, Any]) -> list[Line2D]:
    """The legend of both panels, for the figure's legend under them: each cause's marker with its count
    over every attempt, and the tolerance line (nothing when no placement was verified)."""
    placements = [p for row in rows_by_type(report).values() for p in row]
    if not placements:
        return []
    handles = [
        Line2D(
            [],
            [],
            linestyle="none",
            marker=style["marker"],
            color=style["color"],
            label=f"{style['label']} ×{sum(1 for p in placements if p['cause'] == cause)}",
        )
        for cause, style in CAUSE_STYLES.items()
    ]
    line_mm = tolerance_mm(report)
    tolerance = Line2D([], [], color="black", linestyle="--", label=f"tolerance {line_mm:g} mm")
    return [*handles, tolerance]


def _no_data(ax: Axes, text: str) -> None:
    ax.text(0.5, 0.5, text, transform=ax.transAxes, ha="center", va="center")
    ax.set_yticks([])


def draw_placement_errors(ax: Axes, report: Mapping[str, Any]) -> None:
    """The left panel (see the module)."""
    ax.set_title("placement position error per robot type (every attempt)")
    ax.set_xlabel("position error (mm, log above 1 mm)")
    rows = rows_by_type(report)
    _note(ax, report)
    if not any(rows.values()):
        _no_data(ax, "no placement was verified")
        return
    distribution = (report.get("totals") or {}).get("placement_error_mm_by_type") or {}
    line_mm = tolerance_mm(report)
    _strip(ax, [_points(p, "position_error_mm") for p in rows.values()], box=True, tolerance=line_mm)
    ax.axvline(line_mm, color="black", linestyle="--", linewidth=1.0)
    labels = []
    for name, placements in rows.items():
        p95 = (distribution.get(name) or {}).get("p95")
        labels.append(
            f"{name}\n{len(placements)} placed" + (f", p95 {p95:.1f} mm" if p95 is not None else "")
        )
    ax.set_yticks(range(len(rows)), labels, fontsize=8)


def draw_drift(ax: Axes, report: Mapping[str, Any]) -> None:
    """The right panel (see the module)."""
    totals = report.get("totals") or {}
    retries = totals.get("retries_by_cause") or {}
    largest = totals.get("max_drift_mm")
    title = "drift after release" + (f": largest {largest:.1f} mm" if largest is not None else "")
    if retries:
        title += "\nretries: " + ", ".join(f"{cause} {count}" for cause, count in retries.items())
    ax.set_title(title)
    ax.set_xlabel("moved after release (mm, log above 1 mm)")
    rows = rows_by_type(report)
    _note(ax, report)
    points = [_points(placements, "drift_mm") for placements in rows.values()]
    if not any(points):
        _no_data(ax, "no drift was measured")
        return
    _strip(ax, points, box=False)
    labels = [f"{name}\n{len(row)} measured" for name, row in zip(rows, points, strict=True)]
    ax.set_yticks(range(len(rows)), labels, fontsize=8)
