"""``bimbot run`` counts what the agents' twins say is constructed, not what a state message claims.

A probe once published forged ``constructed`` state messages for every component from a foreign process:
``bimbot run`` printed ``constructed 12/12`` and exited 0 while the agents' journal held one constructed.
Here a forger process does the same while the small 2×1 frame of the full-build test is built with real
processes on a loopback bus, from the moment the first component is really constructed (so the count to
get right is not zero): announcements, jumps the agents' state table forbids, and plausible verdicts,
every 0.1 s for every component. The run's report, its summary line and its exit code must say exactly
what the agents' journal says (up to the end-of-run audit, when the run asks every twin: a component the
robot finishes while the services are being stopped is in the journal but was never the run's to count).
The robot judges the state messages the same way, so the forger does not stall it either: every component
is built.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
import textwrap
import threading
from pathlib import Path
from typing import IO

import pytest
from fleets import ground_fleet_file
from frames import convert_small_frame
from wall_clock import bound_s

from bimbot.polling import wait_until
from bimbot.services.component_agents.journal import journal_path, replay
from bimbot.shared.manifest import read_manifest
from bimbot.shared.messages import ComponentState
from bimbot.shared.run_folder import RunFolder

pytestmark = pytest.mark.integration
RUN_TIMEOUT_S = 300
# at most 60× real time: the small frame's ~430 s of sim time (its columns held while their bases are
# bolted) take ≥ 7 s, so the forgeries have seconds of the run left to be heard in (as fast as possible
# the frame once took 3.5 s, and ended before they came)
RUN_RTF = 60.0

FORGER = textwrap.dedent(
    """
    import sys, time
    from bimbot.shared.bus import BusOptions, encode, open_session
    from bimbot.shared.manifest import read_manifest
    from bimbot.shared.messages import COMPONENT_STATE, ComponentState as S, ComponentStateMsg

    endpoint, build = sys.argv[1], sys.argv[2]
    manifest = read_manifest(build)
    forgeries = ((None, "resume"), (S.PLANNED, "verified"), (S.VERIFYING, "verified"))
    with open_session(BusOptions(connect=(endpoint,))) as session:
        print("ready", flush=True)
        sys.stdin.readline()  # the test says when: once a component is really constructed
        rounds = 0
        while True:
            for component in manifest.components:
                key = COMPONENT_STATE.key(site=manifest.site, key=component.key)
                for previous, event in forgeries:
                    message = ComponentStateMsg(
                        guid=component.guid, state=S.CONSTRUCTED, previous=previous, event=event,
                        attempt=1, robot_id="r1", sim_time_s=1.0, wall_time_s=time.time(),
                    )
                    session.put(key, encode(message))
            rounds += 1
            if rounds == 1:
                print("forging", flush=True)
            time.sleep(0.1)
    """
)


@pytest.fixture(scope="module")
def small_frame(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return convert_small_frame(tmp_path_factory.mktemp("forged_frame"), (2, 1))


class _Lines:
    """A process's stdout, read on a thread (so the test can wait for a line without blocking)."""

    def __init__(self, process: subprocess.Popen[str]) -> None:
        self.lines: list[str] = []
        assert process.stdout is not None
        self._thread = threading.Thread(target=self._read, args=(process.stdout,), daemon=True)
        self._thread.start()

    def _read(self, stream: IO[str]) -> None:
        for line in stream:
            self.lines.append(line)

    def text(self) -> str:
        self._thread.join(timeout=bound_s(5.0))
        return "".join(self.lines)


def _constructed_in_journal(run: RunFolder) -> dict[str, float]:
    """GUID → wall time of its ``constructed`` transition, from the agents' own journal."""
    records = replay(journal_path(run.state_dir, 1, 1)).records
    return {
        guid: record.change.wall_time_s
        for guid, changes in records.items()
        for record in changes
        if record.change.state == ComponentState.CONSTRUCTED and record.change.previous is not None
    }


def test_forged_constructed_messages_change_nothing_the_run_counts_what_the_twins_say(
    small_frame: Path, tmp_path: Path
) -> None:
    manifest = read_manifest(small_frame)
    run = RunFolder(tmp_path / "run")
    command = [sys.executable, "-m", "bimbot.cli", "run", str(small_frame), "-q", "--run-dir", str(run.root)]
    command += ["--fleet", str(ground_fleet_file(tmp_path)), "--rtf", str(RUN_RTF)]  # one carrier
    run_timeout_s = bound_s(RUN_TIMEOUT_S)
    command += ["--timeout-s", f"{run_timeout_s - 60:.0f}"]
    errors = (tmp_path / "run.stderr").open("w")
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=errors, text=True)
    out = _Lines(process)
    forger: subprocess.Popen[str] | None = None
    try:
        assert wait_until(lambda: any("bus: tcp/" in line for line in out.lines), timeout_s=bound_s(60.0))
        found = re.search(r"bus: (tcp/\S+)", "".join(out.lines))
        assert found is not None
        endpoint = found.group(1)
        # the forger starts (imports, joins the bus) while the run does, so its first forgeries go out as
        # soon as a component is constructed, not a second later when a fast run may be over
        forger = subprocess.Popen(
            [sys.executable, "-c", FORGER, endpoint, str(small_frame)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
        )
        assert forger.stdin is not None and forger.stdout is not None
        assert forger.stdout.readline().strip() == "ready"
        assert wait_until(lambda: bool(_constructed_in_journal(run)), timeout_s=run_timeout_s / 2), (
            "nothing was constructed"
        )
        forger.stdin.write("go\n")
        forger.stdin.flush()
        assert forger.stdout.readline().strip() == "forging"
        process.wait(timeout=run_timeout_s)
    finally:
        for child in (forger, process):
            if child is not None and child.poll() is None:
                child.kill()
                child.wait()
        errors.close()
    stdout, err = out.text(), (tmp_path / "run.stderr").read_text()
    journal = _constructed_in_journal(run)
    report = json.loads((run.report_dir / "report.json").read_text())
    reported = {c["guid"] for c in report["components"] if c["state"] == "constructed"}
    detail = f"{stdout}\n{err[-3000:]}\njournal: {sorted(journal)}\nreport: {sorted(reported)}"
    # the twins were asked at the end (the audit) while the agents still ran: everything the journal has
    # from before that moment is in the report, and nothing the journal does not have
    audit = report.get("as_built") or {}
    assert audit.get("audited"), "bimbot run must call RunMonitor.audit() before it stops the services"
    before = {guid for guid, at in journal.items() if at < audit["asked_at_unix_s"]}
    assert before <= reported <= set(journal), detail
    assert report["totals"]["constructed"] == len(reported), detail
    assert f"constructed {len(reported)}/{len(manifest.components)} components" in stdout, detail
    # nor does it stall the robot (it asks the twin about a state that does not follow): all are built
    assert len(reported) == len(manifest.components) and process.returncode == 0, detail
    assert report["totals"]["state_messages_not_taken"] > 0, detail  # the forgeries were heard and refused
