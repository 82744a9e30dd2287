"""``bimbot run``'s service options are declared once (:data:`bimbot.run.options.SERVICE_OPTIONS`): every
service takes the flags the run passes it, a value the user gives reaches the service that uses it as the
same value (each command line parsed by its service's own parser), and a run left at its defaults passes
nothing but its profile and its seed."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from bimbot.command_line import build_parser
from bimbot.run.commands import service_commands
from bimbot.run.options import SERVICE_OPTIONS, RunOptions, run_options
from bimbot.run.preflight import parse_service_arguments
from bimbot.shared.run_folder import RunFolder


def _service_parser(command: str) -> argparse.ArgumentParser:
    parser = build_parser([command])
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices[command]


@pytest.mark.parametrize("option", SERVICE_OPTIONS, ids=lambda option: option.spec.flag)
def test_every_service_takes_the_options_the_run_passes_it(option) -> None:
    for service in option.services:
        parser = _service_parser(service)
        actions = {flag: action for action in parser._actions for flag in action.option_strings}
        assert option.spec.flag in actions, f"{service} does not take {option.spec.flag}"
        assert tuple(actions[option.spec.flag].choices or ()) == tuple(option.spec.choices or ()), service


def _commands(tmp_path: Path, *run_args: str) -> dict[str, argparse.Namespace]:
    args = build_parser(["run", "OUT"]).parse_args(["run", "OUT", *run_args])
    commands = service_commands(Path("OUT"), "tcp/127.0.0.1:7447", run_options(args), RunFolder(tmp_path))
    return {name: parse_service_arguments(name, arguments) for name, arguments in commands}


def test_what_the_user_sets_on_the_run_reaches_each_service_that_uses_it(tmp_path: Path) -> None:
    parsed = _commands(
        tmp_path,
        *("--robots", "2", "--rtf", "2.5", "--no-lock-step", "--laser-beams", "90", "--no-connections"),
        *("--position-tolerance-m", "0.02", "--angle-tolerance-deg", "2", "--drift-tolerance-m", "0.007"),
        *("--seed", "5", "--inject-placement-error-m", "0.03", "--max-attempts", "4"),
        *("--sequence", "plan.xml", "--strict", "--profile", "fine"),
    )
    physics = parsed["physics"]
    assert (physics.robots, physics.rtf, physics.lock_step, physics.laser_beams) == (2, 2.5, False, 90)
    assert (physics.connections, physics.profile, physics.seed) == (False, "fine", 5)
    assert physics.position_tolerance_m == 0.02 and physics.drift_tolerance_m == 0.007
    assert physics.angle_tolerance_deg == pytest.approx(2.0)
    assert (parsed["agents"].max_attempts, parsed["planner"].sequence, parsed["planner"].strict) == (
        4,
        Path("plan.xml"),
        True,
    )
    robots = [args for name, args in parsed.items() if name.startswith("robot-")]
    assert robots and all((r.seed, r.inject_placement_error_m) == (5, 0.03) for r in robots)


def test_a_run_at_its_defaults_passes_only_its_profile_and_seed(tmp_path: Path) -> None:
    args = build_parser(["run", "OUT"]).parse_args(["run", "OUT"])
    options = run_options(args)
    assert options == RunOptions(show_progress=options.show_progress)
    passed = {
        word
        for _, arguments in service_commands(Path("OUT"), "tcp/127.0.0.1:7447", options, RunFolder(tmp_path))
        for word in arguments
    }
    optional = {o.spec.flag for o in SERVICE_OPTIONS if not o.always} | {"--no-connections", "--no-lock-step"}
    assert passed & optional == set()
    assert {"--profile", "--seed"} <= passed


def test_the_planner_source_options_exclude_each_other_and_travel_as_given(tmp_path: Path) -> None:
    with pytest.raises(SystemExit):
        build_parser(["run", "OUT"]).parse_args(["run", "OUT", "--derive", "--sequence", "a.xml"])
    assert _commands(tmp_path, "--derive")["planner"].derive is True
    assert _commands(tmp_path, "--from-ifc")["planner"].from_ifc == ""
    assert _commands(tmp_path, "--from-ifc", "m.ifc")["planner"].from_ifc == "m.ifc"
