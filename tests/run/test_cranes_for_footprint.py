"""A wide building gets the tower cranes its footprint needs: the run, physics and the robot processes
agree robot id by robot id, and the fleet line, the settings and the fleet check say how many and why."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest
from component_boxes import upper_floor_beams

from bimbot.command_line import build_parser
from bimbot.run.commands import (
    fleet_words,
    physics_arguments,
    run_fleet,
    service_commands,
    with_machines_for,
)
from bimbot.run.options import RunOptions
from bimbot.run.settings import run_settings
from bimbot.services.physics.cli import fleet_of
from bimbot.shared.errors import UserError
from bimbot.shared.manifest import Manifest
from bimbot.shared.run_folder import RunFolder


def _physics(*words: str) -> argparse.Namespace:
    argv = ["physics", "--build", "OUT", *words]
    return build_parser(argv).parse_args(argv)


def test_the_run_physics_and_the_robots_agree_on_the_cranes_a_wide_building_gets(
    bundled_build: Path, tmp_path: Path
) -> None:
    frame = Manifest.model_validate_json((bundled_build / "manifest.json").read_text())
    wide = frame.model_copy(update={"components": upper_floor_beams(200.0)})
    options = with_machines_for(RunOptions(), wide)
    ((name, count),) = options.cranes
    assert name == "tower_crane" and 1 < count <= 4
    words = fleet_words(options)
    assert (
        f"{count} tower_crane" in words
        and f"; {count} tower_crane for the building's footprint, where the fleet file has 1 (up to 4)"
        in words
    )
    arguments = physics_arguments(bundled_build, options)
    assert arguments[arguments.index("--cranes") + 1] == f"tower_crane={count}"
    physics = fleet_of(_physics("--cranes", f"tower_crane={count}", "--off-site", ",".join(options.off_site)))
    assert physics.type_of() == run_fleet(options).type_of()
    assert list(physics.type_of().values()).count("tower_crane") == count
    run = RunFolder(tmp_path / "run")
    robots = [
        n
        for n, _ in service_commands(bundled_build, "tcp/127.0.0.1:7000", options, run)
        if n.startswith("robot-")
    ]
    assert robots == [f"robot-{robot_id}" for robot_id in run_fleet(options).type_of()]
    assert run_settings(options)["cranes"] == {"tower_crane": count}
    assert with_machines_for(RunOptions(), frame).cranes == (), "the bundled frame keeps its one crane"


def test_physics_names_a_bad_crane_count_in_one_line() -> None:
    with pytest.raises(UserError, match="--cranes wants TYPE=N"):
        fleet_of(_physics("--cranes", "crane9=2"))
    with pytest.raises(UserError, match="--cranes wants TYPE=N"):
        fleet_of(_physics("--cranes", "tower_crane=lots"))
