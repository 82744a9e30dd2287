"""A service outlives nothing: when the process that started it dies, even by SIGKILL, the service stops.

Orphans were seen: ``bimbot run`` killed with SIGKILL (a test's timeout) left its bus, physics, agents and
robot running for an hour, physics stepping at real time for nobody. Both ways a run starts a service are
tried: a plain child process, and a child of the run's fork server (:mod:`bimbot.fork_server`), whose
death the kernel passes on to its children in turn.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from processes import alive
from wall_clock import bound_s

from bimbot.polling import wait_until
from bimbot.supervisor import free_port

PARENT = textwrap.dedent(
    """
    import sys, time
    from pathlib import Path
    from bimbot.fork_server import ForkServer
    from bimbot.supervisor import ServiceProcess
    launcher = ForkServer() if sys.argv[3] == "forked" else None
    bus = ServiceProcess("bus", ["bus", "--listen", sys.argv[1]], Path(sys.argv[2]), launcher=launcher)
    print(bus.process.pid, flush=True)
    time.sleep(600)
    """
)


@pytest.mark.parametrize("started", ["plain", "forked"])
def test_a_service_stops_when_the_process_that_started_it_is_killed(tmp_path: Path, started: str) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    parent = subprocess.Popen(
        [sys.executable, "-c", PARENT, endpoint, str(tmp_path), started], stdout=subprocess.PIPE, text=True
    )
    child = 0
    try:
        assert parent.stdout is not None
        child = int(parent.stdout.readline())
        assert wait_until(lambda: "listening" in (tmp_path / "bus.log").read_text(), timeout_s=bound_s(60.0))
        assert alive(child)
        parent.send_signal(signal.SIGKILL)
        parent.wait(timeout=bound_s(10))
        assert wait_until(lambda: not alive(child), timeout_s=bound_s(15.0)), "the bus outlived its parent"
    finally:
        parent.kill()
        if child and alive(child):
            os.kill(child, signal.SIGKILL)
