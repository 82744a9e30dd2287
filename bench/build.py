"""Benchmark of the whole construction run: the bundled 28-component frame built end to end at full speed.

Run: ``.venv/bin/python bench/build.py [--robots 1 3] [--observer-cost]``. For each robot count it converts
the bundled model, runs ``bimbot run`` (every service a process on a loopback bus, lock-step physics as fast
as the robots follow) and prints wall time with its ratio to the 60 s target, sim time, physics steps per
wall second (120 Hz physics with the robots and every component), the largest placement errors and the
retries. With more than one robot the planner derives the sequence from the support graph: the bundled
IFC work schedule is one chain (the paper's single-robot erection order) that lets only one task run at a
time. ``--observer-cost`` also builds with 1 robot and the observer recording, and prints the difference
and the recording's size per component. ``--samples`` also converts and builds the two Revit buildings of
the public samples folder beside the checkout (see tests/conftest.py): the structural hub and the sample
house, with the same robot counts, and prints for each constructed/total, sim and wall time, how the run
ended and the reasons of what was not built, counted by code (every run must end by itself: each
component constructed or given a reason). Most of
both rests on footings and slabs of several tonnes, beyond the default robot, so the hub's steel frame
alone (``--only IfcBeam,IfcColumn``: 85 members on a 94 m yard) is built too, which the robots can. Then the
navigation figures (A* 2000×2000, DWA step) from ``bench/navigation.py``.
"""

from __future__ import annotations

import argparse
import runpy
import shutil
import sys
import tempfile
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bimbot.demo import bundled_model_path  # noqa: E402
from bimbot.run import ObserverOptions, RunOptions, RunOutcome, run_build  # noqa: E402
from bimbot.services.converter.convert import ConvertOptions, convert_model  # noqa: E402
from bimbot.services.converter.ifc_input import open_model  # noqa: E402
from bimbot.services.physics.profiles import PROFILES, RUN_PROFILE  # noqa: E402

WALL_TARGET_S = 60.0
SAMPLES = ROOT.parent / "shared" / "samples" / "ifc"
# (file, classes to build or None for the converter's default, label)
REVIT_SAMPLES = (
    ("revit2021_structural_hub.ifc", None, "revit2021_structural_hub"),
    ("revit2021_sample_project.ifc", None, "revit2021_sample_project"),
    ("revit2021_structural_hub.ifc", ("IfcBeam", "IfcColumn"), "revit2021_structural_hub steel frame"),
)
SAMPLE_TIMEOUT_S = 3600.0


def convert_bundled(folder: Path) -> Path:
    source = bundled_model_path()
    build = folder / "build"
    convert_model(open_model(source), source, build)
    return build


def build_once(template: Path, folder: Path, options: RunOptions) -> RunOutcome:
    build = folder / f"run-{options.robots}-{'observed' if options.observer else 'plain'}"
    shutil.copytree(template, build)
    return run_build(build, options, announce=lambda _line: None)


def describe(label: str, outcome: RunOutcome) -> None:
    totals = outcome.report.get("totals", {})
    physics_hz = PROFILES[RUN_PROFILE].physics_hz
    steps = outcome.sim_time_s * physics_hz
    position = totals.get("max_position_error_mm")
    angle = totals.get("max_angle_error_deg")
    distance = ", ".join(
        f"{robot_id} {robot['distance_m']:.0f} m/{len(robot['tasks'])} tasks"
        for robot_id, robot in sorted(outcome.report.get("robots", {}).items())
    )
    print(f"{label}: {outcome.constructed}/{outcome.total} constructed, exit {outcome.exit_code}")
    print(
        f"  wall {outcome.wall_time_s:.1f} s (target ≤ {WALL_TARGET_S:.0f} s, ratio "
        f"{outcome.wall_time_s / WALL_TARGET_S:.2f}), sim {outcome.sim_time_s:.1f} s "
        f"(×{outcome.sim_time_s / outcome.wall_time_s:.1f} real time)"
    )
    print(
        f"  physics {steps:.0f} steps at {physics_hz:g} Hz = {steps / outcome.wall_time_s:.0f} steps/s "
        f"(wall, whole run incl. start-up, robots and {outcome.total} components)"
    )
    print(
        f"  placement error max {position if position is None else f'{position:.2f}'} mm, "
        f"{angle if angle is None else f'{angle:.3f}'}°; retries {totals.get('retries')}; "
        f"makespan {totals.get('makespan_s')} s; {distance}"
    )


def build_sample(name: str, only: tuple[str, ...] | None, label: str, folder: Path, robots: int) -> None:
    """Convert one Revit sample and build it; print how it ended and why what was not built was not."""
    source = SAMPLES / name
    build = folder / f"{label.replace(' ', '-')}-{robots}"
    convert_model(open_model(source), source, build, ConvertOptions(only=only) if only else None)
    options = RunOptions(robots=robots, timeout_s=SAMPLE_TIMEOUT_S)
    outcome = run_build(build, options, announce=lambda _line: None)
    reasons = Counter(
        (component.get("reason") or {}).get("code", "?")
        for component in outcome.report.get("components", [])
        if component["state"] != "constructed"
    )
    ending = outcome.ending.how if outcome.ending is not None else "?"
    print(
        f"{label}, {robots} robot(s): {outcome.constructed}/{outcome.total} constructed, "
        f"ended {ending}, exit {outcome.exit_code}; sim {outcome.sim_time_s:.0f} s, "
        f"wall {outcome.wall_time_s:.1f} s "
        f"(×{outcome.sim_time_s / max(outcome.wall_time_s, 1e-9):.1f} real time)"
    )
    if reasons:
        print("  not built: " + ", ".join(f"{code} {count}" for code, count in reasons.most_common()))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", type=int, nargs="+", default=[1, 3])
    parser.add_argument("--observer-cost", action="store_true", help="also build with the observer")
    parser.add_argument("--no-navigation", action="store_true", help="skip the A*/DWA figures")
    parser.add_argument("--samples", action="store_true", help="also build the two Revit sample buildings")
    parser.add_argument("--only-samples", action="store_true", help="build only the Revit sample buildings")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="bimbot-bench-build-") as tmp:
        folder = Path(tmp)
        if args.samples or args.only_samples:
            for name, only, label in REVIT_SAMPLES:
                for robots in args.robots:
                    build_sample(name, only, label, folder, robots)
        if args.only_samples:
            return
        template = convert_bundled(folder)
        plain: dict[int, RunOutcome] = {}
        for robots in args.robots:
            source = ("--derive",) if robots > 1 else ()
            options = RunOptions(robots=robots, planner_source=source)
            plain[robots] = build_once(template, folder, options)
            describe(
                f"bundled frame, {robots} robot(s){' (derived sequence)' if source else ''}", plain[robots]
            )
        if args.observer_cost:
            observed = build_once(template, folder, RunOptions(robots=1, observer=ObserverOptions()))
            describe("bundled frame, 1 robot, with the observer recording", observed)
            base = plain.get(1) or build_once(template, folder, RunOptions(robots=1))
            rrd = observed.rrd_path
            size = rrd.stat().st_size if rrd and rrd.exists() else 0
            print(
                f"observer cost: wall {observed.wall_time_s:.1f} s with vs {base.wall_time_s:.1f} s without "
                f"(ratio {observed.wall_time_s / base.wall_time_s:.2f}); recording {size / 1024:.0f} KiB = "
                f"{size / 1024 / observed.total:.1f} KiB per component"
            )
    if not args.no_navigation:
        sys.argv = [sys.argv[0], "--pf-repeats", "10"]
        runpy.run_path(str(ROOT / "bench" / "navigation.py"), run_name="__main__")


if __name__ == "__main__":
    main()
