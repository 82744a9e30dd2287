"""Process helpers for tests that start and kill real processes."""

from __future__ import annotations

from pathlib import Path


def alive(pid: int) -> bool:
    """Whether ``pid`` runs (a zombie, exited but not reaped, does not)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def run_services(run_pid: int) -> dict[int, list[str]]:
    """pid → argv of the services (``bimbot.cli`` processes) started by the run ``run_pid``: its children,
    or the children of its fork server, which is the run's child or, a session of a warm fork server
    (tests/conftest.py), names the run in its title. A forked service's title is its command line."""
    parents: dict[int, int] = {}
    argvs: dict[int, list[str]] = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
            argv = (entry / "cmdline").read_bytes().decode(errors="replace").replace("\0", " ").split()
        except OSError:
            continue
        parents[int(entry.name)] = int(stat.rsplit(")", 1)[1].split()[1])
        argvs[int(entry.name)] = argv
    servers = {
        pid
        for pid, argv in argvs.items()
        if parents[pid] == run_pid or " ".join(argv).endswith(f"bimbot run {run_pid})")
    }
    return {
        pid: argv
        for pid, argv in argvs.items()
        if "bimbot.cli" in argv and (parents[pid] == run_pid or parents[pid] in servers)
    }
