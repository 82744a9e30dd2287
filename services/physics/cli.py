"""``bimbot physics --build OUT/ [--robots N] [--rtf X] [--lock-step]``: simulate the site in PyBullet.

Builds the scene from a converted build (components in the yard, robots at the depot, fence; see
:mod:`.simulation`) and serves it on the bus: sim clock, odometry, laser scans, ground-truth poses,
velocity commands, attach and place requests (:mod:`.app`). Runs until SIGTERM/SIGINT (or ``--steps``),
then closes its Zenoh session and exits 0.
"""

from __future__ import annotations

import argparse
import logging
import math
import signal
import threading
from pathlib import Path

from bimbot.shared.bus import add_bus_arguments, bus_options
from bimbot.shared.errors import UserError
from bimbot.shared.manifest import load_manifest

from .handling import HandlingConfig
from .robots import RobotConfig
from .sensors import LaserConfig
from .simulation import SimConfig

_log = logging.getLogger(__name__)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sim, robot, laser, handling = SimConfig(), RobotConfig(), LaserConfig(), HandlingConfig()
    parser.add_argument(
        "--build", type=Path, required=True, metavar="OUT/", help="converted build (manifest.json)"
    )
    parser.add_argument(
        "--robots", type=int, default=sim.robots, help=f"robots at the depot (default {sim.robots})"
    )
    parser.add_argument(
        "--rtf",
        type=float,
        default=1.0,
        help="real-time factor: 1 real time, 0 as fast as possible (default 1)",
    )
    parser.add_argument(
        "--lock-step",
        action="store_true",
        help="advance a period only when every alive robot has answered the clock step (reproducible)",
    )
    parser.add_argument(
        "--lock-step-timeout-s", type=float, default=2.0, help="wall seconds to wait for a robot (default 2)"
    )
    parser.add_argument(
        "--wait-for-robots-s",
        type=float,
        default=0.0,
        metavar="S",
        help="hold the clock at 0 until every robot is alive, at most S wall seconds (default 0: no)",
    )
    parser.add_argument("--steps", type=int, default=None, help="stop after this many control periods")
    parser.add_argument(
        "--physics-hz", type=float, default=1.0 / sim.step_s, help="physics steps per sim second (240)"
    )
    parser.add_argument(
        "--control-period-s",
        type=float,
        default=sim.control_period_s,
        help="sim seconds per clock step (0.1)",
    )
    parser.add_argument("--seed", type=int, default=sim.seed, help="odometry noise seed (default 0)")
    parser.add_argument(
        "--odom-noise",
        type=float,
        default=sim.odom_noise,
        help=f"relative std of each odometry increment (default {sim.odom_noise:g}; 0: exact)",
    )
    parser.add_argument(
        "--reach-m",
        type=float,
        default=handling.reach_m,
        help=f"attach/place reach (default {handling.reach_m:g} m)",
    )
    parser.add_argument(
        "--pose-refresh-s", type=float, default=sim.pose_refresh_s, help="repeat every pose (2 s)"
    )
    group = parser.add_argument_group("robot")
    group.add_argument("--urdf", type=Path, default=None, help="robot URDF (default pybullet_data husky)")
    group.add_argument(
        "--wheel-joints",
        default=None,
        metavar="J1,J2,…",
        help="wheel joint names or indices (default: detected)",
    )
    group.add_argument("--max-speed-mps", type=float, default=robot.max_speed_mps, help="speed limit (1.0)")
    group.add_argument(
        "--max-turn-radps", type=float, default=robot.max_turn_radps, help="turn rate limit (1.5)"
    )
    group = parser.add_argument_group("laser")
    group.add_argument("--laser-beams", type=int, default=laser.beams, help="beams per scan (360)")
    group.add_argument(
        "--laser-fov-deg", type=float, default=math.degrees(laser.fov_rad), help="field of view (360)"
    )
    group.add_argument("--laser-range-m", type=float, default=laser.range_max_m, help="maximum range (15)")
    group.add_argument(
        "--laser-height-m", type=float, default=laser.height_m, help="height above ground (0.06)"
    )
    parser.add_argument("--gui", action="store_true", help="open pybullet's GUI instead of running headless")
    add_bus_arguments(parser)


def sim_config(args: argparse.Namespace) -> SimConfig:
    """The simulation config from the options (a UserError names what is wrong)."""
    try:
        wheels = (
            tuple(item.strip() for item in args.wheel_joints.split(",") if item.strip())
            if args.wheel_joints
            else ()
        )
        config = SimConfig(
            robots=args.robots,
            step_s=1.0 / args.physics_hz,
            control_period_s=args.control_period_s,
            reach_m=args.reach_m,
            odom_noise=args.odom_noise,
            seed=args.seed,
            lock_step=args.lock_step,
            real_time_factor=args.rtf,
            pose_refresh_s=args.pose_refresh_s,
            visuals=args.gui,
            robot=RobotConfig(
                urdf_path=args.urdf,
                wheel_joints=wheels,
                max_speed_mps=args.max_speed_mps,
                max_turn_radps=args.max_turn_radps,
            ),
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
    if args.rtf < 0 or args.robots > 1000:
        raise UserError("physics: --rtf must be >= 0 and --robots at most 1000")
    return config


def run(args: argparse.Namespace) -> int:
    from . import app  # pybullet and zenoh only when the command runs

    try:
        options = bus_options(args)
    except ValueError as error:
        raise UserError(str(error)) from error
    config = sim_config(args)
    manifest = load_manifest(args.build)
    if not manifest.components:
        raise UserError(f"{args.build}: the build has no components to simulate")
    build_dir = args.build if args.build.is_dir() else args.build.parent
    stop = threading.Event()
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda *_: stop.set())
    run_config = app.RunConfig(
        rtf=args.rtf,
        lock_step_timeout_s=args.lock_step_timeout_s,
        max_steps=args.steps,
        gui=args.gui,
        wait_for_robots_s=args.wait_for_robots_s,
    )
    try:
        return app.main(options, manifest, build_dir, config, run_config, stop)
    except (ValueError, OSError) as error:
        raise UserError(f"physics: {error}") from error
