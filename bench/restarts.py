"""Benchmark of what restarts cost a run: a generated 2×2 frame (12 components, one carrier) built by
``bimbot run`` twice, once undisturbed (the reference, in the same run of this script) and once with every
service SIGKILLed in turn — physics, the robot, the agents, the planner, the bus router — after 1, 3, 5, 7
and 9 components are constructed, as ``tests/integration/test_chaos.py`` does.

Run: ``.venv/bin/python bench/restarts.py [--rounds 2]``. Prints, per round, each run's wall time and sim
time, the disturbed run's wall over the reference's (target ≤ 1.5: five restarts cost their start-ups,
not a lock-step wait's 60 s bound each), and the lock-step waits that ran out their bound in its logs
(target 0).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bimbot.data.light_steel_frame import build_light_steel_frame  # noqa: E402
from bimbot.services.component_agents.journal import journal_path, replay  # noqa: E402
from bimbot.services.converter.convert import convert_model  # noqa: E402
from bimbot.shared.fleet import DEFAULT_FLEET_FILE  # noqa: E402
from bimbot.shared.messages import ComponentState  # noqa: E402
from bimbot.shared.run_folder import RunFolder  # noqa: E402

KILLS = ("physics", "robot", "agents", "planner", "bus")
FIRST_KILL_AT, KILL_EVERY = 1, 2
RATIO_TARGET = 1.5
RUN_TIMEOUT_S = 900
RAN_OUT = re.compile(r"lock-step: (no command for step \d+|step \d+ (taken|ticked|goes on) without)")


def prepare(folder: Path) -> tuple[Path, Path]:
    """The converted 2×2 frame and a fleet file with one carrier."""
    source = folder / "frame.ifc"
    model = build_light_steel_frame(2, 2)
    model.write(str(source))
    convert_model(model, source, folder / "build")
    types = DEFAULT_FLEET_FILE.read_text(encoding="utf-8").split("[[robots]]")[0]
    fleet = folder / "one_carrier.toml"
    fleet.write_text(f'{types}[[robots]]\ntype = "carrier"\ncount = 1\n', encoding="utf-8")
    return folder / "build", fleet


def constructed(run: RunFolder) -> int:
    path = journal_path(run.state_dir, 1, 1)
    if not path.exists():
        return 0
    return sum(
        record.change.state == ComponentState.CONSTRUCTED and record.change.previous is not None
        for records in replay(path).records.values()
        for record in records
    )


def services(pid: int) -> dict[str, int]:
    """``bimbot <command>`` → pid of the services ``pid`` started (its children or its fork server's)."""
    parents, argvs = {}, {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                parents[int(entry.name)] = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
                argvs[int(entry.name)] = (entry / "cmdline").read_bytes().replace(b"\0", b" ").split()
            except OSError:
                continue
    found = {}
    for child, argv in argvs.items():
        if (parents[child] == pid or parents.get(parents[child]) == pid) and b"bimbot.cli" in argv:
            found[argv[argv.index(b"bimbot.cli") + 1].decode()] = child
    return found


def build(template: Path, fleet: Path, folder: Path, kills: bool) -> tuple[float, float, int]:
    """One run: (wall s, sim s, lock-step waits that ran out)."""
    run = RunFolder(folder / ("disturbed" if kills else "reference"))
    command = [sys.executable, "-m", "bimbot.cli", "run", str(template), "-q", "--run-dir", str(run.root)]
    command += ["--fleet", str(fleet), "--timeout-s", str(RUN_TIMEOUT_S)]
    started = time.monotonic()
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        for number, victim in enumerate(KILLS if kills else ()):
            while constructed(run) < FIRST_KILL_AT + number * KILL_EVERY and process.poll() is None:
                time.sleep(0.05)
            pid = services(process.pid).get(victim)
            while pid is None and process.poll() is None:  # the one killed before is being restarted
                time.sleep(0.05)
                pid = services(process.pid).get(victim)
            if pid is not None:
                os.kill(pid, signal.SIGKILL)
            time.sleep(1.5)  # the victim's restart begins before the next one is looked for
        process.wait(timeout=RUN_TIMEOUT_S)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    wall_s = time.monotonic() - started
    sim_s = float(json.loads((run.report_dir / "report.json").read_text())["sim_time_s"])
    ran_out = sum(
        bool(RAN_OUT.search(line))
        for log in run.logs_dir.glob("*.log")
        for line in log.read_text(errors="replace").splitlines()
    )
    return wall_s, sim_s, ran_out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=1)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="bench-restarts-") as tmp:
        template, fleet = prepare(Path(tmp))
        for number in range(1, args.rounds + 1):
            folder = Path(tmp) / f"round{number}"
            plain_wall, plain_sim, _ = build(template, fleet, folder, kills=False)
            wall, sim, ran_out = build(template, fleet, folder, kills=True)
            ratio = wall / plain_wall
            print(f"round {number}: undisturbed {plain_wall:.1f} s wall, {plain_sim:.0f} s sim")
            print(f"  five services killed once: {wall:.1f} s wall, {sim:.0f} s sim")
            print(f"  wall over the undisturbed run's {ratio:.2f} (target ≤ {RATIO_TARGET:.1f})")
            print(f"  lock-step waits that ran out their bound: {ran_out} (target 0)")


if __name__ == "__main__":
    main()
