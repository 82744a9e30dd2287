"""The report chart's title agrees with its legend and with the run's summary."""

from __future__ import annotations

from bimbot.services.observer.report_png import caught_last_title


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
