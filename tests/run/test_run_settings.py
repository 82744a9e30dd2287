"""report.json's ``settings``: the profile's values unless the user set them, the total station, the
sequence's source; JSON-ready."""

from __future__ import annotations

import json
from pathlib import Path

from bimbot.run.options import RunOptions
from bimbot.run.settings import model_settings, run_settings
from bimbot.services.physics.profiles import FINE, REHEARSAL
from bimbot.shared.manifest import SourceModel


def test_the_profile_fills_what_the_user_left_open() -> None:
    settings = run_settings(RunOptions())
    assert settings["profile"] == REHEARSAL.name
    assert settings["physics_hz"] == REHEARSAL.physics_hz
    assert settings["control_period_s"] == REHEARSAL.control_period_s
    assert settings["laser_beams"] == REHEARSAL.laser_beams
    assert settings["command_latency_steps"] == REHEARSAL.command_latency_steps
    assert settings["lock_step"] is REHEARSAL.lock_step
    assert settings["total_station_mm"] == REHEARSAL.total_station_mm == 3.0  # a site sets out with one
    assert settings["fleet"] == "the default fleet"
    assert run_settings(RunOptions(total_station_mm=0.0))["total_station_mm"] == 0.0  # none, said as 0
    assert settings["real_time_factor"] == 0.0 and settings["pace"] == "as fast as it can"
    assert settings["max_attempts"] == 3
    assert json.loads(json.dumps(settings)) == settings


def test_what_the_user_set_is_what_the_report_says() -> None:
    options = RunOptions(
        profile=FINE.name,
        physics_hz=480.0,
        laser_beams=90,
        total_station_mm=3.0,
        fleet=Path("fleet.toml"),
        planner_source=("--derive", "--strict"),
        max_attempts=5,
    )
    settings = run_settings(options)
    assert settings["profile"] == FINE.name and settings["physics_hz"] == 480.0
    assert settings["control_period_s"] == FINE.control_period_s  # left open: the fine profile's
    assert settings["laser_beams"] == 90 and settings["total_station_mm"] == 3.0
    assert settings["fleet"] == "fleet.toml" and settings["max_attempts"] == 5
    assert settings["sequence"].startswith("derived")
    assert run_settings(RunOptions(planner_source=("--sequence", "my.xml")))["sequence"] == "my.xml"


def test_a_report_names_the_model_it_built_by_file_and_content() -> None:
    """``bimbot compare`` tells two buildings apart by these (one model converted two ways is one)."""
    source = SourceModel(path="bimbot/data/frame.ifc", schema_name="IFC4", sha256="ab12", length_unit_m=0.001)
    assert model_settings(source) == {"path": "bimbot/data/frame.ifc", "sha256": "ab12"}
