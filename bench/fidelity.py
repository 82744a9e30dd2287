"""The plan fidelity against the physics fidelity, one run each, side by side.

Run: ``.venv/bin/python bench/fidelity.py [BUILD] [--seed N] [-- RUN OPTIONS…]``. Without BUILD the
bundled frame (``bimbot/data/light_steel_frame.ifc``, what ``bimbot demo`` builds) is converted into a
temporary folder first. It runs ``bimbot run BUILD --fidelity physics`` and then ``--fidelity plan`` (same
seed, fleet and options) and prints, for each, the wall time of the whole ``bimbot run`` process (and
from the site's clock start, its first progress line, to its summary: start-up left out), the makespan
and the constructed count, then the ratios (physics wall / plan wall: the speed-up, the
reference being the physics run of the same invocation; plan makespan / physics makespan), whether the
constructed sets are equal, and the reasons for what was not built (per component: its reason code).

Targets (issue 35): plan ≥ 20× faster in wall time, makespan within ±10 %, the same constructed set and
the same reasons. The machine's load average is printed with each run: the wall times depend on it.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

BUNDLED = Path(__file__).resolve().parents[1] / "bimbot" / "data" / "light_steel_frame.ifc"


def _convert_bundled(folder: Path) -> Path:
    build = folder / "world"
    command = [sys.executable, "-m", "bimbot.cli", "convert", str(BUNDLED), "-o", str(build), "--no-progress"]
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
    return build


def _run(build: Path, fidelity: str, run_dir: Path, options: list[str]) -> dict:
    command = [sys.executable, "-m", "bimbot.cli", "run", str(build), "--fidelity", fidelity]
    command += ["--run-dir", str(run_dir), *options]
    load = os.getloadavg()[0]
    started = time.monotonic()
    clock_s = summary_s = None  # when the site's clock started (the first progress line), the summary came
    with subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) as done:
        assert done.stdout is not None and done.stderr is not None
        for line in done.stdout:
            if clock_s is None and line.startswith("progress:"):
                clock_s = time.monotonic()
            if summary_s is None and line.startswith("constructed "):
                summary_s = time.monotonic()
        stderr = done.stderr.read()
    wall_s = time.monotonic() - started
    report_path = run_dir / "report" / "report.json"
    report = json.loads(report_path.read_text()) if report_path.is_file() else {}
    components = report.get("components") or []
    return {
        "fidelity": fidelity,
        "exit": done.returncode,
        "wall_s": wall_s,
        "site_wall_s": summary_s - clock_s if clock_s is not None and summary_s is not None else None,
        "load": load,
        "makespan_s": (report.get("totals") or {}).get("makespan_s"),
        "constructed": {c["guid"] for c in components if c.get("state") == "constructed"},
        "total": len(components),
        "reasons": {
            c["guid"]: (c.get("reason") or {}).get("code", c.get("state"))
            for c in components
            if c.get("state") != "constructed"
        },
        "said": (report.get("settings") or {}).get("fidelity"),
        "tail": stderr.strip()[-300:] if not report else "",
    }


def _line(result: dict) -> str:
    makespan = result["makespan_s"]
    shown = f"{makespan:,.1f} s" if isinstance(makespan, int | float) else "none"
    site = result["site_wall_s"]
    return (
        f"{result['fidelity']:>8}: wall {result['wall_s']:7.1f} s (load {result['load']:.1f}; "
        f"from the clock's start to the summary {site if site is not None else float('nan'):.1f} s), "
        f"makespan {shown}, "
        f"constructed {len(result['constructed'])}/{result['total']}, exit {result['exit']}, report says "
        f"fidelity {result['said']}{'; ' + result['tail'] if result['tail'] else ''}"
    )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "build", nargs="?", type=Path, default=None, help="a converted build (default: bundled)"
    )
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("run_options", nargs=argparse.REMAINDER, help="-- then more bimbot run options")
    args = parser.parse_args()
    extra = [option for option in args.run_options if option != "--"]
    with tempfile.TemporaryDirectory(prefix="bimbot-fidelity-") as temporary:
        folder = Path(temporary)
        build = args.build or _convert_bundled(folder)
        options = ["--seed", str(args.seed), *extra]
        physics = _run(build, "physics", folder / "physics", options)
        print(_line(physics), flush=True)
        plan = _run(build, "plan", folder / "plan", options)
        print(_line(plan), flush=True)
    print(f"wall time: physics / plan = {physics['wall_s'] / plan['wall_s']:.1f}× (target ≥ 20×)")
    if physics["site_wall_s"] and plan["site_wall_s"]:
        ratio = physics["site_wall_s"] / plan["site_wall_s"]
        print(f"  from the clock's start to the summary (start-up left out): {ratio:.1f}×")
    if physics["makespan_s"] and plan["makespan_s"]:
        ratio = plan["makespan_s"] / physics["makespan_s"]
        print(f"makespan: plan / physics = {ratio:.3f} ({100 * (ratio - 1):+.1f} %, target within ±10 %)")
    same = physics["constructed"] == plan["constructed"]
    print(
        f"constructed set: {'the same' if same else 'differs'} "
        f"(only physics: {len(physics['constructed'] - plan['constructed'])}, "
        f"only plan: {len(plan['constructed'] - physics['constructed'])})"
    )
    same_reasons = physics["reasons"] == plan["reasons"]
    print(f"reasons for what was not built: {'the same' if same_reasons else 'differ'}")
    for guid in sorted(set(physics["reasons"]) | set(plan["reasons"])):
        both = (physics["reasons"].get(guid, "built"), plan["reasons"].get(guid, "built"))
        print(f"  {guid}: physics {both[0]}, plan {both[1]}")
    return 0 if same and same_reasons else 1


if __name__ == "__main__":
    sys.exit(main())
