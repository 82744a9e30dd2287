"""The command line of every service a run starts: ``bimbot run`` starts them, its preflight parses them.

Kept apart from :mod:`bimbot.run` so that :mod:`bimbot.run_preflight` checks exactly the command lines the
run will start, without importing the run itself. Physics gets its profile by name and only the values the
user overrode (:mod:`bimbot.services.physics.profiles`); the agents and the observer get the run folder.
"""

from __future__ import annotations

from pathlib import Path

from bimbot.run_args import ObserverOptions, RunOptions
from bimbot.shared.run_folder import RunFolder


def physics_arguments(build: Path, options: RunOptions) -> list[str]:
    """``bimbot physics`` for a run: its profile by name, and only the values the user overrode."""
    arguments = [
        "physics",
        "--build",
        str(build),
        "--robots",
        str(options.robots),
        "--profile",
        options.profile,
    ]
    overrides = {
        "--rtf": options.rtf,
        "--physics-hz": options.physics_hz,
        "--control-period-s": options.control_period_s,
        "--laser-beams": options.laser_beams,
    }
    for flag, value in overrides.items():
        if value is not None:
            arguments += [flag, repr(value)]
    if options.lock_step is not None:
        arguments.append("--lock-step" if options.lock_step else "--no-lock-step")
    return [*arguments, *options.physics_extra]


def service_commands(
    build: Path, endpoint: str, options: RunOptions, run: RunFolder
) -> list[tuple[str, list[str]]]:
    """(name, bimbot arguments) of every service, in start order."""
    bus = ["--connect", endpoint]
    commands = [
        ("physics", [*physics_arguments(build, options), "--run-dir", str(run.root), *bus]),
        ("agents", ["agents", "--build", str(build), "--run-dir", str(run.root), "--fresh", *bus]),
        ("planner", ["planner", "--build", str(build), "--exit-when-done", *options.planner_source, *bus]),
    ]
    for number in range(1, options.robots + 1):
        robot = ["robot", "--build", str(build), "--id", f"r{number}", *bus]
        if options.inject_placement_error_m:
            robot += ["--inject-placement-error-m", repr(options.inject_placement_error_m)]
        commands.append((f"robot-r{number}", robot))
    if options.observer is not None:
        commands.append(("observer", [*observer_arguments(build, options.observer, run), *bus]))
    return commands


def observer_arguments(build: Path, observer: ObserverOptions, run: RunFolder) -> list[str]:
    arguments = ["observe", "--build", str(build), "--run-dir", str(run.root), "--no-report"]
    if observer.web:
        arguments += ["--web-port", str(observer.web_port), "--grpc-port", str(observer.grpc_port)]
    else:
        arguments.append("--no-web")
    if not observer.keep_serving:
        arguments.append("--exit-when-done")
    return arguments
