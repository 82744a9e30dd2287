"""A machine with no work in a build stays off site: a pump comes for concrete, a block layer for masonry.

The default fleet brings a concrete pump, a line pump and a block layer; the bundled frame is all lifted,
so a run of it leaves those three off site: its own fleet, physics' (``--off-site``) and the robot processes
it starts agree, robot id by robot id, and the report's settings say which stayed away.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from bimbot.command_line import build_parser
from bimbot.run.commands import fleet_words, physics_arguments, run_fleet, service_commands, with_machines_for
from bimbot.run.options import RunOptions
from bimbot.run.settings import run_settings
from bimbot.services.physics.cli import fleet_of
from bimbot.shared.construction_methods import ConstructionMethod
from bimbot.shared.errors import UserError
from bimbot.shared.fleet import default_fleet
from bimbot.shared.idle_machines import idle_machine_types, site_fleet, without_types
from bimbot.shared.manifest import Manifest, read_manifest
from bimbot.shared.run_folder import RunFolder

LIFTED, CAST, LAID = ConstructionMethod.LIFTED, ConstructionMethod.CAST_IN_PLACE, ConstructionMethod.LAID
WORK_MACHINES = ("concrete_pump", "block_layer", "line_pump", "piling_rig")  # the default fleet's, in order


def _physics(*words: str) -> argparse.Namespace:
    argv = ["physics", "--build", "OUT", *words]
    return build_parser(argv).parse_args(argv)


def _with_method(manifest: Manifest, method: ConstructionMethod) -> Manifest:
    """``manifest`` with its first component built by ``method``."""
    first = manifest.components[0].model_copy(update={"method": method})
    return manifest.model_copy(update={"components": [first, *manifest.components[1:]]})


def test_a_machine_that_only_pours_or_lays_is_idle_without_its_method_and_a_lifter_never_is() -> None:
    fleet = default_fleet()
    assert idle_machine_types(fleet, [LIFTED]) == WORK_MACHINES
    assert idle_machine_types(fleet, [LIFTED, CAST]) == ("block_layer", "piling_rig")
    assert idle_machine_types(fleet, [LAID]) == ("concrete_pump", "line_pump", "piling_rig")
    assert idle_machine_types(fleet, [CAST, LAID]) == ("piling_rig",)
    assert idle_machine_types(fleet, [CAST, LAID, ConstructionMethod.DRIVEN]) == ()
    assert idle_machine_types(fleet, []) == WORK_MACHINES  # ground robots and cranes come even so
    assert without_types(fleet, WORK_MACHINES).summary() == "1 husky, 1 carrier, 1 tower_crane"


def test_a_run_of_the_all_lifted_frame_leaves_the_pumps_and_the_block_layer_off_site(
    bundled_build: Path, tmp_path: Path
) -> None:
    manifest = read_manifest(bundled_build)
    options = with_machines_for(RunOptions(robots=3), manifest)
    assert options.off_site == WORK_MACHINES
    assert run_fleet(options).summary() == "3 carrier, 1 tower_crane"
    assert fleet_words(options) == (  # not in brackets after the crane: it read as off site
        "3 carrier, 1 tower_crane; off site, no work in this build: concrete_pump, block_layer, line_pump, "
        "piling_rig"
    )
    arguments = physics_arguments(bundled_build, options)
    assert arguments[arguments.index("--off-site") + 1] == ",".join(WORK_MACHINES)
    # physics, given those words, serves the same robots under the same ids as the run starts
    physics_fleet = fleet_of(_physics("--robots", "3", "--off-site", ",".join(WORK_MACHINES)))
    assert (
        physics_fleet.type_of()
        == run_fleet(options).type_of()
        == {
            "r1": "carrier",
            "r2": "carrier",
            "r3": "carrier",
            "r4": "tower_crane",
        }
    )
    run = RunFolder(tmp_path / "run")
    robots = [name for name, _ in service_commands(bundled_build, "tcp/127.0.0.1:7000", options, run)]
    assert [name for name in robots if name.startswith("robot-")] == [
        "robot-r1",
        "robot-r2",
        "robot-r3",
        "robot-r4",
    ]
    assert run_settings(options)["off_site"] == list(WORK_MACHINES)


def test_a_cast_component_brings_the_pumps_and_the_default_run_keeps_every_machine_on_the_command_line(
    bundled_build: Path,
) -> None:
    cast = with_machines_for(RunOptions(), _with_method(read_manifest(bundled_build), CAST))
    assert cast.off_site == ("block_layer", "piling_rig")
    assert "concrete_pump" in run_fleet(cast).type_of().values()
    assert "--off-site" not in physics_arguments(Path("OUT"), RunOptions())  # physics alone: the whole fleet
    assert fleet_of(_physics()).summary() == default_fleet().summary()


def test_physics_names_an_off_site_type_the_fleet_does_not_have() -> None:
    with pytest.raises(UserError, match="--off-site names no robot type of the fleet: crane9"):
        fleet_of(_physics("--off-site", "crane9"))


def test_the_converter_plans_the_site_with_the_fleet_the_run_puts_on_it(bundled_build: Path) -> None:
    """The converter cuts precast parts for the crane's lift where the crane stands on the site plan; a
    piling rig (or a pump) the run leaves off site moved the plan's machines and cut the ArchiCAD house's
    walls into 40 panels where the run's crane needed 32. Both now take the same fleet."""
    manifest = read_manifest(bundled_build)
    for methods in ([LIFTED], [LIFTED, CAST], [ConstructionMethod.DRIVEN]):
        built = _with_method(manifest, methods[-1])
        options = with_machines_for(RunOptions(), built)
        fleet = site_fleet(default_fleet(), (component.method for component in built.components))
        assert fleet.type_of() == run_fleet(options).type_of()
        assert fleet.robot_types() == run_fleet(options).robot_types()
    assert "piling_rig" not in site_fleet(default_fleet(), [LIFTED]).type_of().values()
    assert "piling_rig" in site_fleet(default_fleet(), [ConstructionMethod.DRIVEN]).type_of().values()
