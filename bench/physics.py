"""Benchmark of the physics: physics steps per second and the cost of one control period.

Run: ``.venv/bin/python bench/physics.py [--build OUT/]``: the bundled light steel frame (converted into
a temporary folder first) and, with ``--build``, that build too and its control period over the bundled
frame's, same run (the issue's "782 vs 28 components" with a 16×16 frame). For 1 and 3 Huskies with
every component of the build:

1. raw physics: ``stepSimulation`` calls per wall second (1/240 s steps) while the robots drive;
2. one control period (0.1 s = 24 steps) as ``Simulation.advance`` runs it — steps, the carried load
   following its robot after every step, odometry, one 360-beam laser scan per robot, all messages built —
   plus physics' restart record (written every period before publishing, ``snapshot.py``) and encoding
   and publishing them on an isolated Zenoh session (no router, no subscribers): median and p95 in ms, the
   real-time factor that cost allows, and the record's share of the period;
3. the laser alone: one scan, by the compiled caster (the default) and by Bullet's ray test, same run.

A full build needs thousands of control periods (one per 0.1 s of sim time), so the period cost sets how
fast a build can run. Times depend on the machine (and on what else runs on it); the bench prints its
core count and load.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path

from bimbot.services.physics.client import p
from bimbot.services.physics.ray_scene import RayScene
from bimbot.services.physics.simulation import SimConfig, Simulation
from bimbot.services.physics.snapshot import SnapshotRecorder
from bimbot.shared.bus import BusOptions, encode, open_session
from bimbot.shared.manifest import read_manifest
from bimbot.shared.messages import AttachRequest, CmdVelMsg

PERIOD_RATIO_TARGET = 1.5  # issue 12: a large site's control period at most 1.5× the bundled frame's


def bundled_build(out: Path) -> Path:
    from bimbot.demo import bundled_model_path
    from bimbot.services.converter.convert import convert_model
    from bimbot.shared.ifc_input import open_model

    source = bundled_model_path()
    convert_model(open_model(source), source, out)
    return out


def drive_all(sim: Simulation) -> None:
    for index, robot_id in enumerate(sim.robot_ids):
        w = 0.4 if index % 2 == 0 else -0.4
        sim.command(CmdVelMsg(robot_id=robot_id, v_mps=0.6, w_radps=w, sim_time_s=sim.sim_time_s))


def percentile(values: list[float], fraction: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(fraction * len(ordered)))]


def bench(build: Path, robots: int, steps: int, periods: int) -> float:
    """Print the figures of ``robots`` Huskies in ``build``; return the median control period (s)."""
    manifest = read_manifest(build)
    label = f"{robots} Husk{'y' if robots == 1 else 'ies'} + {len(manifest.components)} components"
    with Simulation(manifest, build, SimConfig(robots=robots)) as sim:
        slot = min(sim.layout.slots.values(), key=lambda s: (s.footprint.min_xy[0], s.footprint.min_xy[1]))
        middle_y = (slot.footprint.min_xy[1] + slot.footprint.max_xy[1]) / 2.0
        sim.teleport_robot("r1", (slot.footprint.min_xy[0] - 0.8, middle_y, 3.14159))
        carrying = sim.attach(AttachRequest(robot_id="r1", guid=slot.guid)).ok
        drive_all(sim)
        for _ in range(5):
            sim.advance()
        start = time.perf_counter()
        for _ in range(steps):
            p.stepSimulation(physicsClientId=sim.client_id)
        steps_per_s = steps / (time.perf_counter() - start)
        print(
            f"{label}: {steps_per_s:,.0f} physics steps/s ({steps_per_s * sim.config.step_s:.1f}× real time)"
        )

        period_s = sim.config.control_period_s
        advance, record, publish = [], [], []
        with (
            open_session(BusOptions(mode="peer", connect=(), listen=())) as session,
            tempfile.TemporaryDirectory(prefix="bimbot-physics-record-") as state_dir,
        ):
            recorder = SnapshotRecorder(Path(state_dir), sim.epoch)
            recorder.record(item.message for item in sim.start_messages())
            for _ in range(periods):
                t0 = time.perf_counter()
                result = sim.advance()
                t1 = time.perf_counter()
                recorder.record(item.message for item in result.messages)  # as app.py: record, then publish
                recorder.write()
                t2 = time.perf_counter()
                for item in result.messages:
                    session.put(item.key_expr, encode(item.message))
                t3 = time.perf_counter()
                advance.append(t1 - t0)
                record.append(t2 - t1)
                publish.append(t3 - t2)
        total = [a + r + b for a, r, b in zip(advance, record, publish, strict=True)]
        median = statistics.median(total)
        print(
            f"{label}: control period ({sim.config.substeps} steps, {robots} scan(s), "
            f"{len(result.messages)} messages{', r1 carrying' if carrying else ''}): "
            f"median {median * 1e3:.2f} ms (advance {statistics.median(advance) * 1e3:.2f} + record "
            f"{statistics.median(record) * 1e3:.2f} + publish {statistics.median(publish) * 1e3:.2f}), "
            f"p95 {percentile(total, 0.95) * 1e3:.2f} ms → up to {period_s / median:.0f}× real time; "
            f"the restart record is {statistics.median(record) / median:.1%} of the period"
        )
        robot = sim.robots["r1"]
        mount = sim._laser.mount(robot.frame(sim.client_id), robot.base_height_m)
        starts = sim._laser.beam_starts(robot.half_extents_xy_m)
        scene = sim._ray_scene or RayScene(sim.client_id)
        scene.refresh()
        t0 = time.perf_counter()
        scene.refresh()  # as each period: the robots' links, the carried load, what Bullet moves
        refresh_s = time.perf_counter() - t0
        scans: dict[str, list[float]] = {"bullet": [], "compiled": []}
        for _ in range(50):  # alternated, so that load weighs on both alike
            for kind, caster in (("bullet", None), ("compiled", scene)):
                t0 = time.perf_counter()
                sim._laser.scan(sim.client_id, mount, robot.group, starts, caster)
                scans[kind].append(time.perf_counter() - t0)
        bullet, compiled = (statistics.median(scans[kind]) for kind in ("bullet", "compiled"))
        print(
            f"{label}: one {sim.config.laser.beams}-beam scan: median {compiled * 1e3:.3f} ms compiled "
            f"(posing its shapes once a period {refresh_s * 1e3:.2f} ms), {bullet * 1e3:.3f} ms by "
            f"Bullet's ray test: ratio {compiled / bullet:.2f}"
        )
        return median


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--build", type=Path, default=None, help="converted build (default: the bundled frame)"
    )
    parser.add_argument("--steps", type=int, default=4800, help="physics steps timed (default 4800 = 20 s)")
    parser.add_argument("--periods", type=int, default=300, help="control periods timed (default 300 = 30 s)")
    args = parser.parse_args()
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"physics bench: {os.cpu_count()} cores, load average {load:.1f}, pybullet DIRECT, 1/240 s steps")
    with tempfile.TemporaryDirectory(prefix="bimbot-physics-bench-") as tmp:
        bundled = bundled_build(Path(tmp))
        builds = [bundled] if args.build is None else [bundled, args.build]
        periods = {
            (build, robots): bench(build, robots, args.steps, args.periods)
            for build in builds
            for robots in (1, 3)
        }
        if args.build is not None:  # the measure: a large site's period over the bundled frame's
            large, small = (len(read_manifest(build).components) for build in (args.build, bundled))
            for robots in (1, 3):
                ratio = periods[(args.build, robots)] / periods[(bundled, robots)]
                huskies = f"{robots} Husk{'y' if robots == 1 else 'ies'}"
                print(
                    f"control period, {large} vs {small} components, {huskies}: {ratio:.2f}× "
                    f"(target ≤ {PERIOD_RATIO_TARGET:.1f}×)"
                )


if __name__ == "__main__":
    main()
