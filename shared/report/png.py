"""``report.png``: a Gantt chart of the simulated construction beside the planned sequence, and under them
the placement panels (:mod:`.placements_png`: placement errors per robot type, drift after
release).

Left: one lane per robot, labelled with its type (``r2 (carrier)``), the robots of a type together
(:func:`.report_fleet.robot_order`) with a line between types; a bar per task (the robot left ``idle`` →
came back), coloured by the IFC class of the component it handled, or by its work in place (formwork,
pour, laying: :mod:`.methods_png`); a hand-off task (a ground robot carrying a component to a
crane's staging spot) is hatched and outlined, so it is not taken for a build. A bar is at least
``MIN_BAR_FRACTION`` of the axis wide, and a bar label that would lie on the one before it is left out.
Both panels share one sim-time axis in the unit of its span (s, min, h, days: :mod:`.time_axis`), on
which a long wait with no robot at work (a slab's cure) is a narrow grey band (:mod:`.time_breaks`), so
the lifted work after days of cure still reads.
Its title gives each type's utilisation (busy share of its robots over the makespan).
Right: the planned sequence, one row per component in ``sequence.xml`` order (first at the top), a thin
bar from its release to its pick-up (or the start of its work in place) and a full bar from there to
constructed, in the same colours, a cast component's curing after it hatched grey;
hand-offs to a crane are marked with a black triangle, misplacements with a red cross when detected,
failures with a black one. Every component that is not constructed is marked: a red hatched span from
where it stopped (failed, picked, released, or the start) to the end of the run, its reason code at the
right edge of its row, its label in red, and a legend entry counting the codes. The title gives the
as-built audit made at the end of the run (:mod:`bimbot.run.as_built`: the largest final error of the
constructed components, how many physics has away from their BIM target); each of those has its final
error at the right edge of its row. Both share the sim-time axis, so the chart shows at a glance where
the run waited, which robot did what, whether the building went up in the planned order, and what was not
built and why. Below, how precisely each robot type placed, which placements missed and why, and what moved
after it was released.

Rendered on a bare ``matplotlib.figure.Figure`` (Agg canvas: no pyplot state, no display), at a fixed
size (``FIGURE_SIZE_IN`` × ``DPI``).
"""

from __future__ import annotations

import json
import logging
import math
import textwrap
import warnings
from collections.abc import Collection
from functools import partial
from pathlib import Path
from typing import Any

import matplotlib
from matplotlib import transforms
from matplotlib.artist import Artist
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import to_rgb
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.text import Text

from .building_name import report_building
from .durations import duration_text
from .fleet import lane_label, robot_order, utilisation_line
from .lifts_inset import add_lifts_inset
from .methods import WORK_IN_PLACE
from .methods_png import (
    MIN_BAR_FRACTION,
    STEP_COLORS,
    Segment,
    draw_curing,
    draw_segments,
    method_legend,
    row_work,
    work_segments,
)
from .placements import MISPLACED, RETRY_CAUSES, caught_on_last_attempt
from .placements_png import CAUSE_STYLES, draw_drift, draw_placement_errors, placement_handles
from .time_breaks import TimeBreaks, find_breaks, set_broken_time_axis, task_intervals

_log = logging.getLogger(__name__)
REPORT_JSON = "report.json"
REPORT_PNG = "report.png"
FIGURE_SIZE_IN = (16.0, 12.0)
DPI = 100  # 1600 × 1200 pixels
HEIGHT_RATIOS = (3.0, 1.2)  # the Gantt row over the placement row
LEGEND_ROW = 0.03  # of the figure's height: one row of legend under the panels
TITLE_CHARS_LEFT = 95  # the lanes panel's title wraps here (a fleet's utilisation ran into the next title)
MAX_ROW_LABELS = 60  # beyond this many sequence rows, every k-th row is named (at most this many labels)
NOT_BUILT_COLOR = "red"
NOT_BUILT_HATCH = "////"
HAND_OFF_HATCH = "xx"
HAND_OFF_EDGE = "black"
RGB = tuple[float, float, float]


def _palette(name: str) -> tuple[RGB, ...]:
    """Every colour of a listed (qualitative) colormap, in order, as RGB."""
    colormap = matplotlib.colormaps[name]
    return tuple(to_rgb(colormap(index)) for index in range(colormap.N))


def _far_from(color: RGB, others: Collection[RGB], distance: float = 0.35) -> bool:
    return all(sum((a - b) ** 2 for a, b in zip(color, other, strict=True)) > distance**2 for other in others)


def _distinct(colors: list[RGB], min_distance: float) -> list[RGB]:
    """``colors`` in order, each kept when it lies ``min_distance`` from every one kept before it."""
    kept: list[RGB] = []
    for color in colors:
        if _far_from(color, kept, min_distance):
            kept.append(color)
    return kept


# No red: red marks what was not constructed (a constructed slab in tab10's red looked like the failed
# ones round it on the Revit hub's chart); nor the colours of work in place (formwork, pour, laying,
# driving); nor a grey or a pale colour (curing is hatched grey, a pale bar vanishes on white); and each
# far enough from the ones before it that two classes do not look alike: ten, where tab10 and Dark2
# alone gave seven and the Revit 2025 structural sample's eighth class wore its first one's colour
CLASS_PALETTE = tuple(
    _distinct(
        [
            color
            for color in _palette("tab10") + _palette("Dark2") + _palette("Set1") + _palette("tab20")
            if _far_from(color, [to_rgb(NOT_BUILT_COLOR), *STEP_COLORS.values()])
            and max(color) - min(color) > 0.15
            and sum(color) / 3.0 < 0.85
        ],
        min_distance=0.22,
    )
)


def class_colors(classes: list[str]) -> dict[str, RGB]:
    """A stable colour per IFC class (sorted by name, so a class keeps its colour between runs)."""
    return {
        name: CLASS_PALETTE[index % len(CLASS_PALETTE)] for index, name in enumerate(sorted(set(classes)))
    }


def row_label_size_pt(rows: int) -> float:
    """The sequence rows' label size: as large as a row's height allows, from 6 pt (60 rows, beyond which
    labels are left out) to 10 pt (up to about 30 rows): the bundled frame's 28 labels read at 10 pt."""
    panel_pt = FIGURE_SIZE_IN[1] * 72.0 * HEIGHT_RATIOS[0] / sum(HEIGHT_RATIOS) * 0.85
    return max(6.0, min(10.0, 0.6 * panel_pt / max(rows, 1)))


def labelled_rows(rows: int) -> range:
    """The sequence rows that get a label: all up to :data:`MAX_ROW_LABELS`, else every k-th from the first
    (k the smallest step that keeps to that many), so a user can still find a row of an 85-member frame."""
    step = max(1, -(-rows // MAX_ROW_LABELS))
    return range(0, rows, step)


def with_marked_rows(named: range, marked: Collection[int]) -> list[int]:
    """``named`` plus the ``marked`` rows (a placement caught off target or unstable, an as-built error: what
    a user looks for), each taking the place of a named neighbour whose label would overlap it; at most a
    quarter of :data:`MAX_ROW_LABELS` of them, the first in the sequence. A new user could not tell which
    component of the hub's 85 had toppled: its row was one of the unnamed. Of marked rows closer than a
    label's height only the first is named (twelve toppled beams in a row had piled twelve labels into one
    smudge)."""
    if named.step == 1:
        return list(named)
    # a label is about ``named.step`` rows high: marks closer than that, or a named row that close to a
    # mark, overlap it (the structural sample's 937 rows, a label every 16th, piled marks 6 rows apart)
    gap = named.step
    extra: list[int] = []
    for row in sorted(set(marked)):
        if len(extra) < MAX_ROW_LABELS // 4 and (not extra or row - extra[-1] >= gap):
            extra.append(row)
    kept = [row for row in named if row in extra or all(abs(row - mark) >= gap for mark in extra)]
    return sorted(set(kept) | set(extra))


def marked_row(component: dict[str, Any], wrong: Collection[str]) -> bool:
    """Whether a sequence row carries a mark a user looks for: a placement caught, an as-built error."""
    verdicts = {placement.get("verdict") for placement in component.get("placements", [])}
    caught = bool(verdicts & {"misplaced", "failed"})
    return caught or component["guid"] in wrong


LANES_PANEL_PT = FIGURE_SIZE_IN[0] * 72.0 * 0.6 * 0.85  # the lanes panel: 3/5 of the width, less margins


def bar_label_size_pt(width_s: float, span_s: float) -> float:
    """A task bar's label size (the label runs along the bar's height): as thick as the bar is wide on the
    lanes panel, 5–9 pt."""
    return max(5.0, min(9.0, 0.7 * LANES_PANEL_PT * width_s / max(span_s, 1e-9)))


HAND_OFF_PREFIX = "→ "  # a hand-off task's bar label: the load goes to a crane's staging spot


def fit_bar_labels(figure: Figure, ax: Axes, labels: list[Text]) -> None:
    """Cut each task bar's label to the height of its bar as drawn, after the layout, keeping its end: a
    Revit name such as 'Concrete-Rectangular-Column:300x300:318275' ran over the lanes above and below,
    and its end (type and element id) is what tells one bar from the next ("…300x300:318275")."""
    if not labels:
        return
    renderer = FigureCanvasAgg(figure).get_renderer()
    low, high = ax.transData.transform([(0.0, -0.4), (0.0, 0.4)])
    bar_px = abs(float(high[1] - low[1]))
    for label in labels:
        full = label.get_text()
        length_px = label.get_window_extent(renderer).height
        if length_px <= bar_px:
            continue
        prefix = HAND_OFF_PREFIX if full.startswith(HAND_OFF_PREFIX) else ""
        body = full[len(prefix) :]
        keep = int(len(body) * bar_px / length_px)  # a first guess, then shorter until it fits
        while keep > 0:
            label.set_text(f"{prefix}…{body[-keep:]}")
            if label.get_window_extent(renderer).height <= bar_px:
                break
            keep -= 1
        if keep <= 0:
            label.set_text("")


def _short(component: dict[str, Any]) -> str:
    return component.get("name") or component["guid"][:8]


def chart_span_s(report: dict[str, Any]) -> float:
    """The sim time the Gantt and sequence panels span: to the last task's end, construction, failure or
    curing, or the run's end."""
    times = [float(report.get("sim_time_s") or 0.0)]
    for robot in report["robots"].values():
        times += [task["end_s"] for task in robot["tasks"]]
    for component in report["components"]:
        times += [component[name] for name in ("constructed_s", "failed_s") if component.get(name)]
        if component.get("curing"):
            times.append(component["curing"]["until_s"])
    return max(*times, 1.0)


def _robot_lanes(
    ax: Axes, report: dict[str, Any], colors: dict[str, RGB], breaks: TimeBreaks | None = None
) -> list[Text]:
    """The Gantt lanes over the time axis ``breaks`` (default: :func:`chart_span_s`, linear); the task
    bars' labels (fitted to their bars once the figure is laid out). A label that would lie on the one
    before it in its lane is left out (the sequence panel names every row)."""
    breaks = breaks or TimeBreaks(chart_span_s(report))
    robots = report["robots"]
    robot_ids = robot_order(robots)
    labels = draw_lane_tasks(ax, report, robot_ids, colors, breaks)
    for lane in range(1, len(robot_ids)):  # a line where one robot type's lanes end
        if robots[robot_ids[lane]].get("type") != robots[robot_ids[lane - 1]].get("type"):
            ax.axhline(lane - 0.5, color="black", linewidth=0.8, alpha=0.6)
    ax.set_yticks(range(len(robot_ids)), [lane_label(r, robots[r]) for r in robot_ids])
    ax.set_ylim(-0.6, max(len(robot_ids), 1) - 0.4)
    ax.invert_yaxis()
    set_broken_time_axis(ax, breaks)
    utilisation = utilisation_line(report)
    title = "simulated construction: one lane per robot, grouped by type"
    wrapped = textwrap.fill(utilisation, TITLE_CHARS_LEFT) if utilisation else ""
    ax.set_title(title + (f"\n{wrapped}" if wrapped else ""))
    ax.grid(axis="x", alpha=0.3)
    if not robot_ids:
        ax.text(0.5, 0.5, "no robot reported a state", transform=ax.transAxes, ha="center", va="center")
    return labels


def draw_lane_tasks(
    ax: Axes, report: dict[str, Any], robot_ids: list[str], colors: dict[str, RGB], breaks: TimeBreaks
) -> list[Text]:
    """The task bars of ``robot_ids``, one lane each in that order, and their labels."""
    span_s = breaks.shown_s  # bar widths and labels are sized in axis units (a break's scale differs)
    labels: list[Text] = []
    by_guid = {c["guid"]: c for c in report["components"]}
    robots = report["robots"]
    for lane, robot_id in enumerate(robot_ids):
        last_label_s = -math.inf
        for task in robots[robot_id]["tasks"]:
            component = by_guid.get(task["guid"] or "")
            color = colors.get(component["ifc_class"], "grey") if component else "lightgrey"
            width = task["end_s"] - task["start_s"]
            min_width_s = MIN_BAR_FRACTION * span_s / breaks.scale_at(task["start_s"])
            hand_off = task.get("kind") == "hand_off"
            if hand_off:
                ax.broken_barh(
                    [(task["start_s"], max(width, min_width_s))],
                    (lane - 0.4, 0.8),
                    facecolors=color,
                    edgecolors=HAND_OFF_EDGE,
                    hatch=HAND_OFF_HATCH,
                    linewidth=1.0,
                )
            else:
                segments = work_segments(component, task["start_s"], task["end_s"])
                draw_segments(
                    ax, segments, (lane - 0.4, 0.8), component, class_color=color, min_width_s=min_width_s
                )
            width_shown = width * breaks.scale_at(task["start_s"])
            size_pt = bar_label_size_pt(width_shown, span_s)
            centre_s = task["start_s"] + width / 2
            centre_shown = float(breaks.forward(centre_s))
            if component and width > 0 and centre_shown - last_label_s >= label_width_s(size_pt, span_s):
                label = ax.text(
                    centre_s,
                    lane,
                    (HAND_OFF_PREFIX if hand_off else "") + _short(component),
                    ha="center",
                    va="center",
                    fontsize=size_pt,
                    rotation=90,
                    clip_on=True,
                    color="white" if component.get("method") in WHITE_LABEL_METHODS else "black",
                )
                labels.append(label)
                last_label_s = centre_shown
    return labels


WHITE_LABEL_METHODS = ("cast_in_place",)  # its navy and teal bars: a black label would not read


def label_width_s(size_pt: float, span_s: float) -> float:
    """How much sim time a rotated label of ``size_pt`` covers on the lanes panel (its thickness)."""
    return size_pt * span_s / LANES_PANEL_PT


def _hand_off_legend(report: dict[str, Any]) -> list[Patch]:
    count = report["totals"].get("hand_off_tasks") or 0
    if not count:
        return []
    label = f"hand-off to a crane's staging area ×{count}"
    return [Patch(facecolor="white", edgecolor=HAND_OFF_EDGE, hatch=HAND_OFF_HATCH, label=label)]


def _sequence_rows(ax: Axes, report: dict[str, Any], colors: dict[str, RGB], breaks: TimeBreaks) -> None:
    span_s = breaks.shown_s
    wrong = set((report.get("as_built") or {}).get("wrong", []))
    rows = sorted(
        report["components"],
        key=lambda c: (c["sequence_index"] is None, c["sequence_index"] or 0, c["guid"]),
    )
    regular = labelled_rows(len(rows))
    named = with_marked_rows(regular, [row for row, c in enumerate(rows) if marked_row(c, wrong)])
    for row, component in enumerate(rows):
        labelled = row in named  # a reason or error at the right edge too (else they pile up)
        color = colors[component["ifc_class"]]
        released, picked = component["released_s"], component["picked_s"]
        done = component["constructed_s"] if component["constructed_s"] is not None else component["failed_s"]
        work = row_work(component)  # cast, laid or driven: its work in place instead of pick → placed
        wait_color: RGB | str = color
        if work is not None:
            picked = work[0]
            # its wait in its work's colour, as the legend has it (in its class's, the structural sample's
            # 216 piles drew long lines in a colour no legend entry had)
            first_step = next((step for _, _, step in work[1] if step is not None), None)
            wait_color = STEP_COLORS[first_step] if first_step is not None else color
        if released is not None and picked is not None:
            ax.plot([released, picked], [row, row], color=wait_color, linewidth=1.0, alpha=0.6)
        if picked is not None and done is not None:
            segments: list[Segment] = work[1] if work is not None else [(picked, done, None)]
            min_width_s = MIN_BAR_FRACTION * span_s / breaks.scale_at(picked)
            y = (row - 0.35, 0.7)
            draw_segments(ax, segments, y, component, class_color=color, min_width_s=min_width_s)
        draw_curing(ax, row, component)
        for handed_off_s in component.get("handed_off_s", []):  # put down for a crane
            ax.plot([handed_off_s], [row], marker="v", color=HAND_OFF_EDGE, markersize=5)
        for misplaced_s, cause in retry_causes(component):  # each retry with its cause's marker (legend)
            style = CAUSE_STYLES[cause]
            ax.plot([misplaced_s], [row], marker=style["marker"], color=style["color"], markersize=7)
        if component["failed_s"] is not None:
            ax.plot([component["failed_s"]], [row], marker="x", color="black", markersize=8)
        if component.get("reason"):
            end_s = float(report.get("sim_time_s") or 0.0)
            _mark_not_built(ax, row, component, end_s=end_s, labelled=labelled)
        elif component["guid"] in wrong and labelled:
            _mark_at_right(ax, row, f"as-built {component['final_position_error_mm'] or 0.0:.1f} mm")
    ax.set_yticks(
        named,
        [f"{(rows[row]['sequence_index'] or 0) + 1}. {_short(rows[row])}" for row in named],
        fontsize=row_label_size_pt(len(named)),
    )
    for label, row in zip(ax.get_yticklabels(), named, strict=True):
        if rows[row].get("reason"):
            label.set_color(NOT_BUILT_COLOR)
    if regular.step > 1:
        ax.set_ylabel(
            f"{len(rows)} components in planned order (one row in {regular.step} named, and those with marks)"
        )
    ax.set_ylim(-0.6, max(len(rows), 1) - 0.4)
    ax.invert_yaxis()
    set_broken_time_axis(ax, breaks)
    ax.set_title("planned sequence (top = first)\nrelease ─ pick or start of work ▬ constructed")
    ax.grid(axis="x", alpha=0.3)


def retry_causes(component: dict[str, Any]) -> list[tuple[float, str]]:
    """(sim time, cause) of each retried placement: the cause its verdict gave (``misplaced`` or
    ``unstable``, :mod:`.placements`), ``misplaced`` when no placement of that time is recorded."""
    causes = {
        round(float(p["sim_time_s"]), 3): p["cause"]
        for p in component.get("placements", [])
        if p.get("cause") in RETRY_CAUSES
    }
    return [(t, causes.get(round(float(t), 3), MISPLACED)) for t in component.get("misplaced_s", [])]


def _mark_not_built(
    ax: Axes, row: int, component: dict[str, Any], end_s: float, *, labelled: bool = True
) -> None:
    """A red hatched span from where the component stopped to the end of the run, and (``labelled``) its
    reason code."""
    stops = (component["failed_s"], component["picked_s"], component["released_s"])
    start = next((t for t in stops if t is not None), 0.0)
    ax.broken_barh(
        [(start, max(end_s - start, 0.0))],
        (row - 0.3, 0.6),
        facecolors="none",
        edgecolors=NOT_BUILT_COLOR,
        hatch=NOT_BUILT_HATCH,
        linewidth=0.5,
    )
    if labelled:
        _mark_at_right(ax, row, component["reason"]["code"])


def _mark_at_right(ax: Axes, row: int, text: str) -> None:
    """``text`` in red at the right edge of a sequence row (a reason code, an as-built error)."""
    right_edge = transforms.blended_transform_factory(ax.transAxes, ax.transData)
    ax.text(
        0.995,
        row,
        text,
        transform=right_edge,
        ha="right",
        va="center",
        fontsize=6,
        color=NOT_BUILT_COLOR,
        clip_on=True,
        bbox={"facecolor": "white", "edgecolor": "none", "pad": 0.5},
    )


def _not_built_legend(report: dict[str, Any]) -> list[Artist]:
    """The hatch of what was not built, with its reasons counted, and the cross marking when a component
    failed (at sim 0 for one the planner found it cannot build)."""
    by_reason = report["totals"].get("by_reason") or {}
    if not by_reason:
        return []
    counts = ", ".join(f"{code} ×{count}" for code, count in by_reason.items())
    label = f"not constructed: {counts}"
    handles: list[Artist] = [
        Patch(facecolor="none", edgecolor=NOT_BUILT_COLOR, hatch=NOT_BUILT_HATCH, label=label)
    ]
    if any(component.get("failed_s") is not None for component in report["components"]):
        handles.append(
            Line2D([], [], marker="x", color="black", linestyle="none", markersize=8, label="failed (when)")
        )
    return handles


def caught_last_title(report: dict[str, Any]) -> str:
    last = caught_on_last_attempt(report)
    return f" (and {last} caught on a last attempt)" if last else ""


def _as_built_title(report: dict[str, Any]) -> str:
    """The as-built audit for the title: the largest final error of the constructed components, and how
    many are away from their target (nothing before the audit)."""
    audit, totals = report.get("as_built") or {}, report["totals"]
    if not audit.get("answered"):
        return ""
    position_mm, angle_deg = (
        totals.get("max_final_position_error_mm"),
        totals.get("max_final_angle_error_deg"),
    )
    largest = f" max {position_mm:.2f} mm / {angle_deg:.2f}°," if position_mm is not None else ""
    errors = len(audit.get("errors", []))
    return f" — as-built:{largest} {errors} error{'' if errors == 1 else 's'}"


def report_figure(report: dict[str, Any]) -> Figure:
    """The chart of ``report`` (from :meth:`.report.ReportCollector.report`): axes in the order Gantt lanes,
    planned sequence, placement errors, drift."""
    colors = class_colors([c["ifc_class"] for c in report["components"]])
    breaks = find_breaks(task_intervals(report), chart_span_s(report))
    figure = Figure(figsize=FIGURE_SIZE_IN, dpi=DPI)  # no pyplot: no global state, no display needed
    grid = figure.add_gridspec(2, 2, width_ratios=(3, 2), height_ratios=HEIGHT_RATIOS)
    lanes = figure.add_subplot(grid[0, 0])
    sequence = figure.add_subplot(grid[0, 1], sharex=lanes)
    labels = _robot_lanes(lanes, report, colors, breaks)
    # lifts that a long work in place squeezes into a sliver, drawn again zoomed in
    inset = add_lifts_inset(
        lanes, report, robot_order(report["robots"]), breaks, partial(draw_lane_tasks, colors=colors)
    )
    _sequence_rows(sequence, report, colors, breaks)
    draw_placement_errors(figure.add_subplot(grid[1, 0]), report)
    draw_drift(figure.add_subplot(grid[1, 1]), report)
    totals = report["totals"]
    makespan = totals.get("makespan_s")
    ending = report.get("ending") or {}
    how = ending.get("how")
    figure.suptitle(
        f"bimbot construction report — {report_building(report)}: "
        f"{totals['constructed']}/{totals['components']} constructed, retries: {totals['retries']}"
        + caught_last_title(report)
        + (f", makespan {duration_text(makespan)}" if makespan is not None else "")
        + (f" — run {how}" if how and how != "done" else "")
        + _as_built_title(report)
    )
    # the classes drawn in their own colour: work in place is drawn in its steps' colours
    drawn = {c["ifc_class"] for c in report["components"] if c.get("method") not in WORK_IN_PLACE}
    handles: list[Artist] = [Patch(color=c, label=name) for name, c in colors.items() if name in drawn]
    handles += [*method_legend(report), *_hand_off_legend(report), *_not_built_legend(report)]
    bottom = LEGEND_ROW * fitting_legend(figure, handles)
    placements = placement_handles(report)
    if placements:  # a row of its own, just under the placement panels
        figure.legend(
            handles=placements,
            loc="lower center",
            bbox_to_anchor=(0.5, bottom),
            ncol=len(placements),
            frameon=False,
        )
        bottom += LEGEND_ROW
    figure.tight_layout(rect=(0.0, bottom, 1.0, 0.97))
    fit_bar_labels(figure, lanes, labels)
    if inset is not None:
        fit_bar_labels(figure, *inset)
    # laid out: without a layout engine, savefig draws the figure once (with the placeholder engine that
    # tight_layout leaves behind it first draws it a second time, for a layout already done)
    figure.set_layout_engine(None)
    return figure


def fitting_legend(figure: Figure, handles: list[Artist], max_columns: int = 8) -> int:
    """The figure's legend at its foot, in as many columns (up to ``max_columns``) as fit its width; the
    number of rows it takes. Eight columns of the Revit hub's classes and reasons ran off both edges."""
    renderer = FigureCanvasAgg(figure).get_renderer()
    columns = min(len(handles), max_columns) or 1
    while True:
        legend = figure.legend(handles=handles, loc="lower center", ncol=columns, frameon=False)
        if columns == 1 or legend.get_window_extent(renderer).width <= 0.98 * figure.bbox.width:
            return -(-len(handles) // columns)
        legend.remove()
        columns -= 1


def render_report_png(report: dict[str, Any], path: Path) -> Path:
    """Draw ``report`` (from :meth:`.report.ReportCollector.report`) into ``path``."""
    path = Path(path)
    report_figure(report).savefig(path, dpi=DPI)
    return path


def write_report_files(report: dict[str, Any], report_dir: Path) -> None:
    """``report.json`` and ``report.png`` in ``report_dir``, each written whole and then renamed (a reader
    never sees half a file)."""
    write_report_json(report, report_dir)
    write_report_png(report, report_dir)


def write_report_json(report: dict[str, Any], report_dir: Path) -> None:
    """``report.json`` alone (written whole, then renamed): milliseconds, where the plot takes seconds."""
    report_dir = Path(report_dir)
    report_dir.mkdir(parents=True, exist_ok=True)
    json_tmp = report_dir / f".{REPORT_JSON}.tmp"
    json_tmp.write_text(json.dumps(report, indent=2), encoding="utf-8")
    json_tmp.replace(report_dir / REPORT_JSON)


def write_report_png(report: dict[str, Any], report_dir: Path) -> None:
    """``report.png`` alone (drawn whole, then renamed)."""
    report_dir = Path(report_dir)
    report_dir.mkdir(parents=True, exist_ok=True)
    png_tmp = report_dir / f".{REPORT_PNG}.tmp.png"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        render_report_png(report, png_tmp)
    missing = sorted({str(w.message).split(" (")[0] for w in caught if "missing from font" in str(w.message)})
    if missing:  # a Chinese model's names: one line, not a warning per glyph per draw
        _log.info(
            "report.png: the plot's font has no glyph for %d character(s) of the names (%s); they show as "
            "boxes (a CJK font such as fonts-noto-cjk draws them)",
            len(missing),
            ", ".join(m.replace("Glyph ", "") for m in missing[:3]),
        )
    for other in caught:
        if "missing from font" not in str(other.message):
            warnings.warn_explicit(other.message, other.category, other.filename, other.lineno)
    png_tmp.replace(report_dir / REPORT_PNG)
