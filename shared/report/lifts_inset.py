"""The lifts drawn again, zoomed in, where a long work in place squeezes them into a sliver (matplotlib).

Why: on the Revit house three carriers and a crane make 54 lifts in about two hours at 79 h of sim time,
beside 86 h of formwork and pours on one concrete pump. report.png's lanes showed them as one green
sliver: a builder could not tell one lift, one robot or one hand-off from the next. When the window of the
lifting robots' tasks is drawn narrower than ``INSET_WHEN_FRACTION`` of the time axis, their lanes are
drawn again over that window, in an inset set where no bar is: beside the window, over lanes that are
empty there (the lifting robots' own, which have nothing else to do).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from matplotlib import transforms
from matplotlib.axes import Axes
from matplotlib.text import Text
from matplotlib.ticker import FuncFormatter, MaxNLocator

from .fleet import lane_label
from .methods import WORK_IN_PLACE
from .time_breaks import TimeBreaks

INSET_WHEN_FRACTION = 0.08  # the lifts' window drawn narrower than this share of the axis: an inset
MIN_FREE_LANES = 2  # lanes the inset needs, free of bars beside the window
PAD_FRACTION = 0.06  # of the free side's width, kept clear at each end (the inset's lane labels)
FONT_PT = 7.0

DrawLanes = Callable[..., list[Text]]  # (ax, report, robot_ids, breaks=…) → the bars' labels


def lifting_robots(report: dict[str, Any], robot_ids: list[str]) -> list[str]:
    """The robots, in lane order, with a task that is not work in place (a lift, a hand-off)."""
    methods = {c["guid"]: c.get("method") for c in report["components"]}
    return [
        robot_id
        for robot_id in robot_ids
        if any(
            methods.get(task.get("guid") or "") not in WORK_IN_PLACE
            for task in report["robots"][robot_id]["tasks"]
        )
    ]


def add_lifts_inset(
    ax: Axes, report: dict[str, Any], robot_ids: list[str], breaks: TimeBreaks, draw: DrawLanes
) -> tuple[Axes, list[Text]] | None:
    """An inset of ``ax`` (the lanes, over ``breaks``) with the lifting robots' lanes over their window,
    drawn by ``draw``; the inset and its bars' labels, or None when the lifts read well as they are or no
    place beside them is free."""
    lifting = lifting_robots(report, robot_ids)
    tasks = [task for robot_id in lifting for task in report["robots"][robot_id]["tasks"]]
    if not tasks or len(lifting) == len(robot_ids):
        return None
    start_s = min(float(task["start_s"]) for task in tasks)
    end_s = max(float(task["end_s"]) for task in tasks)
    shown = breaks.shown_s
    left, right = float(breaks.forward(start_s)), float(breaks.forward(end_s))
    if right - left > INSET_WHEN_FRACTION * shown or end_s <= start_s:
        return None
    low, high = (right, shown) if shown - right >= left else (0.0, left)
    pad = PAD_FRACTION * (high - low)
    low, high = low + 3 * pad, high - pad  # more room on the left: the inset's lane labels
    side_s = (float(breaks.inverse(low)), float(breaks.inverse(high)))
    lanes = _longest_free_run(report, robot_ids, side_s)
    if len(lanes) < MIN_FREE_LANES:
        return None
    count = max(len(robot_ids), 1)
    top = (count - 0.4 - (lanes[0] - 0.45)) / count  # axes fraction of an inverted lane axis
    bottom = (count - 0.4 - (lanes[-1] + 0.45)) / count
    top, bottom = top - (top - bottom) * 0.1, bottom + (top - bottom) * 0.18  # its title, its time axis
    place = transforms.blended_transform_factory(ax.transData, ax.transAxes)
    inset = ax.inset_axes((side_s[0], bottom, side_s[1] - side_s[0], top - bottom), transform=place)
    labels = draw(inset, report, lifting, breaks=TimeBreaks(end_s - start_s))
    margin_s = 0.02 * (end_s - start_s)
    inset.set_xlim(start_s - margin_s, end_s + margin_s)
    inset.set_ylim(len(lifting) - 0.4, -0.6)
    robots = report["robots"]
    inset.set_yticks(range(len(lifting)), [lane_label(r, robots[r]).split(" ")[0] for r in lifting])
    inset.xaxis.set_major_locator(MaxNLocator(nbins=5))
    inset.xaxis.set_major_formatter(FuncFormatter(lambda value, _: f"{value / 3600:.1f}"))
    inset.tick_params(labelsize=FONT_PT, length=2, pad=1)
    inset.set_title(
        f"the lifts, zoomed in: {start_s / 3600:.1f}–{end_s / 3600:.1f} h of sim time",
        fontsize=FONT_PT,
        pad=2,
    )
    inset.grid(axis="x", alpha=0.3)
    ax.axvspan(start_s, end_s, color="black", alpha=0.08, linewidth=0, zorder=0)  # where it is zoomed from
    return inset, labels


def _longest_free_run(report: dict[str, Any], robot_ids: list[str], side_s: tuple[float, float]) -> list[int]:
    """The longest run of neighbouring lanes with no task overlapping ``side_s``."""
    best: list[int] = []
    run: list[int] = []
    for lane, robot_id in enumerate(robot_ids):
        busy = any(
            float(task["start_s"]) < side_s[1] and float(task["end_s"]) > side_s[0]
            for task in report["robots"][robot_id]["tasks"]
        )
        run = [] if busy else [*run, lane]
        if len(run) > len(best):
            best = run
    return best
