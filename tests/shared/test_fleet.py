"""The fleet file: one TOML validated by pydantic, an embedded default, clear one-line errors."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from wall_clock import bound_s

from bimbot.shared.errors import InputError
from bimbot.shared.fleet import default_fleet, load_fleet, resolve_urdf
from bimbot.shared.manifest import Manifest, read_manifest
from bimbot.shared.site_layout import plan_site

DEFAULT = default_fleet()


def test_the_default_fleet_has_three_types_each_with_a_urdf_physics_can_load() -> None:
    assert set(DEFAULT.types) == {"husky", "carrier", "tower_crane"}
    assert DEFAULT.type_of() == {"r1": "husky", "r2": "carrier", "r3": "tower_crane"}
    assert DEFAULT.types["husky"].payload_kg == 75  # Clearpath's published maximum
    for description in DEFAULT.types.values():
        assert resolve_urdf(description.urdf).is_file()
    assert DEFAULT.with_robots(4).type_of() == {f"r{i}": "carrier" for i in range(1, 5)}


def test_the_crane_load_chart_gives_payload_by_radius_and_radius_by_payload() -> None:
    crane = DEFAULT.types["tower_crane"].crane
    assert crane is not None
    assert crane.payload_at(10.0) == 4000 and crane.payload_at(40.0) == 1300
    assert crane.payload_at(1.0) == 0 and crane.payload_at(41.0) == 0  # inside the trolley's minimum, beyond
    assert crane.payload_at(20.0) == pytest.approx(3200)
    assert crane.radius_for(3200) == pytest.approx(20.0)
    assert crane.radius_for(1000) == 40.0 and crane.radius_for(5000) == 0.0


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "fleet.toml"
    path.write_text(text, encoding="utf-8")
    return path


HUSKY = """
[types.husky]
urdf = "husky/husky.urdf"
payload_kg = 75
reach_m = 1.5
max_place_height_m = 4.0
length_m = 0.99
width_m = 0.67
max_speed_mps = 1.0
max_turn_radps = 1.5
"""


def test_a_fleet_file_of_one_type_loads_and_spawns_its_count(tmp_path: Path) -> None:
    fleet = load_fleet(_write(tmp_path, HUSKY + '[[robots]]\ntype = "husky"\ncount = 2\n'))
    assert fleet.summary() == "2 husky" and [r.name for r in fleet.robot_types()] == ["husky", "husky"]


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("types = [", "not valid TOML"),
        (HUSKY + '[[robots]]\ntype = "crane"\ncount = 1\n', "unknown type"),
        (HUSKY.replace("payload_kg = 75", "payload_kg = -1"), "types.husky.payload_kg"),
        (HUSKY.replace("max_speed_mps = 1.0", "max_speed_mps = 0"), "needs max_speed_mps"),
        (HUSKY.replace("max_speed_mps = 1.0", "max_speed_mps = nan"), "finite number"),
        (HUSKY.replace("payload_kg = 75", "paylod_kg = 75"), "paylod_kg: Extra inputs are not permitted"),
    ],
)
def test_a_bad_fleet_file_is_one_line_naming_the_file_and_the_field(
    tmp_path: Path, text: str, words: str
) -> None:
    path = _write(tmp_path, text)
    with pytest.raises(InputError) as caught:
        load_fleet(path)
    message = str(caught.value)
    assert str(path) in message and words in message and "\n" not in message


def test_the_site_plan_puts_ground_robots_at_the_depot_and_the_crane_beside_the_building(
    bundled_build: Path,
) -> None:
    frame: Manifest = read_manifest(bundled_build)
    layout = plan_site(frame.components, fleet=DEFAULT.robot_types())
    (husky, carrier, crane) = layout.robot_starts
    assert layout.depot.min_xy[0] <= husky[0] <= layout.depot.max_xy[0]
    assert layout.depot.min_xy[0] <= carrier[0] <= layout.depot.max_xy[0]
    assert crane[0] > layout.building.max_xy[0]  # east of the building
    assert len(layout.staging) == 1
    area = layout.staging[0]
    assert layout.fence.min_xy[0] < area.min_xy[0] and area.max_xy[0] < layout.fence.max_xy[0]


def test_fleet_check_prints_the_husky_only_fleet_footings_too_heavy_with_the_numbers(
    bundled_build: Path, tmp_path: Path
) -> None:
    path = _write(tmp_path, HUSKY + '[[robots]]\ntype = "husky"\ncount = 2\n')
    done = subprocess.run(
        [sys.executable, "-m", "bimbot.cli", "fleet", "check", str(bundled_build), "--fleet", str(path)],
        capture_output=True,
        text=True,
        timeout=bound_s(120),
        check=False,
    )
    assert done.returncode == 1, done.stderr  # 1: the fleet cannot build everything
    assert "buildable: 19 of 28; cannot: 9 too_heavy" in done.stdout
    # what rests on the footings cannot be built either: the check says so, as a run's blocked_by would
    assert "of the buildable, 19 rest (directly or through others) on one that cannot" in done.stdout
    assert "so it can build at most 0" in done.stdout
    assert done.stdout.count("259 kg exceeds the largest payload on site (75 kg") == 9


def test_the_example_fleets_load_and_their_types_match_the_default_ones() -> None:
    examples = sorted((Path(__file__).resolve().parents[2] / "examples" / "fleets").glob("*.toml"))
    assert examples
    for path in examples:
        fleet = load_fleet(path)
        for name, description in fleet.types.items():
            assert description == DEFAULT.types[name], f"{path.name}: {name} differs from the default fleet"
