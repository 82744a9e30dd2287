"""``bimbot run`` stops a service with one SIGTERM, not two.

A service restores the default SIGTERM handler as it finishes; a second SIGTERM landing then killed it
mid-exit (exit -15, no closing log line: physics once lost its peak-memory line in the clean-clone suite).
``stop_all`` signals every service first and then waits for each in turn: waiting for one must not signal
it again once the services before it took their time. The services here are real processes that count the
SIGTERMs they get and take a while to shut down.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
from collections.abc import Mapping, Sequence
from pathlib import Path

from wall_clock import bound_s

from bimbot.polling import wait_until
from bimbot.supervisor import ServiceProcess, stop_all

COUNTING_SERVICE = textwrap.dedent(
    """
    import signal, sys, time
    from pathlib import Path
    folder, shutdown_s, stopping = Path(sys.argv[1]), float(sys.argv[2]), []
    def on_term(signum, frame):
        with (folder / "terms.txt").open("a") as out:
            out.write("TERM\\n")
        stopping.append(signum)
    signal.signal(signal.SIGTERM, on_term)
    (folder / "ready").write_text("ready")
    while not stopping:
        time.sleep(0.01)
    time.sleep(shutdown_s)  # closing its session, writing its last lines
    """
)


class CountingLauncher:
    """Starts a counting service instead of a ``bimbot`` command, as a fork server starts one; its only
    argument is the service's folder, where it writes ``ready`` and one line per SIGTERM."""

    def __init__(self, shutdown_s: dict[str, float]) -> None:
        self.shutdown_s = shutdown_s

    def spawn(self, args: Sequence[str], log_path: Path, env: Mapping[str, str]) -> subprocess.Popen[bytes]:
        (folder,) = args
        command = [sys.executable, "-c", COUNTING_SERVICE, folder, str(self.shutdown_s[folder])]
        return subprocess.Popen(command, start_new_session=True)


def test_stop_all_sends_each_service_one_sigterm_and_waits_for_it(tmp_path: Path) -> None:
    first, second = tmp_path / "first", tmp_path / "second"
    for folder in (first, second):
        folder.mkdir()
    # stop_all waits for the last started first: "second" holds it 0.5 s while "first" still shuts down
    launcher = CountingLauncher({str(first): 1.5, str(second): 0.5})
    services = [
        ServiceProcess(folder.name, [str(folder)], tmp_path, launcher=launcher)  # type: ignore[arg-type]
        for folder in (first, second)
    ]
    assert wait_until(lambda: all((f / "ready").exists() for f in (first, second)), timeout_s=bound_s(20.0))
    stop_all(services)
    for service, folder in zip(services, (first, second), strict=True):
        assert service.process.returncode == 0, service.name  # it finished its own shutdown, not killed
        assert (folder / "terms.txt").read_text().splitlines() == ["TERM"], service.name
