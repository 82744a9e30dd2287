"""The report chart's label sizes follow its rows and bars: readable where there is room, never larger
than a row or a bar (a new user found the 6 pt labels of the bundled frame's 28 rows too small to read)."""

from __future__ import annotations

from bimbot.shared.report.png import bar_label_size_pt, labelled_rows, row_label_size_pt


def test_row_labels_grow_with_the_room_a_row_has() -> None:
    assert row_label_size_pt(28) == 10.0  # the bundled frame
    assert 6.0 < row_label_size_pt(45) < 10.0
    assert row_label_size_pt(60) == 6.0  # the most rows that are labelled
    sizes = [row_label_size_pt(rows) for rows in range(1, 61)]
    assert sizes == sorted(sizes, reverse=True)


def test_a_long_sequence_still_names_every_kth_row() -> None:
    """Beyond 60 rows the panel had no names at all (the hub's 85 steel members): a user could not tell
    which row was which."""
    assert list(labelled_rows(28)) == list(range(28))
    assert list(labelled_rows(60)) == list(range(60))
    hub = labelled_rows(85)
    assert hub.step == 2 and len(hub) == 43 and hub[0] == 0
    large = labelled_rows(988)
    assert len(large) <= 60 and large.step == 17


def test_a_bar_label_is_no_thicker_than_its_bar() -> None:
    assert bar_label_size_pt(40.0, 500.0) == 9.0  # a 40 s task in a 500 s build: room to spare
    assert bar_label_size_pt(1.0, 500.0) == 5.0  # a sliver: the smallest size, clipped to the axes
    assert bar_label_size_pt(8.0, 1000.0) < bar_label_size_pt(16.0, 1000.0) < 9.0


def test_each_retry_in_the_sequence_panel_takes_its_cause_from_the_placement_verdict() -> None:
    from bimbot.shared.report.png import retry_causes

    component = {
        "misplaced_s": [301.6, 366.40000000000003, 400.0],
        "placements": [
            {"sim_time_s": 301.6, "cause": "unstable"},
            {"sim_time_s": 366.40000000000003, "cause": "misplaced"},
            {"sim_time_s": 461.2, "cause": "unstable"},  # the last attempt: failed, no retry
        ],
    }
    assert retry_causes(component) == [
        (301.6, "unstable"),
        (366.40000000000003, "misplaced"),
        (400.0, "misplaced"),
    ]


def test_a_bar_label_is_cut_to_the_height_of_its_bar() -> None:
    """A Revit name ran over the lanes above and below: once the figure is laid out, a label longer than
    its bar is cut from the front with "…" until it fits, keeping the end (type and element id, what tells
    the bars apart); one that fits stays whole."""
    from matplotlib.figure import Figure

    from bimbot.shared.report.png import DPI, FIGURE_SIZE_IN, fit_bar_labels

    figure = Figure(figsize=FIGURE_SIZE_IN, dpi=DPI)
    ax = figure.add_subplot(2, 2, 1)
    ax.set_xlim(0.0, 100.0)
    ax.set_ylim(-0.6, 4.4)  # five lanes
    name = "M_W-Wide Flange-Column:W310X97:318275"
    long = ax.text(30.0, 2.0, name, rotation=90, ha="center", va="center", fontsize=9.0)
    short = ax.text(60.0, 2.0, "C2", rotation=90, ha="center", va="center", fontsize=9.0)
    fit_bar_labels(figure, ax, [long, short])
    assert long.get_text().startswith("…") and name.endswith(long.get_text()[1:])
    assert short.get_text() == "C2"
    renderer = figure.canvas.get_renderer()  # type: ignore[attr-defined]
    low, high = ax.transData.transform([(0.0, -0.4), (0.0, 0.4)])
    assert long.get_window_extent(renderer).height <= abs(high[1] - low[1])
    assert len(long.get_text()) > 3  # cut to the bar, not emptied


def test_the_legend_keeps_within_the_figure_and_no_class_is_drawn_in_the_not_built_red() -> None:
    """The Revit hub's eight legend columns (five classes, a long 'not constructed' count, 'failed') ran off
    both edges, and its constructed slab was drawn in the red of the failed ones round it."""
    from matplotlib.colors import to_rgb
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    from bimbot.shared.report.png import (
        CLASS_PALETTE,
        DPI,
        FIGURE_SIZE_IN,
        NOT_BUILT_COLOR,
        class_colors,
        fitting_legend,
    )

    red = to_rgb(NOT_BUILT_COLOR)
    assert all(sum((a - b) ** 2 for a, b in zip(c, red, strict=True)) > 0.1 for c in CLASS_PALETTE)
    classes = ["IfcBeam", "IfcBuildingElementProxy", "IfcColumn", "IfcSlab", "IfcWallStandardCase"]
    assert red not in class_colors(classes).values()
    figure = Figure(figsize=FIGURE_SIZE_IN, dpi=DPI)
    handles = [Patch(color=color, label=name) for name, color in class_colors(classes).items()]
    handles += [
        Patch(label="not constructed: blocked_by ×22, no_progress ×1, out_of_reach ×71, too_heavy ×19"),
        Line2D([], [], marker="x", label="failed (when)"),
    ]
    rows = fitting_legend(figure, handles)
    assert rows >= 2
    (legend,) = figure.legends
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    extent = legend.get_window_extent(FigureCanvasAgg(figure).get_renderer())
    assert extent.x0 >= 0.0 and extent.x1 <= figure.bbox.width
    assert fitting_legend(Figure(figsize=FIGURE_SIZE_IN, dpi=DPI), handles[:3]) == 1  # a short one: one row


def test_ten_classes_wear_ten_colours_none_like_another_or_a_step_of_work() -> None:
    """The Revit 2025 structural sample has more classes than tab10 and Dark2 left colours for: its
    eighth class wore its first one's colour. Ten classes get ten colours, each far from the others,
    from red (not constructed) and from the colours of work in place (driving a pile among them)."""
    from matplotlib.colors import to_rgb

    from bimbot.shared.report.methods_png import STEP_COLORS
    from bimbot.shared.report.png import NOT_BUILT_COLOR, class_colors

    classes = [
        f"Ifc{name}"
        for name in [
            "Beam",
            "Column",
            "Footing",
            "Member",
            "Pile",
            "Plate",
            "Slab",
            "Wall",
            "Stair",
            "Railing",
        ]
    ]
    colors = list(class_colors(classes).values())
    assert len(set(colors)) == len(classes) == 10

    def distance(a: tuple[float, ...], b: tuple[float, ...]) -> float:
        return float(sum((x - y) ** 2 for x, y in zip(a, b, strict=True)) ** 0.5)

    assert min(distance(a, b) for i, a in enumerate(colors) for b in colors[i + 1 :]) >= 0.22
    avoid = [to_rgb(NOT_BUILT_COLOR), *STEP_COLORS.values()]
    assert min(distance(color, other) for color in colors for other in avoid) > 0.35
