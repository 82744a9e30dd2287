"""A service outlives nothing: when the process that started it dies, even by SIGKILL, the service stops.

Orphans were seen: ``bimbot run`` killed with SIGKILL (a test's timeout) left its bus, physics, agents and
robot running for an hour, physics stepping at real time for nobody.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

from bimbot.supervisor import free_port, wait_until

PARENT = textwrap.dedent(
    """
    import sys, time
    from pathlib import Path
    from bimbot.supervisor import ServiceProcess
    bus = ServiceProcess("bus", ["bus", "--listen", sys.argv[1]], Path(sys.argv[2]))
    print(bus.process.pid, flush=True)
    time.sleep(600)
    """
)


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def test_a_service_stops_when_the_process_that_started_it_is_killed(tmp_path: Path) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    parent = subprocess.Popen(
        [sys.executable, "-c", PARENT, endpoint, str(tmp_path)], stdout=subprocess.PIPE, text=True
    )
    try:
        assert parent.stdout is not None
        child = int(parent.stdout.readline())
        assert wait_until(lambda: "listening" in (tmp_path / "bus.log").read_text(), timeout_s=30.0)
        assert _alive(child)
        parent.send_signal(signal.SIGKILL)
        parent.wait(timeout=10)
        assert wait_until(lambda: not _alive(child), timeout_s=15.0), "the bus outlived its parent"
    finally:
        parent.kill()
        if "child" in locals() and _alive(child):
            os.kill(child, signal.SIGKILL)
