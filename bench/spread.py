"""The spread of a build's outcome over seeds, and whether one seed gives one outcome.

Run:

* ``.venv/bin/python bench/spread.py BUILD [--seeds 0 1 2 3 4] [--repeat 2] [-- RUN OPTIONS…]`` runs
  ``bimbot run BUILD --seed S RUN OPTIONS…`` for each seed (``--repeat`` times each), and prints the median
  and range of the makespan and of the constructed count over the seeds, each component whose outcome
  (state, robots, attempts) is not the same for every seed, and for each seed run more than once the
  differences between its runs (none: the seed reproduces its outcome; the reference figure);
* ``.venv/bin/python bench/spread.py --diff REPORT_A REPORT_B`` prints where two runs' ``report.json``
  differ (every component's state, method, robots and attempts, the order of construction, each robot's
  tasks, the makespan within 1 %); exit 1 when they differ.

Example: ``bench/spread.py out/house --seeds 1 2 3 4 5 -- --derive``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

from bimbot.run.outcome import RunOutcome, differences, outcome, spread


def _load(report: Path) -> RunOutcome:
    return outcome(json.loads(report.read_text()))


def _diff(a: Path, b: Path) -> int:
    lines = differences(_load(a), _load(b))
    print(f"{a} vs {b}: " + ("the same outcome" if not lines else f"{len(lines)} difference(s)"))
    for line in lines:
        print(f"  {line}")
    return 1 if lines else 0


def _run(build: Path, seed: int, index: int, options: list[str], runs_dir: Path) -> RunOutcome | None:
    run_dir = runs_dir / f"seed{seed}-{index}"
    command = [sys.executable, "-m", "bimbot.cli", "run", str(build), "--seed", str(seed), "-q"]
    command += ["--run-dir", str(run_dir), *options]
    started = time.monotonic()
    done = subprocess.run(command, check=False, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    report = run_dir / "report" / "report.json"
    if not report.is_file():
        print(f"seed {seed} run {index}: no report (exit {done.returncode}): {done.stderr.strip()[-300:]}")
        return None
    result = _load(report)
    print(
        f"seed {seed} run {index}: {result.constructed}/{len(result.components)} constructed, makespan "
        f"{result.makespan_s if result.makespan_s is not None else float('nan'):.1f} s "
        f"({time.monotonic() - started:.0f} s wall, load {os.getloadavg()[0]:.1f}) → {report}",
        flush=True,
    )
    return result


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("build", type=Path, nargs="?")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    parser.add_argument("--repeat", type=int, default=1, help="runs of each seed (≥ 2: reproducibility)")
    parser.add_argument("--runs-dir", type=Path, default=None, help="where the runs go (default BUILD/runs/)")
    parser.add_argument("--diff", type=Path, nargs=2, metavar="REPORT", help="compare two report.json")
    args, options = parser.parse_known_args()
    options = [item for item in options if item != "--"]
    if args.diff:
        return _diff(*args.diff)
    if args.build is None:
        parser.error("a build folder, or --diff REPORT_A REPORT_B")
    runs_dir = args.runs_dir or args.build / "runs"
    results: dict[int, list[RunOutcome]] = {}
    for seed in args.seeds:
        runs = [_run(args.build, seed, index, options, runs_dir) for index in range(args.repeat)]
        results[seed] = [run for run in runs if run is not None]
    firsts = [runs[0] for runs in results.values() if runs]
    figure = spread(firsts)
    total = max((len(item.components) for item in firsts), default=0)
    if figure.makespan_range_s is not None and figure.makespan_median_s is not None:
        low, high = figure.makespan_range_s
        print(
            f"makespan over {figure.runs} seed(s): median {figure.makespan_median_s:.1f} s, range "
            f"{low:.1f}–{high:.1f} s ({(high - low) / figure.makespan_median_s:.1%} of the median)"
        )
    low_count, high_count = figure.constructed_range
    print(f"constructed: median {figure.constructed_median:g} of {total}, range {low_count}–{high_count}")
    for guid, seen in figure.varying.items():
        print(f"  varies with the seed: {guid}: {', '.join(seen)}")
    same = True
    for seed, runs in results.items():
        for index, other in enumerate(runs[1:], start=1):
            lines = differences(runs[0], other)
            same = same and not lines
            print(f"seed {seed}, run {index} against run 0: {len(lines)} difference(s)")
            for line in lines:
                print(f"  {line}")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
