"""The study's runs on Dask, for real: an embedded LocalCluster runs ``bimbot run`` processes.

A run that cannot run (no build there) comes back as a ``failed`` row with the run's own one-line reason,
not as a lost study; and ``bimbot study`` over one small fleet writes the CSV, the table and the plot
from a real run's report.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from frames import convert_small_frame

from bimbot.study.cluster import run_on_dask
from bimbot.study.execute import RunJob
from bimbot.study.grid import study_grid
from bimbot.study.summary import read_csv
from bimbot.warm_fork_server import WARM_FORK_SERVER_ENV

ONE_CARRIER = """
default_type = "carrier"

[types.carrier]
urdf = "carrier.urdf"
payload_kg = 3000
reach_m = 1.8
max_place_height_m = 3.5
length_m = 1.4
width_m = 0.9
max_speed_mps = 0.8
max_turn_radps = 1.0
cost_per_h = 60.0

[[robots]]
type = "carrier"
count = 1
"""


def test_a_run_that_cannot_run_is_a_failed_row_with_its_reason(tmp_path: Path) -> None:
    fleet = tmp_path / "one.toml"
    fleet.write_text(ONE_CARRIER)
    grid = study_grid([fleet], seeds=2)
    jobs = [RunJob(tmp_path / "no-build", tmp_path / "study", run, 60.0, pass_seed=False) for run in grid]
    seen: list[str] = []
    rows = run_on_dask(jobs, workers=2, progress=lambda row: seen.append(row["seed"]))
    assert sorted(seen) == [0, 1] and [row["seed"] for row in rows] == [0, 1]  # grid order, from run's seed
    for row in rows:
        assert row["status"] == "failed" and row["exit_code"] == 2, row
        assert row["reason"].startswith("no report (exit 2): bimbot run: error:"), row
        assert "no-build" in row["reason"], row
        assert (tmp_path / "study" / row["run_dir"] / "study-run.log").is_file()


@pytest.mark.integration
def test_bimbot_study_writes_the_csv_table_and_plot_of_its_runs(tmp_path: Path) -> None:
    build = convert_small_frame(tmp_path / "frame", (2, 1))
    fleet = tmp_path / "one_carrier.toml"
    fleet.write_text(ONE_CARRIER)
    out = tmp_path / "study"
    command = [sys.executable, "-m", "bimbot.cli", "-q", "study", str(build), "--fleet", str(fleet)]
    command += ["--seeds", "1", "-o", str(out), "--timeout-s", "300"]
    # the study starts its own warm fork server (not the suite's), and its one run takes a session of it
    environment = {k: v for k, v in os.environ.items() if k != WARM_FORK_SERVER_ENV}
    done = subprocess.run(command, check=False, capture_output=True, text=True, timeout=600, env=environment)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "distributed." not in done.stderr, done.stderr  # Dask's INFO lines are not the user's
    (row,) = read_csv(out / "study.csv")
    assert (row["fleet"], row["seed"], row["status"]) == ("one_carrier", "0", "built"), row
    assert row["constructed"] == row["components"] != "0"
    assert float(row["makespan_s"]) > 0 and 0 < float(row["utilisation_carrier"]) <= 1
    assert float(row["cost"]) == pytest.approx(60.0 * float(row["busy_h"]), abs=0.01)
    assert (out / row["run_dir"] / "report" / "report.json").is_file()
    fork_server_log = (out / row["run_dir"] / "logs" / "fork-server.log").read_text()
    assert "a session of the warm fork server" in fork_server_log, fork_server_log
    table = (out / "study.md").read_text()
    assert "| one_carrier | 1/1 |" in table and table.split("\n", 2)[2] in done.stdout
    assert (out / "study.png").read_bytes()[:4] == b"\x89PNG"


def test_a_scheduler_that_does_not_answer_is_one_clear_error(monkeypatch: pytest.MonkeyPatch) -> None:
    from bimbot.shared.errors import UserError
    from bimbot.study import cluster
    from bimbot.supervisor import free_port

    monkeypatch.setattr(cluster, "SCHEDULER_TIMEOUT_S", 1.0)
    address = f"tcp://127.0.0.1:{free_port()}"
    with pytest.raises(UserError, match="no Dask scheduler answers there"), cluster.dask_client(address, 1):
        pass
