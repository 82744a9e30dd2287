"""Every service command's defaults are the fields of its config dataclass (one truth per fact).

Each sub-command parser is built as ``bimbot`` builds it, parsed with only its required arguments, and each
default compared with the dataclass field it stands for; every "(default X)" in a help text must then name
the parser's own default. A default typed again in a CLI (or a help text left behind) fails here.
"""

from __future__ import annotations

import argparse
import math
import re
from pathlib import Path

import pytest

from bimbot.command_line import build_parser
from bimbot.run.commands import physics_arguments
from bimbot.run.options import RunOptions, run_options
from bimbot.services.physics.app import RunConfig
from bimbot.services.physics.cli import apply_profile
from bimbot.services.physics.profiles import PROFILES, REHEARSAL, RUN_PROFILE
from bimbot.services.physics.sensors import LaserConfig
from bimbot.services.physics.simulation import SimConfig
from bimbot.services.planner.app import PlannerOptions
from bimbot.services.planner.records import PlannerLimits
from bimbot.services.robot.app import RobotOptions
from bimbot.services.robot.task_state import ExecutorConfig

REQUIRED = {
    "physics": ["--build", "OUT"],
    "agents": ["--build", "OUT"],
    "planner": ["--build", "OUT"],
    "robot": ["--build", "OUT", "--id", "r1"],
    "observe": ["--build", "OUT"],
}
_HELP_DEFAULT = re.compile(r"\(default (-?\d+(?:\.\d+)?(?:e-?\d+)?)(?![\w./])")  # not "1/1" (a shard)


def _parsed(name: str, *more: str) -> argparse.Namespace:
    argv = [name, *REQUIRED[name], *more]
    parsed = build_parser(argv).parse_args(argv)
    return apply_profile(parsed) if name == "physics" else parsed  # unset values come from the profile


def _sub_parser(name: str) -> argparse.ArgumentParser:
    parser = build_parser([name])
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices[name]


def _expected(name: str) -> dict[str, object]:
    if name == "physics":
        sim, laser, run = SimConfig(), LaserConfig(), RunConfig()
        return {
            "fleet": None,  # the embedded default fleet
            "robots": None,  # the fleet's robots; N: N of its default type
            "rtf": run.rtf,
            "lock_step_timeout_s": run.lock_step_timeout_s,
            "wait_for_robots_s": run.wait_for_robots_s,
            "steps": run.max_steps,
            "physics_hz": 1.0 / sim.step_s,
            "control_period_s": sim.control_period_s,
            "seed": sim.seed,
            "odom_noise": sim.odom_noise,
            "pose_refresh_s": sim.pose_refresh_s,
            "laser_beams": laser.beams,
            "laser_fov_deg": math.degrees(laser.fov_rad),
            "laser_range_m": laser.range_max_m,
            "laser_height_m": laser.height_m,
            # the placement tolerances in force on site: physics serves them to every service
            "position_tolerance_m": sim.tolerances.position_m,
            "angle_tolerance_deg": math.degrees(sim.tolerances.angle_rad),
            "drift_tolerance_m": sim.tolerances.drift_m,
        }
    if name == "agents":
        from bimbot.services.component_agents.agent import AgentConfig

        agent = AgentConfig()
        return {
            "max_attempts": agent.max_attempts,
            "verify_timeout_s": agent.verify_timeout_s,
        }
    if name == "planner":
        options, limits = PlannerOptions(), PlannerLimits()
        return {
            "agents_timeout_s": options.agents_timeout_s,
            "resend_s": options.resend_s,
            "site_info_timeout_s": options.site_info_timeout_s,
            "max_give_backs": limits.max_give_backs,
            "task_timeout_s": limits.task_timeout_s,
        }
    if name == "robot":
        executor = ExecutorConfig(robot_id="r1")
        return {
            "inject_placement_error_m": executor.placement_error_m,
            "inject_fraction": executor.inject_fraction,
            "seed": executor.seed,
            "place_duration_s": executor.place_duration_s,
            "info_timeout_s": RobotOptions().info_timeout_s,
        }
    from bimbot.services.observer.app import ObserverConfig
    from bimbot.services.observer.twin_log import TwinLogOptions

    twin = TwinLogOptions()
    return {
        "web_port": ObserverConfig.web_port,
        "grpc_port": ObserverConfig.grpc_port,
        "bind": ObserverConfig.bind,
        "scan_every": twin.scan_every,
        "pose_interval_s": twin.pose_min_interval_s,
    }


@pytest.mark.parametrize("name", sorted(REQUIRED))
def test_every_service_default_is_its_config_dataclass_field(name: str) -> None:
    parsed = vars(_parsed(name))
    for option, expected in _expected(name).items():
        if isinstance(expected, float):
            assert parsed[option] == pytest.approx(expected), option
        else:
            assert parsed[option] == expected, option


@pytest.mark.parametrize("name", sorted(REQUIRED))
def test_every_default_named_in_a_help_text_is_the_parsers_own(name: str) -> None:
    for action in _sub_parser(name)._actions:
        match = _HELP_DEFAULT.search(action.help or "")
        if match is None:
            continue
        assert isinstance(action.default, int | float), f"{action.dest}: help names a default it has not"
        assert float(match.group(1)) == pytest.approx(action.default, rel=1e-6), action.dest


def test_physics_takes_a_named_profile_and_single_options_override_one_value() -> None:
    rehearsal = vars(_parsed("physics", "--profile", RUN_PROFILE))
    assert PROFILES[RUN_PROFILE] is REHEARSAL
    assert (rehearsal["physics_hz"], rehearsal["control_period_s"], rehearsal["laser_beams"]) == (
        REHEARSAL.physics_hz,
        REHEARSAL.control_period_s,
        REHEARSAL.laser_beams,
    )
    assert (rehearsal["rtf"], rehearsal["lock_step"]) == (REHEARSAL.rtf, REHEARSAL.lock_step)
    assert rehearsal["wait_for_robots_s"] == REHEARSAL.wait_for_robots_s
    mixed = vars(_parsed("physics", "--profile", RUN_PROFILE, "--physics-hz", "240", "--no-lock-step"))
    assert mixed["physics_hz"] == 240.0 and mixed["lock_step"] is False
    assert mixed["control_period_s"] == REHEARSAL.control_period_s


def test_bimbot_run_names_its_profile_and_passes_only_what_the_user_changed() -> None:
    plain = physics_arguments(Path("OUT"), RunOptions(robots=2))
    wait = "--wait-for-planner"  # the planner's start-up is not sim time
    # the run's seed and its lock-step participants, who may be slow on a loaded machine
    seeded = ["--seed", "0", "--step-with", "planner,agents-1of1", "--lock-step-timeout-s", "60"]
    assert plain == ["physics", "--build", "OUT", wait, "--robots", "2", "--profile", RUN_PROFILE, *seeded]
    changed = physics_arguments(Path("OUT"), RunOptions(physics_hz=240.0, lock_step=False, seed=7))
    assert changed[-5:] == ["--physics-hz", "240.0", "--no-lock-step", "--seed", "7"]
    unconnected = physics_arguments(Path("OUT"), RunOptions(connections=False))
    assert unconnected[-len(seeded) - 1 :] == ["--no-connections", *seeded]
    patient = physics_arguments(Path("OUT"), RunOptions(clock_stall_wall_s=900.0))
    at = patient.index("--wait-for-robots-s")  # the clock waits for the planner as long as the run does
    assert patient[at + 1] == "900" and "--wait-for-robots-s" not in plain


def test_connections_are_made_unless_the_user_says_no_connections() -> None:
    default = build_parser(["run", "OUT"]).parse_args(["run", "OUT"])
    assert run_options(default).connections is True
    off = build_parser(["run", "OUT"]).parse_args(["run", "OUT", "--no-connections"])
    assert run_options(off).connections is False
    assert vars(_parsed("physics", "--no-connections"))["connections"] is False


def test_bimbot_run_and_physics_share_one_definition_of_the_profile_options() -> None:
    run = build_parser(["run", "OUT"]).parse_args(["run", "OUT", "--no-lock-step", "--laser-beams", "90"])
    assert run_options(run).lock_step is False and run_options(run).laser_beams == 90
    run_actions = {a.dest: a for a in _sub_parser("run")._actions}
    for action in _sub_parser("physics")._actions:
        if action.dest in ("profile", "rtf", "lock_step", "physics_hz", "control_period_s", "laser_beams"):
            twin = run_actions[action.dest]
            assert (twin.option_strings, twin.help is not None, twin.type) == (
                action.option_strings,
                action.help is not None,
                action.type,
            ), action.dest


def test_robots_n_keeps_the_fleets_machines_that_stand_fixed_in_run_physics_and_fleet_check() -> None:
    """``--robots 3``: three of the default type (carriers) and still the crane, the pump, the block layer,
    the line pump and the piling rig; the help says so wherever the option is."""
    from bimbot.run.commands import run_fleet
    from bimbot.services.physics.cli import fleet_of

    expected = "3 carrier, 1 tower_crane, 1 concrete_pump, 1 block_layer, 1 line_pump, 1 piling_rig"
    assert run_fleet(RunOptions(robots=3)).summary() == expected
    assert fleet_of(_parsed("physics", "--robots", "3")).summary() == expected
    for command in ("run", "physics", "fleet"):
        (robots,) = [a for a in _sub_parser(command)._actions if a.dest == "robots"]
        assert robots.help is not None and "fixed" in robots.help, command
