"""``bimbot physics --fleet FILE``: a fleet file that cannot be used is one clear line on stderr and exit 2
(no traceback), before anything starts."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from wall_clock import bound_s

GOOD_TYPE = """
[types.husky]
urdf = "{urdf}"
payload_kg = 75
reach_m = 1.5
max_place_height_m = 4.0
length_m = 0.99
width_m = 0.67
max_speed_mps = 1.0
max_turn_radps = 1.5

[[robots]]
type = "{robot}"
count = 1
"""


@pytest.mark.parametrize(
    ("content", "needles"),
    [
        (None, ("fleet file", "does not exist")),
        ("[types.husky\n", ("fleet file", "not valid TOML")),
        (
            GOOD_TYPE.format(urdf="husky/husky.urdf", robot="crawler"),
            ("fleet file", "unknown type", "crawler"),
        ),
        (GOOD_TYPE.format(urdf="no_such.urdf", robot="husky"), ("robot URDF 'no_such.urdf' not found",)),
    ],
)
def test_a_bad_fleet_file_is_one_clear_line(
    bundled_build: Path, tmp_path: Path, content: str | None, needles: tuple[str, ...]
) -> None:
    fleet = tmp_path / "fleet.toml"
    if content is not None:
        fleet.write_text(content, encoding="utf-8")
    done = subprocess.run(
        [
            sys.executable,
            "-P",
            "-m",
            "bimbot.cli",
            "physics",
            "--build",
            str(bundled_build),
            "--fleet",
            str(fleet),
        ],
        check=False,
        capture_output=True,
        text=True,
        timeout=bound_s(120),
    )
    assert done.returncode == 2, done.stderr
    assert "Traceback" not in done.stderr
    lines = [line for line in done.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, done.stderr
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])
