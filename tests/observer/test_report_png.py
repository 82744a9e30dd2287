"""The report chart's title agrees with its legend and with the run's summary."""

from __future__ import annotations

import itertools

from bimbot.shared.report.png import caught_last_title, labelled_rows, marked_row, with_marked_rows


def test_the_title_counts_placements_caught_on_a_last_attempt_beside_the_retries() -> None:
    """The title said "retries: 3" above a legend counting 4 caught placements: the fourth was caught on its
    component's last attempt (verdict failed), so it was not retried. The title now says so."""
    component = {
        "placements": [
            {"verdict": "misplaced", "cause": "misplaced"},
            {"verdict": "failed", "cause": "unstable"},
        ]
    }
    assert caught_last_title({"components": [component, {"placements": []}]}) == (
        " (and 1 caught on a last attempt)"
    )
    assert caught_last_title({"components": [{"placements": [{"verdict": "misplaced"}]}]}) == ""


def test_a_row_with_a_caught_placement_is_named_even_between_the_kth_rows() -> None:
    """A new user could not tell which of the hub's 85 members had toppled: its row was an unnamed one."""
    regular = labelled_rows(85)  # every second row
    named = with_marked_rows(regular, [7, 40])
    assert 7 in named and 40 in named
    assert 6 not in named and 8 not in named  # their neighbours give way: the labels would overlap
    assert all(row in named for row in regular if abs(row - 7) > 1 and abs(row - 40) > 1)
    assert with_marked_rows(labelled_rows(28), [3]) == list(range(28))  # every row named anyway
    run = with_marked_rows(regular, range(23, 36))  # thirteen toppled in a row: every second one named
    assert [row for row in run if 22 <= row <= 36] == [23, 25, 27, 29, 31, 33, 35]
    # 937 rows, a label every 16th: marks 6 rows apart, or a named row 6 rows from a mark, would overlap
    large = labelled_rows(937)
    assert large.step == 16
    marks = with_marked_rows(large, [369, 375, 385, 522, 529])
    assert [row for row in marks if 350 <= row <= 540] == [352, 369, 385, 416, 432, 448, 464, 480, 496, 522]
    assert all(b - a >= 16 for a, b in itertools.pairwise(marks))
    caught = {"guid": "a", "placements": [{"verdict": "misplaced"}, {"verdict": "constructed"}]}
    clean = {"guid": "b", "placements": [{"verdict": "constructed"}]}
    assert marked_row(caught, set()) and not marked_row(clean, set()) and marked_row(clean, {"b"})
