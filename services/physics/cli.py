"""``bimbot physics --build OUT/ [--fleet FILE] [--robots N] [--rtf X] [--lock-step]``: simulate the site in
PyBullet.

Builds the scene from a converted build (components in the yard, the fleet's ground robots at the depot
and its machines that stand fixed set up around the building, fence; see :mod:`.simulation`) and serves
it on the bus: sim clock, odometry, laser scans, ground-truth poses, velocity commands, attach and place
requests (:mod:`.app`).
Runs until SIGTERM/SIGINT (or ``--steps``), then closes its Zenoh session and exits 0. Options are checked
before anything starts (exit 2 with one line); the defaults are the fields of
:class:`.simulation.SimConfig`, :class:`.robots.RobotConfig`, :class:`.sensors.LaserConfig` and
:class:`.app.RunConfig`.

The fleet file (:mod:`bimbot.shared.fleet`; default: the embedded one) is the one source of each robot's
URDF and limits (speed, turn rate, reach, payload): physics clamps commands and checks attach and place
with them and serves them with its site info, where robots and the planner read them. There are no
physics options that override them.
"""

from __future__ import annotations

import argparse
import logging
import math
from pathlib import Path

from bimbot.shared.bus import add_bus_arguments
from bimbot.shared.errors import UserError
from bimbot.shared.fidelity import add_fidelity_argument
from bimbot.shared.fleet import MAX_ROBOTS, Fleet, load_fleet
from bimbot.shared.idle_machines import without_types
from bimbot.shared.option_types import (
    finite_float,
    non_negative_float,
    non_negative_int,
    positive_float,
    positive_int,
)
from bimbot.shared.run_folder import open_run_folder
from bimbot.shared.service_runner import resolve_build, run_service, service_bus, writable_dir
from bimbot.shared.tolerance_options import add_tolerance_arguments, tolerances_from

from .connections import ConnectionConfig
from .profiles import FINE, PROFILES, add_profile_arguments
from .robots import RobotConfig
from .sensors import LaserConfig
from .simulation import SimConfig
from .snapshot import clear_snapshot

_log = logging.getLogger(__name__)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The physics options; every default (and the default named in a help text) is its config's field."""
    from .app import RunConfig  # zenoh only for the physics command

    sim, laser, run = SimConfig(), LaserConfig(), RunConfig()
    parser.add_argument(
        "--build", type=Path, required=True, metavar="OUT/", help="converted build (folder or manifest.json)"
    )
    parser.add_argument(
        "--fleet",
        type=Path,
        default=None,
        metavar="FILE",
        help="the robot types on site and how many of each (TOML; default: bimbot's embedded fleet, "
        "a Husky, a heavy carrier, a tower crane, a concrete pump, a block-laying robot and a trailer line "
        "pump)",
    )
    parser.add_argument(
        "--robots",
        type=non_negative_int,
        default=None,
        metavar="N",
        help="N robots of the fleet's default_type instead of its ground robots, plus every machine of the "
        "fleet that stands fixed (default: the fleet's robots)",
    )
    parser.add_argument(
        "--off-site",
        default="",
        metavar="TYPE[,TYPE]",
        help="robot types of the fleet that stay off site (bimbot run: the machines with no work in the "
        "build, such as a concrete pump when nothing is cast)",
    )
    parser.add_argument(
        "--cranes",
        default="",
        metavar="TYPE=N[,TYPE=N]",
        help="crane counts the site erects instead of the fleet file's (bimbot run: sized for the "
        "building's footprint, up to an entry's up_to)",
    )
    add_profile_arguments(parser, FINE.name)  # bimbot run uses the rehearsal profile
    add_tolerance_arguments(parser)
    parser.add_argument(
        "--lock-step-timeout-s",
        type=positive_float,
        default=run.lock_step_timeout_s,
        help=f"wall seconds to wait for a robot (default {run.lock_step_timeout_s:g})",
    )
    add_fidelity_argument(parser)
    parser.add_argument(
        "--lost-grace-s",
        type=non_negative_float,
        default=run.lost_grace_s,
        help="wall seconds a robot whose liveliness went stays on site, waited for and holding its load, "
        "before it is stopped and its load dropped (a link or router down for a while; "
        f"default {run.lost_grace_s:g})",
    )
    parser.add_argument(
        "--wait-for-robots-s",
        type=non_negative_float,
        default=None,
        metavar="S",
        help="hold the clock at 0 until every robot is alive, at most S wall seconds (0: no)",
    )
    parser.add_argument(
        "--wait-for-planner",
        action="store_true",
        help="with --wait-for-robots-s, also hold the clock until the planner is alive (bimbot run does: "
        "the planner's start-up is not sim time)",
    )
    parser.add_argument(
        "--step-with",
        default="",
        metavar="NAMES",
        help="lock-step participants besides the robots, comma-separated (bimbot run: planner and each "
        "agents shard): physics waits for their answer to each step, so their decisions fall on the same "
        "step in every run",
    )
    parser.add_argument(
        "--steps", type=positive_int, default=run.max_steps, help="stop after this many control periods"
    )
    parser.add_argument(
        "--seed",
        type=int,
        default=sim.seed,
        help=f"seed of every random draw: odometry noise, placement precision, fixes (default {sim.seed})",
    )
    parser.add_argument(
        "--odom-noise",
        type=non_negative_float,
        default=sim.odom_noise,
        help=f"relative std of each odometry increment (default {sim.odom_noise:g}; 0: exact)",
    )
    parser.add_argument(
        "--pose-refresh-s",
        type=positive_float,
        default=sim.pose_refresh_s,
        help=f"repeat every pose this often, wall s (default {sim.pose_refresh_s:g})",
    )
    parser.add_argument(
        "--pose-refresh-max",
        type=positive_int,
        default=sim.pose_refresh_max,
        help=f"repeat at most this many poses a control period (default {sim.pose_refresh_max})",
    )
    group = parser.add_argument_group("robot")
    group.add_argument(
        "--wheel-joints",
        default=None,
        metavar="J1,J2,…",
        help="wheel joint names or indices, for every ground robot type (default: detected)",
    )
    group = parser.add_argument_group("laser")
    fov_deg = math.degrees(laser.fov_rad)
    group.add_argument(
        "--laser-fov-deg",
        type=positive_float,
        default=fov_deg,
        help=f"field of view, degrees (default {fov_deg:g})",
    )
    group.add_argument(
        "--laser-range-m",
        type=positive_float,
        default=laser.range_max_m,
        help=f"maximum range (default {laser.range_max_m:g} m)",
    )
    group.add_argument(
        "--laser-height-m",
        type=finite_float,
        default=laser.height_m,
        help=f"height above ground (default {laser.height_m:g} m)",
    )
    parser.add_argument("--gui", action="store_true", help="open pybullet's GUI instead of running headless")
    parser.add_argument(
        "--run-dir",
        type=Path,
        default=None,
        metavar="DIR",
        help="the run's folder: physics keeps its record of the site in DIR/state/ and, "
        "restarted, continues from it (default OUT/runs/latest, made when missing)",
    )
    parser.add_argument(
        "--fresh", action="store_true", help="ignore a record left by an earlier physics of this run"
    )
    add_bus_arguments(parser)


def apply_profile(args: argparse.Namespace) -> argparse.Namespace:
    """Fill every option left unset from the named profile (idempotent; the user's values stay)."""
    profile = PROFILES[args.profile]
    for name, value in (
        ("rtf", profile.rtf),
        ("lock_step", profile.lock_step),
        ("wait_for_robots_s", profile.wait_for_robots_s),
        ("physics_hz", profile.physics_hz),
        ("control_period_s", profile.control_period_s),
        ("laser_beams", profile.laser_beams),
        ("command_latency_steps", profile.command_latency_steps),
        ("total_station_mm", profile.total_station_mm),
    ):
        if getattr(args, name) is None:
            setattr(args, name, value)
    return args


def fleet_of(args: argparse.Namespace) -> Fleet:
    """The fleet on site: ``--fleet`` (or the embedded default), with ``--robots N`` robots of its default
    type and its machines that stand fixed when given, none of the ``--off-site`` types; every type's URDF
    found. An InputError (one line) when the file or a URDF is bad."""
    fleet = load_fleet(args.fleet)
    if args.robots is not None:
        fleet = fleet.with_robots(args.robots)
    off_site = [name.strip() for name in args.off_site.split(",") if name.strip()]
    unknown = sorted(set(off_site) - set(fleet.types))
    if unknown:
        raise UserError(f"physics: --off-site names no robot type of the fleet: {', '.join(unknown)}")
    fleet = without_types(fleet, off_site).with_counts(crane_counts(args.cranes, fleet))
    for description in fleet.on_site().values():
        fleet.resolve_urdf(description.urdf)
    return fleet


def crane_counts(text: str, fleet: Fleet) -> dict[str, int]:
    """``--cranes tower_crane=3`` as ``{"tower_crane": 3}``; a UserError names what is wrong."""
    counts: dict[str, int] = {}
    for item in (part.strip() for part in text.split(",") if part.strip()):
        name, _, number = item.partition("=")
        if name.strip() not in fleet.types or not number.strip().isdigit():
            raise UserError(f"physics: --cranes wants TYPE=N with a robot type of the fleet, not {item!r}")
        counts[name.strip()] = int(number)
    return counts


def sim_config(args: argparse.Namespace) -> SimConfig:
    """The simulation config from the options and their profile (filled into ``args``); a UserError names
    what is wrong (also the options that only the adapter uses: rtf, lock-step timeout, the fleet's URDFs),
    so ``bimbot run`` can check them all up front."""
    apply_profile(args)
    if args.robots is not None and args.robots > MAX_ROBOTS:
        raise UserError(f"physics: --robots must be at most {MAX_ROBOTS}")
    fleet = fleet_of(args)
    try:
        wheels = (
            tuple(item.strip() for item in args.wheel_joints.split(",") if item.strip())
            if args.wheel_joints
            else ()
        )
        config = SimConfig(
            fleet=fleet,
            step_s=1.0 / args.physics_hz,
            control_period_s=args.control_period_s,
            odom_noise=args.odom_noise,
            seed=args.seed,
            lock_step=args.lock_step,
            command_latency_steps=args.command_latency_steps if args.lock_step else 0,
            real_time_factor=args.rtf,
            pose_refresh_s=args.pose_refresh_s,
            pose_refresh_max=args.pose_refresh_max,
            visuals=args.gui,
            total_station_std_m=args.total_station_mm / 1000.0 if args.total_station_mm > 0 else None,
            connections=ConnectionConfig(enabled=args.connections),
            tolerances=tolerances_from(args),
            robot=RobotConfig(wheel_joints=wheels),
            laser=LaserConfig(
                beams=args.laser_beams,
                fov_rad=math.radians(args.laser_fov_deg),
                range_max_m=args.laser_range_m,
                height_m=args.laser_height_m,
            ),
        )
        config.validate()
    except (ValueError, ZeroDivisionError) as error:
        raise UserError(f"physics: {error}") from error
    if args.rtf < 0:
        raise UserError("physics: --rtf must be >= 0")
    if args.lock_step_timeout_s <= 0 or args.wait_for_robots_s < 0:
        raise UserError("physics: --lock-step-timeout-s must be positive and --wait-for-robots-s ≥ 0")
    return config


def run(args: argparse.Namespace) -> int:
    """Check every option and the build (UserErrors), then serve the scene until stopped."""
    from . import app  # pybullet and zenoh only when the command runs

    options = service_bus(args)
    config = sim_config(args)
    build = resolve_build(args.build)
    if not build.manifest.components:
        raise UserError(f"{args.build}: the build has no components to simulate")
    state_dir = open_run_folder(build.dir, args.run_dir).state_dir
    writable_dir(state_dir, "--run-dir")
    if args.fresh:
        clear_snapshot(state_dir)
    run_config = app.RunConfig(
        rtf=args.rtf,
        lock_step_timeout_s=args.lock_step_timeout_s,
        max_steps=args.steps,
        gui=args.gui,
        wait_for_robots_s=args.wait_for_robots_s,
        wait_for_planner=args.wait_for_planner,
        state_dir=state_dir,
        step_with=tuple(name.strip() for name in args.step_with.split(",") if name.strip()),
        lost_grace_s=args.lost_grace_s,
        fidelity=args.fidelity,
    )
    return run_service(app.main, options, build, config, run_config)
