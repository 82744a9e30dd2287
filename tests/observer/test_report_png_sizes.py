"""The report chart's label sizes follow its rows and bars: readable where there is room, never larger
than a row or a bar (a new user found the 6 pt labels of the bundled frame's 28 rows too small to read)."""

from __future__ import annotations

from bimbot.services.observer.report_png import bar_label_size_pt, row_label_size_pt


def test_row_labels_grow_with_the_room_a_row_has() -> None:
    assert row_label_size_pt(28) == 10.0  # the bundled frame
    assert 6.0 < row_label_size_pt(45) < 10.0
    assert row_label_size_pt(60) == 6.0  # the most rows that are labelled
    sizes = [row_label_size_pt(rows) for rows in range(1, 61)]
    assert sizes == sorted(sizes, reverse=True)


def test_a_bar_label_is_no_thicker_than_its_bar() -> None:
    assert bar_label_size_pt(40.0, 500.0) == 9.0  # a 40 s task in a 500 s build: room to spare
    assert bar_label_size_pt(1.0, 500.0) == 5.0  # a sliver: the smallest size, clipped to the axes
    assert bar_label_size_pt(8.0, 1000.0) < bar_label_size_pt(16.0, 1000.0) < 9.0


def test_each_retry_in_the_sequence_panel_takes_its_cause_from_the_placement_verdict() -> None:
    from bimbot.services.observer.report_png import retry_causes

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
