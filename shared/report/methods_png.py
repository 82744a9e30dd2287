"""``report.png`` by construction method: how a bar is drawn for the way its component was built.

* lifted: the colour of its IFC class (as before methods existed);
* panelised: its class colour, hatched ``//`` (a panel cut from an element, lifted like any part);
* cast in place: the formwork in navy and the pour in teal, the colours the live viewer gives the states
  ``forming`` and ``pouring`` (:mod:`.state_colors`), split where the component's agent entered
  ``pouring``; its curing after the pour as a grey hatched span on its sequence row (until the planner's
  hold on it ended, else constructed + ``cast.cure_s``: :mod:`.methods`);
* laid: the laying in magenta (the viewer's ``laying``).

A legend entry per method present, counted, joins the figure's legend (when not every component was
lifted). Pure functions over the report
dictionary; the axes are the caller's.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from matplotlib.artist import Artist
from matplotlib.axes import Axes
from matplotlib.patches import Patch

from bimbot.shared.construction_methods import ConstructionMethod
from bimbot.shared.messages import ComponentState

from ..state_colors import STATE_COLORS, unit_rgb
from .methods import method_word

RGB = tuple[float, float, float]
FORMWORK, POUR, LAYING, DRIVING = "formwork", "pour", "laying", "driving"
STEP_COLORS: dict[str, RGB] = {
    FORMWORK: unit_rgb(STATE_COLORS[ComponentState.FORMING]),
    POUR: unit_rgb(STATE_COLORS[ComponentState.POURING]),
    LAYING: unit_rgb(STATE_COLORS[ComponentState.LAYING]),
    DRIVING: unit_rgb(STATE_COLORS[ComponentState.DRIVING]),
}
PANEL_HATCH = "///"
CURING_HATCH = "\\\\\\"
CURING_EDGE = "0.45"
NO_BARS = (ConstructionMethod.WITH_HOST.value, ConstructionMethod.IN_PLACE.value)  # not built as tasks
MIN_BAR_FRACTION = 0.006  # of the time axis: the narrowest bar drawn (a 30 s lift in a 3-day run: 3-5 px)
Segment = tuple[float, float, str | None]  # (start s, end s, work step or None: the component's own bar)


def work_segments(component: Mapping[str, Any] | None, start_s: float, end_s: float) -> list[Segment]:
    """The parts of ``[start_s, end_s]`` (a robot's task, a component's work) by work step: a cast
    component's formwork up to its ``pouring_s`` and its pour after; a laid one's laying; a driven pile's
    driving; else the whole span as the component's own bar."""
    method = (component or {}).get("method")
    if method == ConstructionMethod.LAID.value:
        return [(start_s, end_s, LAYING)]
    if method == ConstructionMethod.DRIVEN.value:
        return [(start_s, end_s, DRIVING)]
    if method != ConstructionMethod.CAST_IN_PLACE.value:
        return [(start_s, end_s, None)]
    pouring_s = (component or {}).get("pouring_s")
    if pouring_s is None or pouring_s >= end_s:
        return [(start_s, end_s, FORMWORK)]
    if pouring_s <= start_s:
        return [(start_s, end_s, POUR)]
    return [(start_s, pouring_s, FORMWORK), (pouring_s, end_s, POUR)]


def bar_style(
    component: Mapping[str, Any] | None, step: str | None, class_color: RGB | str
) -> dict[str, Any]:
    """``broken_barh`` keywords of one segment: its step's colour, else its class colour (hatched for a
    panel)."""
    if step is not None:
        return {"facecolors": STEP_COLORS[step], "edgecolors": "white", "linewidth": 0.5}
    panel = (component or {}).get("method") == ConstructionMethod.PANELISED.value
    return {
        "facecolors": class_color,
        "edgecolors": "white",
        "hatch": PANEL_HATCH if panel else None,
        "linewidth": 0.5,
    }


def draw_segments(
    ax: Axes,
    segments: list[Segment],
    y: tuple[float, float],
    component: Mapping[str, Any] | None,
    *,
    class_color: RGB | str,
    min_width_s: float,
) -> None:
    """Each segment as a bar of at least ``min_width_s`` (so a short lift shows on a run of days)."""
    for start_s, end_s, step in segments:
        width = max(end_s - start_s, min_width_s)
        ax.broken_barh([(start_s, width)], y, **bar_style(component, step, class_color))


def row_work(component: Mapping[str, Any]) -> tuple[float, list[Segment]] | None:
    """A sequence row's work in place: (when its work began, its segments up to constructed or failed),
    None for a component that was not built in place or never started."""
    done = component.get("constructed_s")
    if done is None:
        done = component.get("failed_s")
    start = component.get("forming_s")
    if component.get("method") == ConstructionMethod.LAID.value:
        start = component.get("laying_s")
    if component.get("method") == ConstructionMethod.DRIVEN.value:
        start = component.get("driving_s")
    if start is None or done is None:
        return None
    return start, work_segments(component, start, done)


def draw_curing(ax: Axes, row: int, component: Mapping[str, Any]) -> None:
    """A cast component's curing on its sequence row: a grey hatched span from the pour to its end."""
    curing = component.get("curing")
    if not curing:
        return
    ax.broken_barh(
        [(curing["from_s"], max(curing["until_s"] - curing["from_s"], 0.0))],
        (row - 0.3, 0.6),
        facecolors="none",
        edgecolors=CURING_EDGE,
        hatch=CURING_HATCH,
        linewidth=0.5,
    )


def method_legend(report: Mapping[str, Any]) -> list[Artist]:
    """A legend entry per method present in ``report`` (see the module), counted; none when every
    component was lifted (the classes' entries say it all)."""
    counts = (report.get("totals") or {}).get("by_method") or {}
    methods = {name: entry for name, entry in counts.items() if name not in NO_BARS}
    handles: list[Artist] = []
    if set(methods) <= {ConstructionMethod.LIFTED.value}:
        return handles
    for name, entry in methods.items():
        count = f"×{entry['components']}"
        if name == ConstructionMethod.CAST_IN_PLACE.value:
            handles += [
                Patch(color=STEP_COLORS[FORMWORK], label=f"cast in place {count}: formwork"),
                Patch(color=STEP_COLORS[POUR], label="cast in place: pour"),
            ]
            if any(component.get("curing") for component in report.get("components", [])):
                handles.append(
                    Patch(
                        facecolor="none",
                        edgecolor=CURING_EDGE,
                        hatch=CURING_HATCH,
                        label="curing (what rests on it waits)",
                    )
                )
        elif name == ConstructionMethod.LAID.value:
            handles.append(Patch(color=STEP_COLORS[LAYING], label=f"laid {count}: courses"))
        elif name == ConstructionMethod.DRIVEN.value:
            handles.append(Patch(color=STEP_COLORS[DRIVING], label=f"driven {count}: piles"))
        elif name == ConstructionMethod.PANELISED.value:
            handles.append(
                Patch(facecolor="0.75", edgecolor="white", hatch=PANEL_HATCH, label=f"panelised {count}")
            )
        else:
            handles.append(Patch(facecolor="0.75", label=f"{method_word(name)} {count} (its class colour)"))
    return handles
