"""The fleet file: one TOML validated by pydantic, an embedded default, clear one-line errors."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest
from wall_clock import bound_s

from bimbot.shared.construction_methods import ConstructionMethod
from bimbot.shared.errors import InputError
from bimbot.shared.fleet import default_fleet, load_fleet, resolve_urdf
from bimbot.shared.idle_machines import idle_machine_types
from bimbot.shared.manifest import Manifest, read_manifest
from bimbot.shared.robot_description import Capability
from bimbot.shared.site_layout import plan_site

DEFAULT = default_fleet()


def test_the_default_fleet_has_its_types_each_with_a_urdf_physics_can_load() -> None:
    assert set(DEFAULT.types) == {
        "husky", "carrier", "tower_crane", "concrete_pump", "block_layer", "line_pump", "piling_rig",
        "crawler_crane",
    }  # fmt: skip
    assert DEFAULT.type_of() == {
        "r1": "husky",
        "r2": "carrier",
        "r3": "tower_crane",
        "r4": "concrete_pump",
        "r5": "block_layer",
        "r6": "line_pump",
        "r7": "piling_rig",
    }  # fmt: skip  (the crawler crane is in the catalogue only: its relocation is not simulated)
    assert DEFAULT.types["husky"].payload_kg == 75  # Clearpath's published maximum
    for description in DEFAULT.types.values():
        assert resolve_urdf(description.urdf).is_file()


def test_each_machine_type_says_what_it_can_do_with_the_spec_that_goes_with_it() -> None:
    types = DEFAULT.types
    ground = {Capability.DRIVE, Capability.CARRY, Capability.PLACE, Capability.HAND_OFF}
    assert types["husky"].capabilities == types["carrier"].capabilities == ground  # implied: no crane spec
    crane = {Capability.STAND_FIXED, Capability.HOOK_LIFT, Capability.PLACE}
    assert types["tower_crane"].capabilities == types["crawler_crane"].capabilities == crane  # implied
    relocate = Capability.RELOCATE  # truck-mounted: they drive to another set-up for what they cannot reach
    assert types["concrete_pump"].capabilities == {Capability.STAND_FIXED, Capability.POUR, relocate}
    assert types["block_layer"].capabilities == {Capability.STAND_FIXED, Capability.LAY, relocate}
    assert types["piling_rig"].capabilities == {Capability.STAND_FIXED, Capability.PILE, relocate}
    piling = types["piling_rig"].piling
    assert (
        piling is not None
        and piling.drive_s(6.0) == piling.pitch_s + 3600.0 * 6.0 / piling.penetration_m_per_h
    )
    with pytest.raises(ValueError, match="pile and a \\[piling\\] spec go together"):
        types["piling_rig"].model_validate({**types["piling_rig"].model_dump(), "piling": None})
    # a line pump's placing line reaches pours in the middle of a large footprint: it is extended, not moved
    assert types["line_pump"].capabilities == {Capability.STAND_FIXED, Capability.POUR}
    assert types["line_pump"].reach_m == 120.0 and not types["line_pump"].relocates
    assert types["line_pump"].handling_s > types["concrete_pump"].handling_s  # the boom is taken first
    assert all(
        types[name].relocation_speed_mps > 0 and types[name].setup_s > 0
        for name in ("concrete_pump", "block_layer")
    )
    assert not types["tower_crane"].relocates
    pump, layer = types["concrete_pump"], types["block_layer"]
    assert pump.reach_m == 28.0 and pump.crane is None and pump.laying is None  # a 32 m class boom
    laying = layer.laying
    assert laying is not None and layer.reach_m == 32.0  # Hadrian X: 32 m boom
    assert (laying.block_length_m, laying.block_height_m, laying.block_width_m) == (0.6, 0.4, 0.3)
    assert laying.block_mass_kg == layer.payload_kg == 45 and laying.blocks_per_h == 300
    for name in ("tower_crane", "concrete_pump", "block_layer", "line_pump", "crawler_crane"):
        assert types[name].max_speed_mps == 0 and not types[name].can(Capability.DRIVE)


def test_the_tower_crane_is_sized_like_a_real_site_crane() -> None:
    """8 t at short radius, 1.5 t at the 60 m tip (Potain MDT 178), the hook 40 m up."""
    crane = DEFAULT.types["tower_crane"].crane
    assert crane is not None
    assert max(point.payload_kg for point in crane.load_chart) == 8000
    assert crane.max_radius_m == 60.0 and crane.payload_at(60.0) == 1500
    assert crane.jib_height_m == 40.0
    crawler = DEFAULT.types["crawler_crane"].crane
    assert crawler is not None and crawler.payload_at(26.0) > 3 * crane.payload_at(26.0)  # heavy precast


def test_robots_n_means_n_of_the_default_type_plus_every_machine_that_stands_fixed() -> None:
    three = DEFAULT.with_robots(3)
    assert three.type_of() == {
        "r1": "carrier", "r2": "carrier", "r3": "carrier",
        "r4": "tower_crane", "r5": "concrete_pump", "r6": "block_layer", "r7": "line_pump",
        "r8": "piling_rig",
    }  # fmt: skip
    assert three.summary() == (
        "3 carrier, 1 tower_crane, 1 concrete_pump, 1 block_layer, 1 line_pump, 1 piling_rig"
    )
    assert DEFAULT.with_robots(1, "husky").type_of() == {
        "r1": "husky", "r2": "tower_crane", "r3": "concrete_pump", "r4": "block_layer", "r5": "line_pump",
        "r6": "piling_rig",
    }  # fmt: skip
    # asked for machines of a type that stands fixed: that count replaces the file's, the others stay
    assert (
        DEFAULT.with_robots(2, "tower_crane").summary()
        == "2 tower_crane, 1 concrete_pump, 1 block_layer, 1 line_pump, 1 piling_rig"
    )
    assert (
        DEFAULT.with_robots(0).summary()
        == "1 tower_crane, 1 concrete_pump, 1 block_layer, 1 line_pump, 1 piling_rig"
    )
    with pytest.raises(InputError, match="no robot type 'digger'"):
        DEFAULT.with_robots(1, "digger")


def test_the_crane_load_chart_gives_payload_by_radius_and_radius_by_payload() -> None:
    crane = DEFAULT.types["tower_crane"].crane
    assert crane is not None
    assert crane.payload_at(10.0) == 8000 and crane.payload_at(40.0) == 2800
    assert crane.payload_at(1.0) == 0 and crane.payload_at(61.0) == 0  # inside the trolley's minimum, beyond
    assert crane.payload_at(25.0) == pytest.approx(4950)
    assert crane.radius_for(4950) == pytest.approx(25.0)
    assert crane.radius_for(1000) == 60.0 and crane.radius_for(9000) == 0.0


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


LAYER = """
[types.layer]
urdf = "block_layer.urdf"
capabilities = ["stand_fixed", "lay"]
payload_kg = 45
reach_m = 32
max_place_height_m = 10
length_m = 12.5
width_m = 5
max_speed_mps = 0
max_turn_radps = 0

[types.layer.laying]
block_length_m = 0.6
block_height_m = 0.4
block_width_m = 0.3
block_mass_kg = 45
blocks_per_h = 300
"""


def test_a_fleet_file_of_one_type_loads_and_spawns_its_count(tmp_path: Path) -> None:
    fleet = load_fleet(_write(tmp_path, HUSKY + '[[robots]]\ntype = "husky"\ncount = 2\n'))
    assert fleet.summary() == "2 husky" and [r.name for r in fleet.robot_types()] == ["husky", "husky"]


def test_a_block_layer_of_ones_own_loads_with_its_laying_spec(tmp_path: Path) -> None:
    fleet = load_fleet(_write(tmp_path, HUSKY + LAYER + '[[robots]]\ntype = "layer"\ncount = 1\n'))
    layer = fleet.types["layer"]
    assert layer.can(Capability.LAY) and not layer.can(Capability.PLACE) and layer.laying is not None
    assert fleet.with_robots(2, "husky").summary() == "2 husky, 1 layer"


def test_a_fleet_file_of_robots_alone_uses_bimbot_s_own_types(tmp_path: Path) -> None:
    fleet = load_fleet(_write(tmp_path, '[[robots]]\ntype = "carrier"\ncount = 2\n'))
    assert fleet.summary() == "2 carrier"
    assert fleet.types["carrier"] == default_fleet().types["carrier"]


def test_a_fleet_file_that_changes_a_built_in_type_changes_only_what_it_gives(tmp_path: Path) -> None:
    """``[types.carrier]`` with a payload alone is bimbot's carrier with that payload, in the default fleet;
    with its own robots, the carrier as changed and the crane it names but does not define are bimbot's."""
    default = default_fleet()
    changed = load_fleet(_write(tmp_path, "[types.carrier]\npayload_kg = 5000\n"))
    assert changed.types["carrier"] == default.types["carrier"].model_copy(update={"payload_kg": 5000.0})
    assert changed.robots == default.robots and changed.default_type == default.default_type
    assert {name: t for name, t in changed.types.items() if name != "carrier"} == {
        name: t for name, t in default.types.items() if name != "carrier"
    }
    own = load_fleet(
        _write(
            tmp_path,
            '[types.carrier]\nreach_m = 2.5\n[[robots]]\ntype = "carrier"\ncount = 2\n'
            '[[robots]]\ntype = "tower_crane"\ncount = 1\n',
        )
    )
    assert own.summary() == "2 carrier, 1 tower_crane"
    assert (
        own.types["carrier"].reach_m == 2.5
        and own.types["carrier"].payload_kg == default.types["carrier"].payload_kg
    )
    assert own.types["tower_crane"] == default.types["tower_crane"]
    with pytest.raises(InputError, match="payload_kgg: not a known key"):
        load_fleet(_write(tmp_path, "[types.carrier]\npayload_kgg = 5000\n"))
    with pytest.raises(
        InputError, match=r"\[types.carier\] is no type of bimbot's \(did you mean carrier\?\)"
    ):
        load_fleet(_write(tmp_path, "[types.carier]\npayload_kg = 5000\n"))


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("types = [", "not valid TOML"),
        (HUSKY + '[[robots]]\ntype = "crane"\ncount = 1\n', "unknown type"),
        (HUSKY + '[[robots]]\ntype = "huksy"\ncount = 1\n', "(did you mean husky?)"),
        (HUSKY.replace("payload_kg = 75", "payload_kg = -1"), "types.husky.payload_kg"),
        (HUSKY.replace("max_speed_mps = 1.0", "max_speed_mps = 0"), "needs max_speed_mps"),
        (HUSKY.replace("max_speed_mps = 1.0", "max_speed_mps = nan"), "finite number"),
        (
            HUSKY.replace("payload_kg = 75", "paylod_kg = 75"),
            "paylod_kg: not a known key (did you mean payload_kg?)",
        ),
        (
            HUSKY + '[[robots]]\ntype = "husky"\ncount = 1\nmax_sped_mps = 1\n',
            "max_sped_mps: not a known key (a robot type's limits go in its [types.NAME] table)",
        ),
        # the second [[robots]] entry, counted as its reader counts (pydantic's robots.1 counts from 0)
        (
            HUSKY + '[[robots]]\ntype = "husky"\ncount = 1\n[[robots]]\ntype = "husky"\ncuont = 1\n',
            "[[robots]] #2: count: missing; [[robots]] #2: cuont: not a known key (did you mean count?)",
        ),
        (LAYER.split("[types.layer.laying]", maxsplit=1)[0], "lay and a [laying] spec go together"),
        (
            LAYER.replace('"stand_fixed", "lay"', '"stand_fixed", "drive", "lay"'),
            "either drive or stand_fixed",
        ),
        (LAYER.replace('"stand_fixed", "lay"', '"stand_fixed", "fly"'), "types.layer.capabilities"),
        (LAYER.replace("blocks_per_h = 300", "blocks_per_h = 0"), "types.layer.laying.blocks_per_h"),
        (LAYER.replace('"lay"', '"hook_lift"').split("[types.layer.laying]")[0], "hook_lift and a [crane]"),
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


def test_the_site_plan_puts_ground_robots_at_the_depot_and_the_machines_around_the_building(
    bundled_build: Path,
) -> None:
    frame: Manifest = read_manifest(bundled_build)
    layout = plan_site(frame.components, fleet=DEFAULT.robot_types())
    (husky, carrier, crane, pump, layer, _line, _rig) = layout.robot_starts
    assert layout.depot.min_xy[0] <= husky[0] <= layout.depot.max_xy[0]
    assert layout.depot.min_xy[0] <= carrier[0] <= layout.depot.max_xy[0]
    assert crane[0] > layout.building.max_xy[0]  # east of the building: its hook nearest the yard
    assert pump[1] > layout.building.max_xy[1] and layer[1] > pump[1]  # north, one behind the other
    assert not layout.building.overlaps(layout.machines[3])  # the line pump stands outside, too
    assert len(layout.machines) == 5 and len(layout.staging) == 1  # only the crane has a staging area
    area = layout.staging[0]
    assert layout.fence.min_xy[0] < area.min_xy[0] and area.max_xy[0] < layout.fence.max_xy[0]


def _fleet_check(build: Path, *args: str) -> subprocess.CompletedProcess[str]:
    """``bimbot fleet check BUILD ARGS`` as a process of its own."""
    return subprocess.run(
        [sys.executable, "-m", "bimbot.cli", "fleet", "check", str(build), *args],
        capture_output=True,
        text=True,
        timeout=bound_s(120),
        check=False,
    )


def test_fleet_check_prints_the_husky_only_fleet_footings_too_heavy_with_the_numbers(
    bundled_build: Path, tmp_path: Path
) -> None:
    path = _write(tmp_path, HUSKY + '[[robots]]\ntype = "husky"\ncount = 2\n')
    done = _fleet_check(bundled_build, "--fleet", str(path))
    assert done.returncode == 1, done.stderr  # 1: the fleet cannot build everything
    assert "buildable: 19 of 28; cannot: 9 too_heavy" in done.stdout
    # what rests on the footings cannot be built either: the check says so, as a run's blocked_by would
    assert "of the buildable, 19 rest (directly or through others) on one that cannot" in done.stdout
    assert "so it can build at most 0" in done.stdout
    assert f"the fleet of {path}" in done.stdout.replace("\n", "")  # which file the table is for
    assert done.stdout.count("259 kg exceeds the largest payload on site (75 kg") == 9
    # --summary: the totals and the nine footings that cannot be built, no row for the 19 columns and beams;
    # the nine say the same, so they take one row (the Revit office's 4,105 rows ran to 39,709 lines)
    summary = _fleet_check(bundled_build, "--fleet", str(path), "--summary")
    assert summary.returncode == 1, summary.stderr
    assert "buildable: 19 of 28; cannot: 9 too_heavy" in summary.stdout
    assert summary.stdout.count("259 kg exceeds the largest payload on site (75 kg") == 1
    assert "9 components" in summary.stdout
    assert "(9 of 28 components)" in summary.stdout and "IfcColumn" not in summary.stdout


def test_fleet_check_leaves_off_site_the_machines_a_run_leaves_off_so_the_ids_are_the_run_s(
    bundled_build: Path,
) -> None:
    """The bundled frame is all lifted: bimbot run leaves the pumps and the block layer off site and numbers
    the robots without them; fleet check says so and numbers them as the run does (a new user read the
    line pump as r6 in the check and r5 in the run)."""
    done = _fleet_check(bundled_build)
    assert done.returncode == 0, done.stderr
    # where the machines that stand fixed stand (a new user could not tell where a second crane stood)
    where = next(line for line in done.stdout.splitlines() if line.startswith("set up round the building"))
    assert re.search(r"tower_crane r\d+ \(-?\d+\.\d, -?\d+\.\d\)", where), where
    idle = idle_machine_types(DEFAULT, [ConstructionMethod.LIFTED])
    assert idle  # the default fleet has machines that only pour or lay
    assert f"off site, no work in this build (as bimbot run leaves them): {', '.join(idle)}" in done.stdout
    for name in idle:
        assert f"{name} (r" not in done.stdout


def test_the_example_fleets_load_and_their_types_match_the_default_ones() -> None:
    examples = sorted((Path(__file__).resolve().parents[2] / "examples" / "fleets").glob("*.toml"))
    assert examples
    for path in examples:
        fleet = load_fleet(path)
        for name, description in fleet.types.items():
            # an example may give an hourly rate (bimbot study's cost); the machine itself is the default's
            machine = description.model_copy(update={"cost_per_h": DEFAULT.types[name].cost_per_h})
            assert machine == DEFAULT.types[name], f"{path.name}: {name} differs from the default fleet"
            assert description.cost_per_h is None or description.cost_per_h > 0


def test_fleet_show_with_a_file_prints_the_fleet_in_force_which_loads_back_the_same(tmp_path: Path) -> None:
    """``fleet show --fleet`` of a file that changes one field printed that file back, not the fleet a run
    would use; it now prints the whole fleet, the change laid over bimbot's, as a fleet file."""
    path = _write(tmp_path, "[types.carrier]\npayload_kg = 5000\n")
    done = subprocess.run(
        [sys.executable, "-m", "bimbot.cli", "fleet", "show", "--fleet", str(path), "--robots", "2"],
        capture_output=True,
        text=True,
        timeout=bound_s(120),
        check=True,
    )
    assert done.stdout.startswith(
        f"# the fleet in force: {path} laid over bimbot's default fleet, --robots 2"
    )
    shown = tmp_path / "shown.toml"
    shown.write_text(done.stdout, encoding="utf-8")
    in_force = load_fleet(path).with_robots(2)
    assert load_fleet(shown).model_dump() == in_force.model_dump()
    assert load_fleet(shown).types["carrier"].payload_kg == 5000.0


def test_the_first_route_line_breaks_between_entries_never_inside_one() -> None:
    """The console broke the structural sample's "216 piling_rig (r6)" between its name and its id."""
    from bimbot.fleet_cli import packed_lines

    entries = ["502 concrete_pump (r4)", "216 piling_rig (r6)", "172 line_pump (r5)", "22 husky"]
    lines = packed_lines("first route:", entries, 50)
    assert lines == [
        "first route: 502 concrete_pump (r4),",
        "216 piling_rig (r6), 172 line_pump (r5), 22 husky",
    ]
    assert all(len(line) <= 50 for line in lines)
    assert packed_lines("first route:", ["1 husky"], 160) == ["first route: 1 husky"]
