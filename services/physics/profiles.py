"""Named simulation profiles: the settings of a run that go together, chosen by one name.

A profile fixes how finely the site is simulated (physics rate, the robots' control period, laser beams)
and how the clock is paced (real-time factor, lock-step, how long the clock waits for the robots at
start). ``bimbot physics --profile NAME``, ``bimbot run --profile NAME`` and ``compose.yaml`` all name a
profile instead of repeating its numbers; single options (``--physics-hz`` …) still override one value.

* ``rehearsal`` (what ``bimbot run``, ``bimbot demo`` and compose use): 120 Hz physics, a 5 Hz control
  loop (DWA, localisation, the lock-step handshake) and a 180-beam laser (2°: a 0.2 m column at 5 m
  still takes a beam), a robotic total station tracking every ground robot (3 mm, as sites set out: a
  laser alone left the Revit samples' carriers 0.1–0.3 m off where the footprint is empty or cluttered),
  lock-step and as fast as the robots follow, with one control period (0.2 s) between
  a robot's sensing and its command taking effect: physics steps the next period while the robots think,
  on the other core, and every robot plans from where it will be when its command acts (a real robot's
  sensing-to-actuation latency, held exact and reproducible). It builds the bundled frame within
  tolerance in about half the wall time of ``fine`` (measured with ``bench/build.py``).
* ``fine``: 240 Hz physics, a 10 Hz control loop and a 360-beam laser, no total station (the paper's
  laser-only robots), real time and free-running (no latency held): for watching a site in pybullet's
  GUI. :class:`.simulation.SimConfig` and :class:`.sensors.LaserConfig` take their defaults from it
  (this module imports nothing of pybullet, so ``bimbot run`` stays light).

``wait_for_robots_s`` is an upper bound: the clock starts as soon as every robot is alive, so a long
bound costs nothing when the robots come up fast (compose's containers need longer than local processes).
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

from bimbot.shared.option_types import (
    OptionSpec,
    non_negative_float,
    non_negative_float_up_to,
    positive_float,
    positive_int,
)


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
    # a robotic total station tracking every ground robot, 1σ of its fixes (mm; 0: none, laser only)
    total_station_mm: float = 0.0


# A robotic total station in tracking mode: about 3 mm + 1.5 ppm on a moving prism (a typical instrument's
# data sheet; check your own). Sites set out with one; a run without it is the paper's laser-only robots.
SITE_TOTAL_STATION_MM = 3.0
# the coarsest a run takes (1 m): coarser fixes are no positioning sensor (SimConfig checks it in m)
MAX_TOTAL_STATION_MM = 1000.0

REHEARSAL = SimProfile(
    name="rehearsal",
    physics_hz=120.0,
    control_period_s=0.2,
    laser_beams=180,
    rtf=0.0,
    lock_step=True,
    wait_for_robots_s=300.0,
    command_latency_steps=1,
    total_station_mm=SITE_TOTAL_STATION_MM,
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


def profile_option(default: str) -> OptionSpec:
    """``--profile``, defaulting to ``default`` (``fine`` for ``bimbot physics``, ``rehearsal`` for a run)."""
    chosen = PROFILES[default]
    return OptionSpec(
        "--profile",
        choices=tuple(sorted(PROFILES)),
        default=default,
        help=f"named simulation settings (default {default}: {chosen.physics_hz:g} Hz physics, "
        f"{chosen.control_period_s:g} s control period, {chosen.laser_beams} laser beams, "
        f"{'lock-step' if chosen.lock_step else 'free-running'}, "
        f"{'as fast as the robots follow' if chosen.rtf == 0 else f'real-time factor {chosen.rtf:g}'}; "
        f"profiles: {', '.join(sorted(PROFILES))}, see services/physics/profiles.py); "
        "the next options override one value of it",
    )


#: The options that override one value of the profile (unset: the profile's), and ``--connections``.
PROFILE_OPTIONS: tuple[OptionSpec, ...] = (
    OptionSpec("--rtf", type=non_negative_float, help="real-time factor: 1 real time, 0 as fast as possible"),
    OptionSpec("--physics-hz", type=positive_float, help="physics steps per sim second"),
    OptionSpec("--control-period-s", type=positive_float, help="sim seconds per clock step (control period)"),
    OptionSpec("--laser-beams", type=positive_int, help="beams per laser scan"),
    OptionSpec(
        "--command-latency-steps",
        type=int,
        choices=(0, 1),
        help="control periods between a robot's sensing and its command taking effect, in lock-step "
        "(1: physics steps while the robots think)",
    ),
    OptionSpec(
        "--total-station-mm",
        type=non_negative_float_up_to(MAX_TOTAL_STATION_MM, "mm"),
        metavar="STD_MM",
        help="a robotic total station on site: every ground robot gets a fix of its position each control "
        "period with this standard deviation (mm), fused by its localisation; 0: none, the robots localise "
        "by laser and odometry alone (default: the profile's, 3 mm in rehearsal, none in fine)",
    ),
    OptionSpec(
        "--lock-step",
        kind="boolean",
        help="advance a period only when every alive robot has answered the clock step (reproducible)",
    ),
    OptionSpec(
        "--connections",
        kind="boolean",
        default=True,
        help="a component set down at its target beside a component already built is connected to it "
        "(bolted, welded, fixed) while its robot holds it, and stands; --no-connections: every component "
        "must stand by itself (default: connections are made)",
    ),
)


def add_profile_arguments(parser: argparse.ArgumentParser, default: str) -> None:
    """``--profile`` and the options that override one of its values, for ``bimbot physics``."""
    for option in (profile_option(default), *PROFILE_OPTIONS):
        option.declare(parser)
