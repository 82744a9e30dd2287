"""Fleet study ("what a fleet buys"): makespan of a whole build against the size of a mixed robot fleet.

Run: ``.venv/bin/python bench/fleet.py [--models frame,hub] [--sizes 1,2,4,8] [--timeout-s 3600]
[--plot bench/out/fleet.png] [--json bench/out/fleet.json] [--work DIR] [--keep] [--build-sequence]``.

For each model it makes its own build (``bimbot sample light-steel-frame`` + ``bimbot convert``):

- ``frame``: the bundled 28-component light steel frame;
- ``hub``: the Revit structural hub of the public samples folder beside the checkout
  (``../shared/samples/ifc/revit2021_structural_hub.ifc``, read in place, skipped when it is not there),
  whole model: nearly all of it rests, by the support graph, on a 49 t foundation slab that no fleet lifts,
  so every fleet builds a few footings and the rest ends ``blocked_by`` that slab;
- ``hub-steel`` (on request): the hub's steel frame alone (``--only IfcBeam,IfcColumn``, 85 members), the
  part of that building a fleet can build.

For each fleet size it writes a fleet TOML with the default fleet's robot types
(``shared/robots/default_fleet.toml``) and this mix:

- 1: 1 carrier (the ground robot that lifts footings and slabs);
- 2: 1 carrier + 1 tower crane (the crane lifts what is high; the carrier hands it loads the hook cannot
  reach in the yard);
- 4: 1 husky + 2 carrier + 1 tower crane (the Husky takes light members: columns, and
  beams within its placement height);
- 8: 3 husky + 3 carrier + 2 tower crane (the site plan stands the second crane on another side of the
  building, with its own staging area).

Other sizes: 3/8 husky, 1/4 crane, the rest carriers. The types' limits (payload, placement height, load
chart) are read from the default fleet file when the study runs, so the figures follow that file.

Each fleet runs a real ``bimbot run BUILD --fleet F --derive -q --run-dir …`` (every service a process on
a loopback bus, lock-step physics as fast as the robots follow). ``--derive``: the planner orders the build
by its support graph, so robots can work side by side; the bundled frame's IFC work schedule is one chain
(the paper's single-robot erection order) in which a fleet gains nothing but capability
(``--build-sequence`` runs with it). Each run gives one row: model, fleet, constructed/buildable/total
(buildable: the components ``bimbot fleet check --json`` finds a route for with that fleet; it does not
follow supports, so a component it counts that rests on one no fleet lifts still ends ``blocked_by``),
makespan in sim seconds (the report's release-to-last-constructed makespan when the planner was done,
else the sim time at the end of the run, marked ``*``), wall seconds, sim/wall ratio, utilisation per robot
type (busy / (robots of the type × makespan)), hand-off tasks, how the run ended, the reason codes of what
was not built and the robots that got no task. Then a plot of makespan against fleet size, one line per
model through the fleets that built the most of it (a cross: a fleet that built less; hollow: the run
ended early), and the rows as JSON. A run that ends early (its own ``--timeout-s``, a stall) still gives
its row: a run always writes its report.

Wall time on 2 shared cores: the frame 1-1.5 min per fleet, the whole hub under a minute (it stops after
the footings), the hub's steel frame 1-12 min per fleet (the crane is its bottleneck); the default study
about 10 min, with ``hub-steel`` about 40. Run folders (journal, ``logs/*.log``, report) are deleted after
their row unless ``--keep``.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
BIMBOT = Path(sys.executable).with_name("bimbot")
DEFAULT_FLEET = ROOT / "shared" / "robots" / "default_fleet.toml"
HUB_IFC = ROOT.parent / "shared" / "samples" / "ifc" / "revit2021_structural_hub.ifc"
MODELS = ("frame", "hub", "hub-steel")
DEFAULT_MODELS = ("frame", "hub")
HUB_STEEL = "IfcBeam,IfcColumn"  # hub-steel: the hub converted with --only these classes
TYPES = ("husky", "carrier", "tower_crane")
# fleet size → robots per type (in TYPES order); the mixes the module docstring explains
MIXES: dict[int, tuple[int, int, int]] = {1: (0, 1, 0), 2: (0, 1, 1), 4: (1, 2, 1), 8: (3, 3, 2)}
RUN_TIMEOUT_S = 3600.0
KILL_GRACE_S = 600.0  # beyond the run's own timeout, before the bench gives up on the process


def mix_of(size: int) -> dict[str, int]:
    """Robots per type for ``size`` robots: the table above, else 3/8 husky, 1/4 crane, the rest carriers."""
    if size in MIXES:
        counts = MIXES[size]
    else:
        cranes = round(size / 4) if size > 1 else 0
        huskies = round(size * 3 / 8)
        counts = (huskies, size - huskies - cranes, cranes)
    return {name: count for name, count in zip(TYPES, counts, strict=True) if count}


def fleet_label(mix: dict[str, int]) -> str:
    return ", ".join(f"{count} {name}" for name, count in mix.items())


def write_fleet(folder: Path, size: int) -> Path:
    """A fleet TOML with the default fleet's types (its text up to its robots) and this size's robots."""
    text = DEFAULT_FLEET.read_text(encoding="utf-8")
    head = text[: text.index("\n[[robots]]")] if "\n[[robots]]" in text else text
    entries = "".join(
        f'\n[[robots]]\ntype = "{name}"\ncount = {count}\n' for name, count in mix_of(size).items()
    )
    path = folder / f"fleet-{size}.toml"
    path.write_text(f"{head.rstrip()}\n{entries}", encoding="utf-8")
    return path


def bimbot(*args: str | Path, timeout_s: float | None = None) -> subprocess.CompletedProcess[str]:
    """One ``bimbot`` command, its output captured."""
    command = [str(BIMBOT), *map(str, args)]
    return subprocess.run(command, capture_output=True, text=True, timeout=timeout_s, check=False)


def make_build(model: str, work: Path) -> Path | None:
    """Convert ``model`` into ``work/builds/<model>``; None (with a line) when its IFC is not there."""
    build = work / "builds" / model
    if model == "frame":
        source = work / "builds" / "frame.ifc"
        source.parent.mkdir(parents=True, exist_ok=True)
        made = bimbot("sample", "light-steel-frame", "-o", source)
        if made.returncode != 0:
            raise SystemExit(f"bimbot sample failed: {made.stderr.strip()}")
    else:
        if not HUB_IFC.is_file():
            print(f"{model}: {HUB_IFC} is not there; skipped")
            return None
        source = HUB_IFC
    if build.exists():
        shutil.rmtree(build)
    start = time.perf_counter()
    only = ("--only", HUB_STEEL) if model == "hub-steel" else ()
    converted = bimbot("convert", source, "-o", build, "--no-progress", *only)
    if converted.returncode != 0:
        raise SystemExit(f"bimbot convert {source} failed: {converted.stderr.strip()[-2000:]}")
    print(f"{model}: converted {source.name} in {time.perf_counter() - start:.1f} s wall → {build}")
    return build


def buildable(build: Path, fleet: Path) -> int | None:
    """How many components ``fleet`` has a route for (``bimbot fleet check --json``: reason null)."""
    checked = bimbot("fleet", "check", build, "--fleet", fleet, "--json")
    if checked.returncode != 0:
        print(f"  fleet check failed: {checked.stderr.strip()[-500:]}")
        return None
    rows = [json.loads(line) for line in checked.stdout.splitlines() if line.strip().startswith("{")]
    return sum(1 for row in rows if row.get("reason") is None)


def run_fleet(
    model: str, build: Path, size: int, work: Path, timeout_s: float, *, derive: bool
) -> dict[str, Any]:
    """One ``bimbot run`` of ``build`` with the ``size``-robot fleet; its row from the run's report."""
    fleet = write_fleet(work, size)
    mix = mix_of(size)
    can = buildable(build, fleet)
    run_dir = work / "runs" / f"{model}-{size}"
    if run_dir.exists():
        shutil.rmtree(run_dir)
    command = ("run", build, "--fleet", fleet, "-q", "--run-dir", run_dir, "--timeout-s", f"{timeout_s:g}")
    command += ("--derive",) if derive else ()
    start = time.perf_counter()
    try:
        result = bimbot(*command, timeout_s=timeout_s + KILL_GRACE_S)
        exit_code: int | None = result.returncode
        output = result.stdout + result.stderr
    except subprocess.TimeoutExpired as exc:
        exit_code, output = None, f"bimbot run did not end within {timeout_s + KILL_GRACE_S:.0f} s: {exc}"
    wall_s = time.perf_counter() - start
    (work / "runs" / f"{model}-{size}.out").write_text(output, encoding="utf-8")
    row: dict[str, Any] = {
        "model": model,
        "size": size,
        "fleet": fleet_label(mix),
        "mix": mix,
        "buildable": can,
        "wall_s": wall_s,
        "exit_code": exit_code,
        "run_dir": str(run_dir),
    }
    report_path = run_dir / "report" / "report.json"
    if not report_path.is_file():
        row.update(error=f"no report ({report_path}); output: {output.strip()[-500:]}")
        return row
    return row | from_report(json.loads(report_path.read_text(encoding="utf-8")), can, wall_s)


def from_report(report: dict[str, Any], can: int | None, wall_s: float) -> dict[str, Any]:
    """The row's figures from a run report (see the module docstring for the makespan)."""
    totals = report.get("totals", {})
    constructed = int(totals.get("constructed", 0))
    sim_s = float(report.get("sim_time_s") or 0.0)
    ended = (report.get("ending") or {}).get("how")
    complete = ended == "done" and totals.get("makespan_s") is not None
    makespan = float(totals["makespan_s"]) if complete else sim_s
    utilisation: dict[str, float | None] = {}
    for name, entry in (totals.get("by_type") or {}).items():
        robots = len(entry.get("robots") or [])
        utilisation[name] = entry.get("busy_s", 0.0) / (robots * makespan) if robots and makespan else None
    robots = report.get("robots", {})
    idle = sorted(robot_id for robot_id, robot in robots.items() if not robot.get("tasks"))
    reasons = Counter(
        (component.get("reason") or {}).get("code") or "?"
        for component in report.get("components", [])
        if component.get("state") != "constructed"
    )
    return {
        "constructed": constructed,
        "total": int(totals.get("components", 0)),
        "complete": complete,
        "makespan_s": makespan,
        "report_makespan_s": totals.get("makespan_s"),
        "sim_s": sim_s,
        "ratio": sim_s / wall_s if wall_s > 0 else None,
        "utilisation": utilisation,
        "hand_offs": int(totals.get("hand_off_tasks") or 0),
        "retries": totals.get("retries"),
        "give_backs": totals.get("give_backs"),
        "idle_robots": [f"{robot_id} ({robots[robot_id].get('type')})" for robot_id in idle],
        "ended": ended,
        "ending": (report.get("ending") or {}).get("message"),
        "not_built": dict(reasons.most_common()),
    }


HEADER = (
    f"{'model':<9} {'fleet':<34} {'built/can/all':>13} {'makespan s':>11} {'wall s':>7} {'sim/wall':>8} "
    f"{'hand-offs':>9}  {'ended':<8} utilisation"
)


def table_row(row: dict[str, Any]) -> str:
    """One printed line (and a second with what was not built, when something was not)."""
    if "error" in row:
        return f"{row['model']:<9} {row['fleet']:<34} run failed: {row['error']}"
    can = "?" if row["buildable"] is None else row["buildable"]
    counts = f"{row['constructed']}/{can}/{row['total']}"
    makespan = f"{row['makespan_s']:.0f}{'' if row['complete'] else '*'}"
    ratio = "-" if row["ratio"] is None else f"×{row['ratio']:.1f}"
    use = ", ".join(
        f"{name} {'-' if value is None else f'{value:.2f}'}" for name, value in row["utilisation"].items()
    )
    line = (
        f"{row['model']:<9} {row['fleet']:<34} {counts:>13} {makespan:>11} {row['wall_s']:>7.0f} "
        f"{ratio:>8} {row['hand_offs']:>9}  {row['ended'] or '?':<8} {use}"
    )
    notes = []
    if row["not_built"]:
        notes.append("not built: " + ", ".join(f"{code} {count}" for code, count in row["not_built"].items()))
    if row["idle_robots"]:
        notes.append("no task: " + ", ".join(row["idle_robots"]))
    if row["ended"] != "done" and row["ending"]:
        notes.append(f"ending: {row['ending']}")
    return line + "".join(f"\n{'':<10}{note}" for note in notes)


def plot(rows: list[dict[str, Any]], path: Path) -> None:
    """Makespan against fleet size, one line per model through the runs that built the most of it (a
    fleet that builds less is a cross, not on the line); hollow markers: the run ended early."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(figsize=(7, 4.5))
    for model in dict.fromkeys(row["model"] for row in rows):
        points = sorted(
            (r for r in rows if r["model"] == model and "error" not in r), key=lambda r: r["size"]
        )
        if not points:
            continue
        most = max(r["constructed"] for r in points)
        full = [r for r in points if r["constructed"] == most]
        (line,) = axes.plot([r["size"] for r in full], [r["makespan_s"] for r in full], "-", label=model)
        for r in points:
            axes.plot(
                r["size"],
                r["makespan_s"],
                "o" if r["constructed"] == most else "x",
                color=line.get_color(),
                markerfacecolor=line.get_color() if r["complete"] else "white",
            )
            axes.annotate(
                f"{r['constructed']}/{r['total']}",
                (r["size"], r["makespan_s"]),
                textcoords="offset points",
                xytext=(4, 6),
                fontsize=8,
            )
    all_sizes = sorted({row["size"] for row in rows})
    axes.set_xscale("log", base=2)
    axes.set_xticks(all_sizes, [str(size) for size in all_sizes])
    axes.set_xlabel("robots in the fleet (mixed types)")
    axes.set_ylabel("makespan (sim s)")
    axes.set_title(
        "What a fleet buys: makespan against fleet size, labels constructed/total\n"
        "(×: built less than the model's best fleet; hollow: the run ended early)"
    )
    axes.title.set_fontsize(9)
    axes.margins(x=0.1, y=0.1)
    axes.grid(True, alpha=0.3)
    axes.legend()
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)


def speedups(rows: list[dict[str, Any]]) -> None:
    """Per model: each complete run's makespan over the smallest fleet's that built as many components
    (a 1-carrier fleet that builds only the low members is no baseline for one that builds them all)."""
    for model in dict.fromkeys(row["model"] for row in rows):
        done = [r for r in rows if r["model"] == model and r.get("complete")]
        most = max((r["constructed"] for r in done), default=0)
        done = sorted((r for r in done if r["constructed"] == most), key=lambda r: r["size"])
        if len(done) < 2:
            continue
        base = done[0]
        ratios = ", ".join(f"{r['size']}: {r['makespan_s'] / base['makespan_s']:.2f}" for r in done)
        print(f"{model}, {most} constructed: makespan relative to {base['size']} robot(s): {ratios}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--models", default=",".join(DEFAULT_MODELS), help="comma-separated: " + ", ".join(MODELS)
    )
    parser.add_argument("--sizes", default="1,2,4,8", help="comma-separated fleet sizes")
    parser.add_argument("--timeout-s", type=float, default=RUN_TIMEOUT_S, help="per run (bimbot run)")
    parser.add_argument("--plot", type=Path, default=ROOT / "bench" / "out" / "fleet.png")
    parser.add_argument("--json", type=Path, default=ROOT / "bench" / "out" / "fleet.json")
    parser.add_argument("--work", type=Path, help="work folder (default: a temporary one)")
    parser.add_argument(
        "--build-sequence", action="store_true", help="the build's own sequence.xml, not --derive"
    )
    parser.add_argument("--keep", action="store_true", help="keep the run folders (and the work folder)")
    args = parser.parse_args()
    models = [name.strip() for name in args.models.split(",") if name.strip()]
    unknown = sorted(set(models) - set(MODELS))
    if unknown:
        parser.error(f"unknown model(s) {unknown}; models: {', '.join(MODELS)}")
    sizes = [int(size) for size in args.sizes.split(",") if size.strip()]
    if any(size < 1 for size in sizes):
        parser.error("fleet sizes are at least 1")
    work = args.work or Path(tempfile.mkdtemp(prefix="bimbot-bench-fleet-"))
    work.mkdir(parents=True, exist_ok=True)
    (work / "runs").mkdir(exist_ok=True)
    print(f"work folder {work}; bimbot run --timeout-s {args.timeout_s:g} per run")
    rows: list[dict[str, Any]] = []
    try:
        for model in models:
            build = make_build(model, work)
            if build is None:
                continue
            for size in sizes:
                print(f"{model}, {size} robot(s): {fleet_label(mix_of(size))} …", flush=True)
                row = run_fleet(model, build, size, work, args.timeout_s, derive=not args.build_sequence)
                rows.append(row)
                print(HEADER)
                print(table_row(row), flush=True)
                if not args.keep:
                    shutil.rmtree(row["run_dir"], ignore_errors=True)
        print("\n" + HEADER)
        for row in rows:
            print(table_row(row))
        print("* makespan: sim time at the end (the run ended before the planner was done)")
        speedups(rows)
        if rows:
            plot(rows, args.plot)
            args.json.parent.mkdir(parents=True, exist_ok=True)
            args.json.write_text(json.dumps(rows, indent=1), encoding="utf-8")
            print(f"plot {args.plot}; rows {args.json}")
    finally:
        if args.keep:
            print(f"kept {work}")
        elif args.work is None:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
