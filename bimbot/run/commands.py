"""The command line of every service a run starts: ``bimbot run`` starts them, its preflight parses them.

Kept apart from :mod:`bimbot.run.build` so that :mod:`bimbot.run.preflight` checks exactly the command
lines the run will start, without importing the run itself. Physics gets its profile by name and only the
values the user overrode (:mod:`bimbot.services.physics.profiles`); the agents and the observer get the run
folder.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

from bimbot.run.options import ObserverOptions, RunOptions, service_flags
from bimbot.run.watchdog import DEFAULT_CLOCK_STALL_WALL_S
from bimbot.services.physics.profiles import PROFILES
from bimbot.shared.bus import BusOptions
from bimbot.shared.bus_access import robot_user
from bimbot.shared.bus_credentials import BusFiles, write_bus_credentials
from bimbot.shared.crane_count import crane_count_words, sized_cranes
from bimbot.shared.errors import UserError
from bimbot.shared.fleet import Fleet, load_fleet
from bimbot.shared.idle_machines import idle_machine_types, without_types
from bimbot.shared.manifest import Manifest
from bimbot.shared.run_folder import RunFolder
from bimbot.shared.step_gate import HOLD_S

#: With two routers, how long physics and the planner wait for a robot whose liveliness went (a router or
#: link down) before they drop its load and give its task back (wall s).
LINK_GRACE_S = 30.0


def run_fleet(options: RunOptions) -> Fleet:
    """The run's fleet: ``--fleet`` (else the default), with ``--robots N`` N of its default type and
    every machine of it that stands fixed (:meth:`bimbot.shared.fleet.Fleet.with_robots`), without the
    types that stay off site (``options.off_site``)."""
    fleet = load_fleet(options.fleet)
    fleet = fleet.with_robots(options.robots) if options.robots is not None else fleet
    return without_types(fleet, options.off_site).with_counts(dict(options.cranes))


def with_machines_for(options: RunOptions, manifest: Manifest) -> RunOptions:
    """``options`` with ``off_site`` the machine types of the run's fleet that no component of
    ``manifest`` gives work (:func:`bimbot.shared.idle_machines.idle_machine_types`), and ``cranes`` the
    crane counts the site erects for the building (:func:`bimbot.shared.crane_count.sized_cranes`)."""
    fleet = run_fleet(replace(options, off_site=(), cranes=()))
    idle = idle_machine_types(fleet, (component.method for component in manifest.components))
    on_site = without_types(fleet, idle)
    sized = sized_cranes(on_site, manifest.components)
    before = {entry.type: entry.count for entry in on_site.robots}
    cranes = tuple((entry.type, entry.count) for entry in sized.robots if entry.count != before[entry.type])
    return replace(options, off_site=idle, cranes=cranes)


def fleet_words(options: RunOptions) -> str:
    """The run's fleet in words, and the machines left off site: ``1 husky, 1 carrier, 1 tower_crane;
    off site, no work in this build: concrete_pump, block_layer`` (in brackets after the last machine, a
    trial user read the tower crane as off site); a crane count raised for the building's footprint is
    said with the file's."""
    words = run_fleet(options).summary()
    raised = crane_count_words(run_fleet(replace(options, cranes=())), run_fleet(options))
    if raised:
        words += f"; {'; '.join(raised)}"
    if options.off_site:
        words += f"; off site, no work in this build: {', '.join(options.off_site)}"
    return words


def physics_arguments(build: Path, options: RunOptions) -> list[str]:
    """``bimbot physics`` for a run: its fleet, its profile by name, and only the values the user overrode
    (:func:`~bimbot.run.options.service_flags`)."""
    arguments = ["physics", "--build", str(build), "--wait-for-planner"]  # its start-up is not sim time
    arguments += service_flags("physics", options)  # the tolerances too: physics serves them to every service
    if 0.0 < options.clock_stall_wall_s != DEFAULT_CLOCK_STALL_WALL_S:  # the clock waits as long as the run
        arguments += ["--wait-for-robots-s", f"{options.clock_stall_wall_s:g}"]
    if options.off_site:
        arguments += ["--off-site", ",".join(options.off_site)]
    if options.cranes:
        arguments += ["--cranes", ",".join(f"{name}={count}" for name, count in options.cranes)]
    if stepped(options):  # the planner and the agents answer each step too (reproducible runs)
        arguments += ["--step-with", ",".join(stepped_participants(options))]
        arguments += ["--lock-step-timeout-s", f"{HOLD_S:g}"]  # a loaded machine is not a hang
    return [*arguments, *options.physics_extra]


def stepped_participants(options: RunOptions) -> tuple[str, ...]:
    """A run's lock-step participants besides its robots: the planner and each agents shard."""
    shards = max(1, options.routers)  # two routers: an agents shard beside each
    return ("planner", *(f"agents-{shard}of{shards}" for shard in range(1, shards + 1)))


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


def router_commands(endpoints: Sequence[str], bus: BusFiles | None = None) -> list[tuple[str, list[str]]]:
    """(name, bimbot arguments) of the run's routers: ``bus`` on the first endpoint; with a second,
    ``bus-2`` on it, linked router to router to the first (it connects, and reconnects after either dies)."""
    commands = [("bus", router_arguments(endpoints[0], bus))]
    for number, endpoint in enumerate(endpoints[1:], start=2):
        commands.append((f"bus-{number}", [*router_arguments(endpoint, bus), "--connect", endpoints[0]]))
    return commands


def monitor_bus_options(endpoint: str, bus: BusFiles | None = None, routers: int = 1) -> BusOptions:
    """The bus options of ``bimbot run``'s own session: read-only ``monitor`` on a secured bus; a client
    of the first router when the site has two (what it hears from the other half crossed their link)."""
    if bus is None:
        if routers > 1:
            return BusOptions(mode="client", connect=(endpoint,), listen=())
        return BusOptions(connect=(endpoint,))
    return BusOptions(mode="client", connect=(endpoint,), listen=(), config_file=bus.monitor)


def service_commands(
    build: Path,
    endpoint: str,
    options: RunOptions,
    run: RunFolder,
    bus: BusFiles | None = None,
    *,
    second_endpoint: str | None = None,
) -> list[tuple[str, list[str]]]:
    """(name, bimbot arguments) of every service, in start order; with ``bus`` (a secured bus) each in
    client mode with its own credentials.

    With two routers (``options.routers``), a site across two hosts: physics, the planner, the observer
    and agent shard 1/2 join the first router (``endpoint``), the robots and shard 2/2 the second
    (``second_endpoint``), every one in client mode, so all that passes between the two halves crosses
    the routers' link."""
    two_hosts = options.routers > 1

    def joined(user: str, where: str = endpoint) -> list[str]:
        on_bus = ["--connect", where]
        if bus is None:
            # lock-step or two hosts: every service a client of a router, one link each, so what one
            # service sends reaches each other in the order it was sent (a peer mesh has two ways between
            # two services, the direct link and the router, and a step's answer overtook its messages)
            return [*on_bus, "--mode", "client"] if stepped(options) or two_hosts else on_bus
        return [*on_bus, "--mode", "client", "--bus-config", str(bus.service(user))]

    other = second_endpoint or endpoint
    in_step = ["--stepped"] if stepped(options) else []
    agents = ["agents", "--build", str(build), "--run-dir", str(run.root), "--fresh", *in_step]
    agents += service_flags("agents", options)
    planner = ["planner", "--build", str(build), "--exit-when-done", *service_flags("planner", options)]
    planner += in_step
    grace = ["--lost-grace-s", repr(LINK_GRACE_S)] if two_hosts else []  # ride out a router's restart
    physics = [*physics_arguments(build, options), "--run-dir", str(run.root), *grace]
    commands = [("physics", [*physics, *joined("physics")])]
    if two_hosts:
        commands += [
            ("agents-1", [*agents, "--shard", "1/2", *joined("agents")]),
            ("agents-2", [*agents, "--shard", "2/2", *joined("agents", other)]),
        ]
    else:
        commands.append(("agents", [*agents, *joined("agents")]))
    commands.append(("planner", [*planner, *grace, *joined("planner")]))
    for robot_id in run_fleet(options).type_of():
        robot = ["robot", "--build", str(build), "--id", robot_id, *service_flags("robot", options), *in_step]
        robot += joined(robot_user(robot_id), other)
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
    """A service's command line when ``bimbot run`` restarts it (:mod:`bimbot.run.restarts`): the same,
    without ``--fresh``, so the agents resume from their journal instead of clearing it."""
    return [argument for argument in arguments if argument != "--fresh"]
