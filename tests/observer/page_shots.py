"""Screenshots of a web page as a person sees it, taken until they show what a test waits for.

Real Chromium (not headless) under Xvfb, WebGL through the SwiftShader software rasteriser, captured over
the DevTools protocol (websocket-client, a test dependency). A WebGL app such as rerun's web viewer draws
seconds after its page loaded (15 to 30 s of software rendering on a busy 2-core machine): one screenshot
after a fixed wait either comes before it drew or waits far longer than it needed, so :func:`shoot_until`
takes one after another until a check passes, or its bound runs out, and returns the last.
"""

from __future__ import annotations

import base64
import json
import os
import shutil
import signal
import subprocess
import tempfile
import time
import urllib.request
from collections.abc import Callable, Iterator
from contextlib import contextmanager, suppress
from pathlib import Path

import websocket

SCREEN = "1600x1000x24"
CHROMIUM_FLAGS = (
    "--no-sandbox",
    "--use-gl=angle",
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
    "--ignore-gpu-blocklist",
    "--window-size=1600,1000",
)


def missing_programs() -> list[str]:
    """The programs a screenshot needs that are not installed (``scripts/setup.sh --tests`` installs them)."""
    return [name for name in ("xvfb-run", "xauth", "chromium") if shutil.which(name) is None]


@contextmanager
def browser_page(url: str, port: int, timeout_s: float) -> Iterator[websocket.WebSocket]:
    """Chromium under ``xvfb-run`` showing ``url``, and a DevTools connection to its page. Every process
    of it (Xvfb, Chromium's helpers) is ended with its process group on exit."""
    profile = tempfile.mkdtemp(prefix="page-shots-")
    command = ["xvfb-run", "-a", "-s", f"-screen 0 {SCREEN}", "chromium", *CHROMIUM_FLAGS]
    command += [f"--remote-debugging-port={port}", f"--user-data-dir={profile}", url]
    browser = subprocess.Popen(
        command,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
        env={**os.environ, "TMPDIR": profile},  # Chromium's own temporary folders go with the profile
    )
    try:
        deadline = time.monotonic() + timeout_s
        pages: list[dict] = []
        while not pages:
            assert browser.poll() is None, f"chromium exited ({browser.returncode}) before it opened a page"
            assert time.monotonic() < deadline, f"chromium opened no page within {timeout_s:.0f} s"
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{port}/json", timeout=5) as reply:
                    pages = [tab for tab in json.load(reply) if tab.get("type") == "page"]
            except OSError:
                pages = []
            if not pages:
                time.sleep(0.2)
        page = websocket.create_connection(pages[0]["webSocketDebuggerUrl"], timeout=timeout_s)
        try:
            yield page
        finally:
            page.close()
    finally:
        with suppress(ProcessLookupError):
            os.killpg(browser.pid, signal.SIGTERM)
        try:
            browser.wait(10)
        except subprocess.TimeoutExpired:
            os.killpg(browser.pid, signal.SIGKILL)
            browser.wait()
        shutil.rmtree(profile, ignore_errors=True)


def screenshot(page: websocket.WebSocket, out: Path, request_id: int) -> Path:
    """The page as it is drawn now, written to ``out`` (PNG)."""
    page.send(json.dumps({"id": request_id, "method": "Page.captureScreenshot", "params": {"format": "png"}}))
    while True:
        message = json.loads(page.recv())
        if message.get("id") == request_id:
            break
    out.write_bytes(base64.b64decode(message["result"]["data"]))
    return out


def shoot_until(
    url: str, out: Path, shows: Callable[[Path], bool], *, port: int, timeout_s: float, every_s: float = 1.0
) -> Path:
    """Screenshots of ``url`` into ``out``, one every ``every_s`` after the last, until ``shows`` says the
    last one shows what is waited for or ``timeout_s`` (wall s) has passed; ``out`` holds the last one."""
    deadline = time.monotonic() + timeout_s
    with browser_page(url, port, timeout_s) as page:
        for request_id in range(1, 1_000_000):
            screenshot(page, out, request_id)
            if shows(out) or time.monotonic() + every_s > deadline:
                break
            time.sleep(every_s)
    return out
