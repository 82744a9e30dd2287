"""The report of a run with work in place (see method_run): each component's method and resources, the
times of its formwork, pour and laying, its curing, the totals by method, and the placement figures
without the work in place; report.png's legend of methods, its curing span and its time axis in hours."""

from __future__ import annotations

import pytest
from matplotlib.axes import Axes
from matplotlib.collections import PolyCollection
from matplotlib.colors import to_rgb
from method_run import END_S, FIRST_CURED_S, TYPES, method_manifest, method_messages

from bimbot.shared.manifest import Manifest
from bimbot.shared.report.collector import ReportCollector
from bimbot.shared.report.durations import duration_text, in_unit_text, spoken_unit, time_unit
from bimbot.shared.report.methods import curing_line
from bimbot.shared.report.methods_png import (
    CURING_HATCH,
    FORMWORK,
    POUR,
    RGB,
    STEP_COLORS,
    method_legend,
)
from bimbot.shared.report.png import chart_span_s, report_figure
from bimbot.shared.report.time_breaks import BREAK_WIDTH, find_breaks, task_intervals


@pytest.fixture(scope="module")
def manifest(frame_manifest: Manifest) -> Manifest:
    return method_manifest(frame_manifest)


@pytest.fixture(scope="module")
def report(manifest: Manifest) -> dict:
    collector = ReportCollector(manifest, [c.guid for c in manifest.components])
    collector.robot_type_of.update(TYPES)  # as bimbot run gives its fleet's types
    for message in method_messages(manifest):
        collector.add(message)
    return collector.report()


def _entry(report: dict, index: int, manifest: Manifest) -> dict:
    guid = manifest.components[index].guid
    return next(c for c in report["components"] if c["guid"] == guid)


def test_a_cast_component_has_its_method_its_machine_its_formwork_pour_and_curing(
    report: dict, manifest: Manifest
) -> None:
    first = _entry(report, 0, manifest)
    assert (first["method"], first["method_source"]) == ("cast_in_place", "rule")
    assert first["resources"] == ["pump"]
    assert (first["forming_s"], first["pouring_s"], first["placed_s"]) == (1.0, 14401.0, 16201.0)
    assert first["laying_s"] is None
    column = manifest.components[9].guid
    assert first["curing"] == {
        "from_s": pytest.approx(16201.2),
        "until_s": pytest.approx(FIRST_CURED_S),
        "source": "planner",
        "holds": [column],
    }
    # nothing rested on the second footing in this run: its cure comes from the manifest
    second = _entry(report, 1, manifest)
    assert second["curing"]["source"] == "manifest" and second["curing"]["holds"] == []
    assert second["curing"]["until_s"] == pytest.approx(second["constructed_s"] + 259200.0)


def test_a_laid_a_lifted_and_a_panel_component_say_how_they_were_built(
    report: dict, manifest: Manifest
) -> None:
    laid = _entry(report, 2, manifest)
    assert (laid["method"], laid["method_note"]) == ("laid", "masonry pier")
    assert laid["resources"] == ["block_layer"]
    assert (laid["laying_s"], laid["placed_s"], laid["curing"]) == (1.0, 7201.0, None)
    column = _entry(report, 9, manifest)
    assert (column["method"], column["resources"], column["curing"]) == ("lifted", ["carrier"], None)
    assert column["guests"] == ["3BasePlate0000000000A1"]
    panel = _entry(report, 12, manifest)
    assert (panel["method"], panel["parent_guid"]) == ("panelised", "2WallElement0000000000")


def test_the_totals_count_by_method_and_the_report_lists_panels_and_guests(report: dict) -> None:
    assert report["totals"]["by_method"] == {
        "cast_in_place": {"components": 2, "constructed": 2},
        "laid": {"components": 1, "constructed": 1},
        "lifted": {"components": 23, "constructed": 1},
        "panelised": {"components": 2, "constructed": 0},
        "with_host": {"components": 1, "constructed": 1},
    }
    (element,) = report["panelised"]
    assert (element["guid"], len(element["panels"]), element["panels_constructed"]) == (
        "2WallElement0000000000",
        2,
        0,
    )
    (guest,) = report["with_host"]
    assert (guest["guid"], guest["constructed"]) == ("3BasePlate0000000000A1", True)


def test_work_in_place_is_no_placement_by_a_hand(report: dict) -> None:
    """The pump's and the block layer's verdicts (0 mm: physics built them at their targets) made a 'pump'
    row of perfect placements in the placement figures."""
    totals = report["totals"]
    assert list(totals["placement_error_mm_by_type"]) == ["carrier"]
    assert totals["placement_error_mm_by_type"]["carrier"]["max"] == pytest.approx(4.0)
    assert totals["work_in_place_verdicts"] == 3


def test_the_run_summary_says_how_long_the_cast_components_cured(report: dict) -> None:
    assert curing_line(report) == (
        "cured: 2 cast components, the longest 72.0 h (259,200 s) (1 component that rests on one waited for "
        "its cure, and what rests on it in turn); the makespan ends with the last construction, and the "
        "concrete reaches its strength 4.5 h (16,172 s) later, when the last cure ends: 81.0 h (291,602 s) "
        "from the first release"
    )
    assert curing_line({"components": [{"curing": None}]}) is None
    last_poured = {
        "components": [{"curing": {"from_s": 100.0, "until_s": 86_500.0, "holds": []}}],
        "totals": {"last_constructed_s": 100.0},
    }
    assert curing_line(last_poured) == (
        "cured: 1 cast component, the longest 24.0 h (86,400 s); the makespan ends with the last "
        "construction, and the concrete reaches its strength 24.0 h (86,400 s) later, when the last cure ends"
    )
    last_poured["totals"]["first_release_s"] = 0.5  # the date a builder asks for: strength, from the start
    assert curing_line(last_poured).endswith(
        "when the last cure ends: 24.0 h (86,500 s) from the first release"
    )
    lifted = {"by_method": {"lifted": {"components": 3, "constructed": 3}, "with_host": {"components": 2}}}
    assert method_legend({"totals": lifted}) == []  # all lifted (guests have no bars): no legend of methods


def test_times_are_said_in_the_unit_of_their_span() -> None:
    assert [time_unit(s).name for s in (45.0, 1800.0, 291652.0, 30 * 86400.0)] == ["s", "min", "h", "days"]
    assert duration_text(291651.0) == "81.0 h (291,651 s)"
    assert duration_text(45.0) == "45.0 s"
    assert (duration_text(1800.0), duration_text(7201.0)) == ("30.0 min (1,800 s)", "2.0 h (7,201 s)")
    # robots' busy times share one unit, but one shorter than that unit is not "0.0 days" or "0.1 days":
    # it is said in its own
    days = spoken_unit(30 * 86400.0)
    assert [in_unit_text(s, days) for s in (935.0, 11_062.0, 0.0, 300_000.0)] == [
        "15.6 min (935 s)",
        "3.1 h (11,062 s)",
        "0 s",
        "3.5 days round the clock (300,000 s)",
    ]


def _bars_x(ax: Axes, color: RGB | None = None, hatch: str | None = None) -> list[tuple[float, float]]:
    """(start, end) of every bar of ``ax`` in ``color`` or with ``hatch``."""
    spans = []
    for collection in ax.collections:
        if not isinstance(collection, PolyCollection):
            continue
        if hatch is not None and collection.get_hatch() != hatch:
            continue
        if color is not None and tuple(collection.get_facecolor()[0][:3]) != pytest.approx(to_rgb(color)):
            continue
        for path in collection.get_paths():
            xs = path.vertices[:, 0]
            spans.append((float(xs.min()), float(xs.max())))
    return spans


def test_the_chart_draws_formwork_pour_and_curing_with_a_legend_of_methods(
    report: dict, manifest: Manifest
) -> None:
    figure = report_figure(report)
    lanes, sequence, errors, drift = figure.axes[:4]
    texts = [text.get_text() for legend in figure.legends for text in legend.get_texts()]
    for label in (
        "cast in place ×2: formwork",
        "cast in place: pour",
        "curing (what rests on it waits)",
        "laid ×1: courses",
        "panelised ×2",
        "lifted ×23 (its class colour)",
    ):
        assert label in texts
    # the pump's lane: each footing's formwork up to its pour, then the pour
    assert _bars_x(lanes, STEP_COLORS[FORMWORK])[0] == (pytest.approx(0.8), pytest.approx(14401.0))
    assert _bars_x(lanes, STEP_COLORS[POUR])[0] == (pytest.approx(14401.0), pytest.approx(16201.4))
    # the first footing's curing, hatched on its row from the pour to the end of the planner's hold
    cured = _bars_x(sequence, hatch=CURING_HATCH)
    assert (pytest.approx(16201.2), pytest.approx(FIRST_CURED_S)) in cured and len(cured) == 2
    assert lanes.get_xlabel() == sequence.get_xlabel() == "sim time (h); grey: long waits, narrowed"
    assert {tick.get_text() for tick in sequence.get_xticklabels()} >= {"0", "2", "4", "6", "8"}
    assert "makespan 76.5 h" in figure.get_suptitle() and END_S > FIRST_CURED_S
    # the placement panels: the carrier's row only, and what they leave out
    assert [label.get_text().split("\n")[0] for label in errors.get_yticklabels()] == ["carrier"]
    for ax in (errors, drift):
        assert any("left out: 3 verdicts on work in place" in text.get_text() for text in ax.texts)


def test_the_wait_for_a_cure_is_drawn_narrow_so_the_work_after_it_reads(report: dict) -> None:
    """On a linear axis the first footing's 67.5 h of curing, in a span of 81 h, left the work after it 6 %
    of the axis; the wait is now a labelled grey band of BREAK_WIDTH, and the work after it a quarter."""
    figure = report_figure(report)
    lanes, sequence = figure.axes[:2]
    span_s = chart_span_s(report)
    ((start_s, end_s),) = find_breaks(task_intervals(report), span_s).breaks

    def at(sim_s: float) -> float:  # where a sim time is drawn, as a fraction of the axis' width
        return float(lanes.transAxes.inverted().transform(lanes.transData.transform((sim_s, 0.0)))[0])

    assert (end_s - start_s) / span_s > 0.8 and (span_s - end_s) / span_s < 0.06
    assert at(end_s) - at(start_s) == pytest.approx(BREAK_WIDTH, rel=0.15)
    assert at(span_s) - at(end_s) > 0.2
    assert any(text.get_text() == "67.5 h wait" for text in lanes.texts)
    ticks = [tick.get_position()[0] for tick in sequence.get_xticklabels()]
    assert ticks and not [t for t in ticks if start_s < t < end_s]  # no tick crammed into the wait


def test_a_wait_for_work_in_place_is_drawn_in_its_works_colour_not_its_class(report: dict) -> None:
    """The planned-sequence panel drew the wait from release to the start of work in the class colour: the
    structural sample's 216 piles (IfcSlab) ran long magenta lines no legend entry had."""
    from matplotlib.lines import Line2D

    from bimbot.shared.report.methods_png import LAYING

    figure = report_figure(report)
    sequence = figure.axes[1]
    waits: dict[tuple[float, float], list[tuple[float, float, float]]] = {}
    for line in sequence.get_lines():
        if isinstance(line, Line2D) and len(line.get_xdata()) == 2:
            span = (round(float(line.get_xdata()[0]), 3), round(float(line.get_xdata()[1]), 3))
            waits.setdefault(span, []).append(tuple(round(v, 6) for v in to_rgb(line.get_color())))
    checked = 0
    for component in report["components"]:
        start = {"cast_in_place": component["forming_s"], "laid": component["laying_s"]}.get(
            component["method"]
        )
        if start is None or component["released_s"] is None or start <= component["released_s"]:
            continue
        step = FORMWORK if component["method"] == "cast_in_place" else LAYING
        colors = waits[(round(component["released_s"], 3), round(start, 3))]
        assert tuple(round(v, 6) for v in STEP_COLORS[step]) in colors
        checked += 1
    assert checked >= 2


def test_the_summary_says_when_work_in_place_and_cures_set_the_makespan_not_the_lifting() -> None:
    """The Revit house: the lifting robots at 1 % each and three carriers changing its makespan by 0.1 %,
    and nothing said that a slab's formwork, pour and cure took the time."""
    from bimbot.shared.report.methods import set_by_line

    def report(lift_end_s: float) -> dict:
        return {
            "totals": {"makespan_s": 100_000.0, "first_release_s": 0.0, "working_s": 40_000.0 + lift_end_s},
            "components": [
                {
                    "guid": "slab",
                    "method": "cast_in_place",
                    "forming_s": 0.0,
                    "pouring_s": 36_000.0,
                    "constructed_s": 40_000.0,
                },
                {"guid": "beam", "method": "lifted"},
            ],
            "robots": {
                "r1": {
                    "type": "concrete_pump",
                    "tasks": [{"guid": "slab", "start_s": 0.0, "end_s": 40_000.0}],
                },
                "r2": {"tasks": [{"guid": "beam", "start_s": 40_000.0, "end_s": 40_000.0 + lift_end_s}]},
            },
        }

    line = set_by_line(report(3_600.0))
    assert line is not None and line.startswith("what set the makespan: work in place")
    assert "11.1 h (40,000 s)" in line and "15.7 h (56,400 s)" in line and "60.0 min (3,600 s)" in line
    assert "(summed over its components, which may overlap: forming 10.0 h (36,000 s), pouring 1.1 h" in line
    assert line.endswith(
        "; the work in place was r1 (concrete_pump)'s: it waits on cures and on what it stands on, so "
        "another machine for it shortens it only where that work can run side by side; the forming rates "
        "and cure times are the methods file's (bimbot convert MODEL --methods FILE, then run again)"
    )
    idle_pump = report(3_600.0)
    idle_pump["robots"]["r3"] = {"type": "line_pump", "tasks": [], "distance_m": 0.0}
    idle_line = str(set_by_line(idle_pump))
    assert "was r1 (concrete_pump)'s, while r3 (line_pump) stood idle: it waits" in idle_line
    assert set_by_line(report(50_000.0)) is None  # the lifting took half of it: more robots may help
    side_by_side = report(3_600.0)  # a second lifting robot at work in the same hour: still one hour
    side_by_side["robots"]["r4"] = {"tasks": [{"guid": "beam", "start_s": 40_000.0, "end_s": 43_600.0}]}
    said = str(set_by_line(side_by_side))
    assert "; one robot that lifts or more was at work 60.0 min (3,600 s) of it" in said
