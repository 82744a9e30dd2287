"""The command line of every service a run starts: ``bimbot run`` starts them, its preflight parses them.

Kept apart from :mod:`bimbot.run` so that :mod:`bimbot.run_preflight` checks exactly the command lines the
run will start, without importing the run itself. Physics gets its profile by name and only the values the
user overrode (:mod:`bimbot.services.physics.profiles`); the agents and the observer get the run folder.
"""

from __future__ import annotations

from pathlib import Path

from bimbot.run_args import ObserverOptions, RunOptions
from bimbot.services.physics.profiles import PROFILES
from bimbot.shared.bus import BusOptions
from bimbot.shared.bus_access import robot_user
from bimbot.shared.bus_credentials import BusFiles, write_bus_credentials
from bimbot.shared.errors import UserError
from bimbot.shared.fleet import Fleet, load_fleet
from bimbot.shared.run_folder import RunFolder
from bimbot.shared.step_gate import HOLD_S
from bimbot.shared.tolerance_options import tolerance_flags


def run_fleet(options: RunOptions) -> Fleet:
    """The run's fleet: ``--fleet`` (else the default), with ``--robots N`` N of its default type and
    every machine of it that stands fixed (:meth:`bimbot.shared.fleet.Fleet.with_robots`)."""
    fleet = load_fleet(options.fleet)
    return fleet.with_robots(options.robots) if options.robots is not None else fleet


def physics_arguments(build: Path, options: RunOptions) -> list[str]:
    """``bimbot physics`` for a run: its fleet, its profile by name, and only the values the user
    overrode."""
    arguments = ["physics", "--build", str(build)]
    if options.fleet is not None:
        arguments += ["--fleet", str(options.fleet.resolve())]
    if options.robots is not None:
        arguments += ["--robots", str(options.robots)]
    arguments += ["--profile", options.profile, "--wait-for-planner"]  # its start-up is not sim time
    overrides = {
        "--rtf": options.rtf,
        "--physics-hz": options.physics_hz,
        "--control-period-s": options.control_period_s,
        "--laser-beams": options.laser_beams,
        "--command-latency-steps": options.command_latency_steps,
        "--total-station-mm": options.total_station_mm,
    }
    for flag, value in overrides.items():
        if value is not None:
            arguments += [flag, repr(value)]
    if options.lock_step is not None:
        arguments.append("--lock-step" if options.lock_step else "--no-lock-step")
    if not options.connections:
        arguments.append("--no-connections")
    arguments += tolerance_flags(options.tolerances)  # physics serves them to every service
    arguments += ["--seed", str(options.seed)]
    if stepped(options):  # the planner and the agents answer each step too (reproducible runs)
        arguments += ["--step-with", ",".join(STEPPED_PARTICIPANTS)]
        arguments += ["--lock-step-timeout-s", f"{HOLD_S:g}"]  # a loaded machine is not a hang
    return [*arguments, *options.physics_extra]


STEPPED_PARTICIPANTS = ("planner", "agents-1of1")  # a run's lock-step participants besides its robots


def stepped(options: RunOptions) -> bool:
    """Whether the run's services take part in physics' lock-step (every lock-step run): the planner, the
    agents and the robots then take their inputs at defined steps, and a seed gives one outcome."""
    lock_step = PROFILES[options.profile].lock_step if options.lock_step is None else options.lock_step
    return bool(lock_step)


def secure_bus(run: RunFolder, options: RunOptions, site: str) -> BusFiles | None:
    """With ``options.secure``: new credentials for this run's services in ``RUN/bus/`` (their paths);
    None for the open bus."""
    if not options.secure:
        return None
    try:
        return write_bus_credentials(run.root, list(run_fleet(options).type_of()), site=site)
    except (ValueError, OSError) as error:
        raise UserError(f"cannot secure the bus in {run.root}: {error}") from None


def router_arguments(endpoint: str, bus: BusFiles | None = None) -> list[str]:
    """``bimbot bus`` of a run: on ``endpoint``; with the access control when the bus is secured."""
    arguments = ["bus", "--listen", endpoint]
    return [*arguments, "--bus-config", str(bus.router)] if bus is not None else arguments


def monitor_bus_options(endpoint: str, bus: BusFiles | None = None) -> BusOptions:
    """The bus options of ``bimbot run``'s own session: read-only ``monitor`` on a secured bus."""
    if bus is None:
        return BusOptions(connect=(endpoint,))
    return BusOptions(mode="client", connect=(endpoint,), listen=(), config_file=bus.monitor)


def service_commands(
    build: Path, endpoint: str, options: RunOptions, run: RunFolder, bus: BusFiles | None = None
) -> list[tuple[str, list[str]]]:
    """(name, bimbot arguments) of every service, in start order; with ``bus`` (a secured bus) each in
    client mode with its own credentials."""

    def joined(user: str) -> list[str]:
        on_bus = ["--connect", endpoint]
        if bus is None:
            # lock-step: every service a client of the run's router, one link each, so what one service
            # sends reaches each other in the order it was sent (a peer mesh has two ways between two
            # services, the direct link and the router, and a step's answer overtook its messages)
            return [*on_bus, "--mode", "client"] if stepped(options) else on_bus
        return [*on_bus, "--mode", "client", "--bus-config", str(bus.service(user))]

    in_step = ["--stepped"] if stepped(options) else []
    agents = ["agents", "--build", str(build), "--run-dir", str(run.root), "--fresh", *in_step]
    if options.max_attempts is not None:
        agents += ["--max-attempts", str(options.max_attempts)]
    planner = ["planner", "--build", str(build), "--exit-when-done", *options.planner_source, *in_step]
    commands = [
        ("physics", [*physics_arguments(build, options), "--run-dir", str(run.root), *joined("physics")]),
        ("agents", [*agents, *joined("agents")]),
        ("planner", [*planner, *joined("planner")]),
    ]
    for robot_id in run_fleet(options).type_of():
        robot = ["robot", "--build", str(build), "--id", robot_id, "--seed", str(options.seed), *in_step]
        robot += joined(robot_user(robot_id))
        if options.inject_placement_error_m:
            robot += ["--inject-placement-error-m", repr(options.inject_placement_error_m)]
        commands.append((f"robot-{robot_id}", robot))
    if options.observer is not None:
        observer = observer_arguments(build, options.observer, run)
        commands.append(("observer", [*observer, *joined("observer")]))
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


def restart_arguments(arguments: list[str]) -> list[str]:
    """A service's command line when ``bimbot run`` restarts it (:mod:`bimbot.run_restarts`): the same,
    without ``--fresh``, so the agents resume from their journal instead of clearing it."""
    return [argument for argument in arguments if argument != "--fresh"]
