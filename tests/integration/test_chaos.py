"""Any service may die mid-build: ``bimbot run`` restarts it and the build completes, nothing done twice.

A generated 3×1 frame (8 components, one robot) is built by ``bimbot run`` as a process; while it builds,
the test SIGKILLs each service once, in turn — physics, the robot, the agents, the planner and the bus
router — each when one more component is constructed and the one killed before is running again (three
components are left to build with every service restarted).
Then: the run ends by itself with every component constructed and exit 0; its report lists the five
deaths, each restarted; the agents' journal holds exactly one ``constructed`` transition per component
(nothing was built twice); the as-built audit finds every component at its BIM target in physics
(the restarted physics put the built ones back where they were placed); and no lock-step wait ran out its
bound (each restart cost its own start-up, not a minute of every participant waiting for it).
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
from wall_clock import bound_s

from bimbot.polling import wait_until
from bimbot.services.component_agents.journal import journal_path, replay
from bimbot.shared.messages import ComponentState
from bimbot.shared.run_folder import RunFolder

pytestmark = pytest.mark.integration

RUN_TIMEOUT_S = 600
KILLS = ("physics", "robot", "agents", "planner", "bus")  # the `bimbot <command>` of each victim
# constructed components before the first kill, and between kills: the last kill (after 5 of 8) leaves a
# column and two beams, minutes of sim time (a restart takes seconds; this process reads the journal every
# 50 ms)
FIRST_KILL_AT, KILL_EVERY = 1, 1


def _children(pid: int) -> dict[str, int]:
    """``bimbot <command>`` → pid of the services started by the run ``pid`` (tests/processes.py)."""
    return {argv[argv.index("bimbot.cli") + 1]: child for child, argv in run_services(pid).items()}


def _constructions(run: RunFolder) -> Counter[str]:
    """How often each component went to ``constructed`` in the agents' journal (announcements of a
    restarted agent, which have no previous state, are not transitions)."""
    path = journal_path(run.state_dir, 1, 1)
    if not path.exists():
        return Counter()
    return Counter(
        guid
        for guid, records in replay(path).records.items()
        for record in records
        if record.change.state == ComponentState.CONSTRUCTED and record.change.previous is not None
    )


@pytest.fixture(scope="module")
def frame_3x1(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """8 components: the last kill (after 5) leaves three to build with every service restarted."""
    return convert_small_frame(tmp_path_factory.mktemp("chaos_frame"), (3, 1))


def test_every_service_killed_once_mid_build_the_build_completes_once(
    frame_3x1: Path, tmp_path: Path
) -> None:
    build = frame_3x1
    run = RunFolder(tmp_path / "run")
    command = [sys.executable, "-m", "bimbot.cli", "run", str(build), "-q", "--run-dir", str(run.root)]
    command += ["--fleet", str(ground_fleet_file(tmp_path))]  # one process per kind: the one robot dies too
    run_timeout_s = bound_s(RUN_TIMEOUT_S)
    command += ["--timeout-s", f"{run_timeout_s - 60:.0f}"]
    with (tmp_path / "run.stdout").open("w") as out, (tmp_path / "run.stderr").open("w") as err:
        process = subprocess.Popen(command, stdout=out, stderr=err)
        killed: dict[str, int] = {}
        try:
            for number, victim in enumerate(KILLS):
                due = FIRST_KILL_AT + number * KILL_EVERY
                assert wait_until(
                    lambda due=due: sum(_constructions(run).values()) >= due or process.poll() is not None,
                    timeout_s=run_timeout_s / 2,
                ), f"fewer than {due} constructed before killing {victim}"
                assert process.poll() is None, f"the run ended before {victim} was killed"
                for earlier, pid in killed.items():  # the one killed before runs again
                    assert wait_until(
                        lambda e=earlier, p=pid: _children(process.pid).get(e, p) != p,
                        timeout_s=bound_s(60.0),
                    ), f"{earlier} was not restarted"
                pid = _children(process.pid)[victim]
                os.kill(pid, signal.SIGKILL)
                killed[victim] = pid
            process.wait(timeout=run_timeout_s)
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
    deaths = {record["service"]: record for record in report["restarts"]}
    robots = {name for name in deaths if name.startswith("robot-")}  # one robot of the fleet (any type)
    assert len(robots) == 1 and set(deaths) - robots == {"physics", "agents", "planner", "bus"}, detail
    assert all(record["restarted_wall_s"] is not None for record in deaths.values()), detail
    constructions = _constructions(run)
    assert len(constructions) == total and set(constructions.values()) == {1}, constructions
    audit = report["as_built"]
    assert audit["errors"] == [] and audit["checked"] == total, detail
    assert report["totals"]["max_final_position_error_mm"] <= 10.0, detail
    assert waits_that_ran_out(run.logs_dir) == []
