"""Named simulation profiles: the settings of a run that go together, chosen by one name.

A profile fixes how finely the site is simulated (physics rate, the robots' control period, laser beams)
and how the clock is paced (real-time factor, lock-step, how long the clock waits for the robots at
start). ``bimbot physics --profile NAME``, ``bimbot run --profile NAME`` and ``compose.yaml`` all name a
profile instead of repeating its numbers; single options (``--physics-hz`` …) still override one value.

* ``rehearsal`` (what ``bimbot run``, ``bimbot demo`` and compose use): 120 Hz physics, a 5 Hz control
  loop (DWA, localisation, the lock-step handshake) and a 180-beam laser (2°: a 0.2 m column at 5 m
  still takes a beam), lock-step and as fast as the robots follow, with one control period (0.2 s) between
  a robot's sensing and its command taking effect: physics steps the next period while the robots think,
  on the other core, and every robot plans from where it will be when its command acts (a real robot's
  sensing-to-actuation latency, held exact and reproducible). It builds the bundled frame within
  tolerance in about half the wall time of ``fine`` (measured with ``bench/build.py``).
* ``fine``: 240 Hz physics, a 10 Hz control loop and a 360-beam laser, real time and free-running (no
  latency held): for watching a site in pybullet's GUI. :class:`.simulation.SimConfig` and
  :class:`.sensors.LaserConfig` take their defaults from it (this module imports nothing of pybullet, so
  ``bimbot run`` stays light).

``wait_for_robots_s`` is an upper bound: the clock starts as soon as every robot is alive, so a long
bound costs nothing when the robots come up fast (compose's containers need longer than local processes).
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

from bimbot.shared.option_types import non_negative_float, positive_float, positive_int


@dataclass(frozen=True)
class SimProfile:
    name: str
    physics_hz: float
    control_period_s: float
    laser_beams: int
    rtf: float  # real-time factor: 1 real time, 0 as fast as possible
    lock_step: bool  # advance a period only when every alive robot answered the clock step
    wait_for_robots_s: float  # hold the clock at 0 until every robot is alive, at most this (wall s)
    # control periods between a robot's sensing and its command taking effect (lock-step): with 1, physics
    # steps the next period while the robots compute their commands for the one after (see app.py)
    command_latency_steps: int = 0


REHEARSAL = SimProfile(
    name="rehearsal",
    physics_hz=120.0,
    control_period_s=0.2,
    laser_beams=180,
    rtf=0.0,
    lock_step=True,
    wait_for_robots_s=300.0,
    command_latency_steps=1,
)
FINE = SimProfile(
    name="fine",
    physics_hz=240.0,
    control_period_s=0.1,
    laser_beams=360,
    rtf=1.0,
    lock_step=False,
    wait_for_robots_s=0.0,
)
PROFILES: dict[str, SimProfile] = {profile.name: profile for profile in (REHEARSAL, FINE)}
RUN_PROFILE = REHEARSAL.name  # bimbot run, bimbot demo, compose


def add_profile_arguments(parser: argparse.ArgumentParser, default: str) -> None:
    """``--profile`` and the options that override one of its values (unset: the profile's), defined once for
    ``bimbot physics`` and ``bimbot run``/``demo``."""
    chosen = PROFILES[default]
    parser.add_argument(
        "--profile",
        choices=sorted(PROFILES),
        default=default,
        help=f"named simulation settings (default {default}: {chosen.physics_hz:g} Hz physics, "
        f"{chosen.control_period_s:g} s control period, {chosen.laser_beams} laser beams, "
        f"{'lock-step' if chosen.lock_step else 'free-running'}, "
        f"{'as fast as the robots follow' if chosen.rtf == 0 else f'real-time factor {chosen.rtf:g}'}; "
        f"profiles: {', '.join(sorted(PROFILES))}, see services/physics/profiles.py); "
        "the next options override one value of it",
    )
    parser.add_argument(
        "--rtf",
        type=non_negative_float,
        default=None,
        help="real-time factor: 1 real time, 0 as fast as possible",
    )
    parser.add_argument(
        "--lock-step",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="advance a period only when every alive robot has answered the clock step (reproducible)",
    )
    parser.add_argument(
        "--physics-hz", type=positive_float, default=None, help="physics steps per sim second"
    )
    parser.add_argument(
        "--control-period-s",
        type=positive_float,
        default=None,
        help="sim seconds per clock step (control period)",
    )
    parser.add_argument("--laser-beams", type=positive_int, default=None, help="beams per laser scan")
    parser.add_argument(
        "--total-station-mm",
        type=positive_float,
        default=None,
        metavar="STD_MM",
        help="a robotic total station on site: every ground robot gets a fix of its position each control "
        "period with this standard deviation (mm), fused by its localisation; for large sites, where the "
        "laser sees nothing in the empty footprint (default: none, laser and odometry only)",
    )
    parser.add_argument(
        "--connections",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="a component set down at its target beside a component already built is connected to it "
        "(bolted, welded, fixed) while its robot holds it, and stands; --no-connections: every component "
        "must stand by itself (default: connections are made)",
    )
    parser.add_argument(
        "--command-latency-steps",
        type=int,
        choices=(0, 1),
        default=None,
        help="control periods between a robot's sensing and its command taking effect, in lock-step "
        "(1: physics steps while the robots think)",
    )
