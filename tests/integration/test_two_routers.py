"""A site across two hosts, on Zenoh's router-to-router link: ``bimbot run --routers 2`` with each router
killed mid-build.

Two routers on loopback, the second connected to the first; physics, the planner and agent shard 1/2 are
clients of the first, the robot and shard 2/2 clients of the second, so every message between the two
halves crosses the routers' link (a client talks to its router only). While a generated 3×1 frame builds
(8 components; shard 2/2 owns Footing A3, built between the two kills, and Beam A2-A3, built last), the
test SIGKILLs the second router (the robot's and half the agents' only way to the site), then, once
``bimbot run`` has restarted it and more components are built, the first. The run ends by itself with
every component constructed, exit 0, both deaths restarted in its report, each component built once (in
both shards' journals), and no lock-step wait ran out its bound (a router's restart cost its own start-up
and the reconnections).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from collections import Counter
from pathlib import Path

import pytest
from fleets import ground_fleet_file
from frames import convert_small_frame
from lock_step_logs import waits_that_ran_out
from processes import run_services

from bimbot.polling import wait_until
from bimbot.services.component_agents.journal import journal_path, replay
from bimbot.shared.messages import ComponentState
from bimbot.shared.run_folder import RunFolder

pytestmark = pytest.mark.integration

RUN_TIMEOUT_S = 600
KILLS = ("bus-2", "bus")  # the second router first: the robot and shard 2/2 lose the site
# constructed components before the first kill, and between kills: the last (after 5 of 8) leaves three
FIRST_KILL_AT, KILL_EVERY = 2, 3


def _routers(pid: int) -> dict[str, tuple[int, list[str]]]:
    """``bus`` / ``bus-2`` → (pid, argv) of the routers started by the run ``pid`` (tests/processes.py):
    the second is the one that connects to another router."""
    found: dict[str, tuple[int, list[str]]] = {}
    for child, argv in run_services(pid).items():
        if argv[argv.index("bimbot.cli") + 1] == "bus":
            found["bus-2" if "--connect" in argv else "bus"] = (child, argv)
    return found


def _constructions(run: RunFolder, shards: tuple[int, ...] = (1, 2)) -> Counter[str]:
    """How often each component went to ``constructed``, over these shards' journals (default both)."""
    counts: Counter[str] = Counter()
    for shard in shards:
        path = journal_path(run.state_dir, shard, 2)
        if path.exists():
            counts.update(
                guid
                for guid, records in replay(path).records.items()
                for record in records
                if record.change.state == ComponentState.CONSTRUCTED and record.change.previous is not None
            )
    return counts


def test_two_routers_each_killed_mid_build_the_site_still_builds(tmp_path: Path) -> None:
    build = convert_small_frame(tmp_path / "frame", (3, 1))
    run = RunFolder(tmp_path / "run")
    command = [sys.executable, "-m", "bimbot.cli", "run", str(build), "-q", "--run-dir", str(run.root)]
    command += ["--fleet", str(ground_fleet_file(tmp_path))]  # the one robot: no idle crane, pump or layer
    command += ["--routers", "2", "--timeout-s", str(RUN_TIMEOUT_S - 60)]
    with (tmp_path / "run.stdout").open("w") as out, (tmp_path / "run.stderr").open("w") as err:
        process = subprocess.Popen(command, stdout=out, stderr=err)
        killed: dict[str, int] = {}
        try:
            for number, victim in enumerate(KILLS):
                due = FIRST_KILL_AT + number * KILL_EVERY
                assert wait_until(
                    lambda due=due: sum(_constructions(run).values()) >= due or process.poll() is not None,
                    timeout_s=RUN_TIMEOUT_S / 2,
                ), f"fewer than {due} constructed before killing {victim}"
                assert process.poll() is None, f"the run ended before {victim} was killed"
                for earlier, pid in killed.items():  # the router killed before runs again
                    assert wait_until(
                        lambda e=earlier, p=pid: _routers(process.pid).get(e, (p, []))[0] != p, timeout_s=60.0
                    ), f"{earlier} was not restarted"
                pid, argv = _routers(process.pid)[victim]
                if victim == "bus-2":  # it links to the first router
                    first = _routers(process.pid)["bus"][1]
                    assert argv[argv.index("--connect") + 1] == first[first.index("--listen") + 1]
                os.kill(pid, signal.SIGKILL)
                killed[victim] = pid
            process.wait(timeout=RUN_TIMEOUT_S)
        finally:
            if process.poll() is None:
                process.kill()
                process.wait()
    stdout = (tmp_path / "run.stdout").read_text()
    detail = f"{stdout}\n{(tmp_path / 'run.stderr').read_text()[-3000:]}"
    report = json.loads((run.report_dir / "report.json").read_text())
    total = len(report["components"])
    assert process.returncode == 0, detail
    assert f"constructed {total}/{total} components" in stdout, detail
    assert report["settings"]["routers"] == 2, detail
    deaths = {record["service"]: record for record in report["restarts"]}
    assert set(deaths) == set(KILLS), detail
    assert all(record["restarted_wall_s"] is not None for record in deaths.values()), detail
    constructions = _constructions(run)
    assert len(constructions) == total and set(constructions.values()) == {1}, constructions
    assert all(_constructions(run, (shard,)) for shard in (1, 2)), "both shards' agents built"
    assert waits_that_ran_out(run.logs_dir) == []
