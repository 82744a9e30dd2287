"""Off a terminal, ``bimbot convert`` says how far it got at each stage's start and then every 30 s of wall
time (services/converter/cli.py), so a long conversion in a log or CI is seen to go on."""

from __future__ import annotations

import pytest

from bimbot.services.converter.cli import PROGRESS_LINE_S, _ProgressBar


def test_progress_lines_come_at_a_stage_start_then_every_30_s(capsys: pytest.CaptureFixture[str]) -> None:
    now = [0.0]
    bar = _ProgressBar(enabled=False, lines=True, clock=lambda: now[0])
    for done, at_s in ((0, 0.0), (10, 5.0), (20, PROGRESS_LINE_S + 1.0), (30, PROGRESS_LINE_S + 2.0)):
        now[0] = at_s
        bar.update("convert", done, 100)
    assert capsys.readouterr().err.splitlines() == [
        "bimbot convert: 100 IFC elements to convert",  # not "0 of 100": it may say nothing more
        "bimbot convert: 20 of 100 IFC elements converted",
    ]


def test_no_lines_on_a_terminal_bar_or_with_no_progress(capsys: pytest.CaptureFixture[str]) -> None:
    _ProgressBar(enabled=False, lines=False).update("convert", 1, 2)  # --no-progress
    assert capsys.readouterr().err == ""
