"""Numeric options are checked by argparse itself: nan, inf and out-of-range values are one line, exit 2."""

from __future__ import annotations

import argparse

import pytest

from bimbot.command_line import build_parser
from bimbot.shared.option_types import (
    finite_float,
    non_negative_float,
    non_negative_int,
    positive_float,
    positive_int,
)


@pytest.mark.parametrize("text", ["nan", "NaN", "inf", "-inf", "1e400", "x", ""])
def test_no_float_option_takes_a_non_finite_or_non_number(text: str) -> None:
    for check in (finite_float, positive_float, non_negative_float):
        with pytest.raises(argparse.ArgumentTypeError):
            check(text)


def test_the_bounds_of_each_float_check() -> None:
    assert finite_float("-2.5") == -2.5
    assert positive_float("0.1") == 0.1
    assert non_negative_float("0") == 0.0
    with pytest.raises(argparse.ArgumentTypeError, match="positive"):
        positive_float("0")
    with pytest.raises(argparse.ArgumentTypeError, match="zero or a positive"):
        non_negative_float("-1")


def test_the_bounds_of_each_int_check() -> None:
    assert positive_int("3") == 3
    assert non_negative_int("0") == 0
    for bad in ("0", "-1", "1.5", "nan"):
        with pytest.raises(argparse.ArgumentTypeError):
            positive_int(bad)
    with pytest.raises(argparse.ArgumentTypeError):
        non_negative_int("-1")


@pytest.mark.parametrize(
    ("argv", "option"),
    [
        (["physics", "--build", "OUT", "--physics-hz", "nan"], "--physics-hz"),
        (["physics", "--build", "OUT", "--control-period-s", "inf"], "--control-period-s"),
        (["physics", "--build", "OUT", "--rtf", "-1"], "--rtf"),
        (["physics", "--build", "OUT", "--laser-range-m", "0"], "--laser-range-m"),
        (["physics", "--build", "OUT", "--laser-height-m", "nan"], "--laser-height-m"),
        (["run", "OUT", "--physics-hz", "nan"], "--physics-hz"),
        (["run", "OUT", "--rtf", "-1"], "--rtf"),
        (["run", "OUT", "--timeout-s", "-1"], "--timeout-s"),
        (["run", "OUT", "--timeout-s", "inf"], "--timeout-s"),
        (["run", "OUT", "--stall-after-s", "nan"], "--stall-after-s"),
        (["run", "OUT", "--robots", "0"], "--robots"),
        (["run", "OUT", "--profile", "nope"], "--profile"),
    ],
)
def test_a_bad_number_is_one_line_naming_the_option_and_exit_2(
    argv: list[str], option: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as ended:
        build_parser(argv).parse_args(argv)
    assert ended.value.code == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1, lines  # argparse's usage text is left out: it buried the error
    assert option in lines[0] and lines[0].startswith(f"bimbot {argv[0]}: error:")


def test_a_total_station_too_coarse_is_answered_in_the_mm_the_user_typed(
    capsys: pytest.CaptureFixture[str],
) -> None:
    argv = ["run", "OUT", "--total-station-mm", "2000"]
    with pytest.raises(SystemExit) as ended:
        build_parser(argv).parse_args(argv)
    assert ended.value.code == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert "--total-station-mm: 2000 mm is more than 1000 mm" in line, line
    assert "] m" not in line, line  # not physics' bound in metres
    top = ["run", "OUT", "--total-station-mm", "1000"]
    assert build_parser(top).parse_args(top).total_station_mm == 1000.0
