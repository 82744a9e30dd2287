"""The served web viewer: ``bimbot observe`` serves the rerun viewer on loopback, and headless Chromium
(Debian's ``chromium``) loads it; SIGTERM then ends the observer cleanly with its report and recording.
"""

from __future__ import annotations

import json
import shutil
import signal
import subprocess
import urllib.request
from collections.abc import Iterator
from pathlib import Path

import pytest
from wall_clock import bound_s

from bimbot.polling import wait_until
from bimbot.services.observer.app import rerun_cli_binary
from bimbot.shared.run_folder import latest_run_folder
from bimbot.supervisor import ServiceProcess, free_port

pytestmark = pytest.mark.integration
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


def listening_addresses(port: int) -> set[str]:
    """IPv4 addresses with a listening TCP socket on ``port`` (Linux ``/proc/net/tcp``)."""
    addresses = set()
    for line in Path("/proc/net/tcp").read_text().splitlines()[1:]:
        fields = line.split()
        local, state = fields[1], fields[3]
        host_hex, port_hex = local.split(":")
        if state == "0A" and int(port_hex, 16) == port:  # 0A: LISTEN
            addresses.add(".".join(str(int(host_hex[i : i + 2], 16)) for i in (6, 4, 2, 0)))
    return addresses


@pytest.fixture(scope="module")
def served(bundled_build: Path, tmp_path_factory: pytest.TempPathFactory) -> Iterator[dict]:
    tmp = tmp_path_factory.mktemp("served")
    build = tmp / "build"
    shutil.copytree(bundled_build, build)
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    web_port, grpc_port = free_port(), free_port()
    router = ServiceProcess("bus", ["bus", "--listen", endpoint], tmp)
    observer = ServiceProcess(
        "observe",
        [
            *("observe", "--build", str(build), "--connect", endpoint),
            *("--web-port", str(web_port), "--grpc-port", str(grpc_port)),
        ],
        tmp,
    )
    try:
        assert wait_until(lambda: "observing" in observer.log(), bound_s(30.0)), observer.log()
        yield {"observer": observer, "web_port": web_port, "grpc_port": grpc_port, "build": build, "tmp": tmp}
    finally:
        observer.stop()
        router.stop()


def test_the_viewer_and_its_data_are_served_on_loopback_only(served: dict) -> None:
    assert listening_addresses(served["web_port"]) == {"127.0.0.1"}
    assert listening_addresses(served["grpc_port"]) == {"127.0.0.1"}


def test_the_viewer_wasm_is_served(served: dict) -> None:
    with urllib.request.urlopen(
        f"http://127.0.0.1:{served['web_port']}/re_viewer_bg.wasm", timeout=bound_s(10)
    ) as reply:
        assert reply.read(4) == b"\0asm"


@pytest.mark.skipif(
    CHROMIUM is None, reason="Debian's chromium is not installed (scripts/setup.sh installs it)"
)
def test_headless_chromium_loads_the_rerun_viewer_page(served: dict) -> None:
    url = f"http://127.0.0.1:{served['web_port']}/?url=rerun%2Bhttp%3A%2F%2F127.0.0.1%3A{served['grpc_port']}%2Fproxy"
    command = [
        str(CHROMIUM),
        *("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run"),
        *("--disable-background-networking", "--disable-component-update", "--disable-sync"),
        f"--user-data-dir={served['tmp'] / 'chromium-profile'}",
        "--dump-dom",
        url,
    ]
    result = subprocess.run(command, check=False, capture_output=True, text=True, timeout=bound_s(90))
    assert result.returncode == 0, result.stderr[-2000:]
    dom = result.stdout
    assert "<title>Rerun Viewer</title>" in dom
    assert 'src="re_viewer.js"' in dom and 'id="the_canvas_id"' in dom


def test_sigterm_ends_the_observer_with_a_report_and_a_valid_recording(served: dict) -> None:
    observer = served["observer"]
    observer.process.send_signal(signal.SIGTERM)
    assert observer.wait(bound_s(30.0)) == 0, observer.log()[-3000:]
    run = latest_run_folder(served["build"])  # no --run-dir: the build's latest run folder, made for it
    assert run is not None
    report = json.loads((run.report_dir / "report.json").read_text())
    assert report["totals"]["components"] == 28 and report["totals"]["constructed"] == 0
    assert (run.report_dir / "report.png").is_file()
    rrd = run.recording_path("greenhouse-site")
    verify = subprocess.run(
        [str(rerun_cli_binary()), "rrd", "verify", str(rrd)],
        check=False,
        capture_output=True,
        text=True,
        timeout=bound_s(60),
    )
    assert verify.returncode == 0, verify.stderr[-2000:]
    assert not listening_addresses(served["web_port"])  # the web viewer process is gone too
