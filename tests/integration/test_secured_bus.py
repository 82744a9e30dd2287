"""A secured bus, for real: ``bimbot bus`` as a process with the router config of ``bimbot bus-credentials``,
and client sessions holding the services' own files. Only the right service can speak: what a stranger or
the wrong robot puts never reaches a subscriber, while the owner's own messages do.

Every forged put is followed, from the same session, by a put that session may make; messages of one
session arrive in order, so once the allowed one is in, the forged one would have been too.
"""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
import zenoh
from wall_clock import bound_s

from bimbot.shared.bus import BusOptions, open_session
from bimbot.shared.bus_credentials import BusFiles, write_bus_credentials
from bimbot.shared.errors import InputError
from bimbot.shared.messages import (
    CLOCK,
    COMPONENT_STATE,
    COMPONENT_TWIN,
    PHYSICS_ATTACH,
    ROBOT_CMD_VEL,
    TASK,
)
from bimbot.supervisor import ServiceProcess, free_port

pytestmark = pytest.mark.integration
SITE = "site_a"
WAIT_S = 10.0


class Heard:
    """Every (key, payload) a session's subscriber on the whole site received, thread-safe."""

    def __init__(self, session: zenoh.Session) -> None:
        self._lock = threading.Lock()
        self._items: list[tuple[str, bytes]] = []
        self.subscriber = session.declare_subscriber(f"bimbot/{SITE}/**", self._on_sample)

    def _on_sample(self, sample: zenoh.Sample) -> None:
        with self._lock:
            self._items.append((str(sample.key_expr), sample.payload.to_bytes()))

    @property
    def items(self) -> list[tuple[str, bytes]]:
        with self._lock:
            return list(self._items)

    def payloads(self, key: str) -> list[bytes]:
        return [payload for got, payload in self.items if got == key]


def _until(check: Callable[[], bool], what: str, put_again: Callable[[], None] | None = None) -> None:
    """Wait for ``check`` (putting again every 0.2 s while the new session's routes settle)."""
    deadline = time.monotonic() + bound_s(WAIT_S)
    while not check():
        if time.monotonic() > deadline:
            pytest.fail(f"timed out waiting for {what}")
        if put_again is not None:
            put_again()
        time.sleep(0.2)


@pytest.fixture
def secured(tmp_path: Path) -> Iterator[tuple[str, BusFiles]]:
    files = write_bus_credentials(tmp_path / "run", ("r1", "r2"), site=SITE)
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    router = ServiceProcess("bus", ["bus", "--listen", endpoint, "--bus-config", str(files.router)], tmp_path)
    try:
        yield endpoint, files
    finally:
        router.stop()


def _anonymous(endpoint: str, mode: str) -> zenoh.Config:
    """A session of ``mode`` with no credentials that does not give up opening when it is refused."""
    config = zenoh.Config()
    settings = {
        "mode": mode,
        "connect/endpoints": [endpoint],
        "listen/endpoints": ["tcp/127.0.0.1:0"] if mode == "peer" else [],
        "scouting/multicast/enabled": False,
        "connect/timeout_ms": 500,
        "connect/exit_on_failure": False,
    }
    for key, value in settings.items():
        config.insert_json5(key, json.dumps(value))
    return config


def _as(endpoint: str, config_file: Path) -> zenoh.Session:
    return open_session(BusOptions(mode="client", connect=(endpoint,), listen=(), config_file=config_file))


def test_a_client_without_credentials_cannot_join_and_what_it_puts_never_arrives(
    secured: tuple[str, BusFiles],
) -> None:
    endpoint, files = secured
    with _as(endpoint, files.monitor) as monitor, _as(endpoint, files.physics) as physics:
        heard = Heard(monitor)
        clock = CLOCK.key(site=SITE)
        _until(lambda: bool(heard.payloads(clock)), "physics' clock", lambda: physics.put(clock, b"real"))
        forged = [clock, COMPONENT_STATE.key(site=SITE, key="k1"), TASK.key(site=SITE, task_id="t1")]
        with pytest.raises(zenoh.ZError):  # a client must join its router; refused, it cannot even open
            zenoh.open(_anonymous(endpoint, "client"))
        with zenoh.open(_anonymous(endpoint, "peer")) as stranger:  # a peer opens alone, and puts
            for key in forged:
                stranger.put(key, b"forged")
        physics.put(clock, b"after")
        _until(lambda: b"after" in heard.payloads(clock), "the clock after the stranger's puts")
        time.sleep(0.3)
        assert all(payload != b"forged" for _, payload in heard.items)


def test_a_wrong_password_ends_within_the_bound_in_one_line(
    secured: tuple[str, BusFiles], tmp_path: Path
) -> None:
    endpoint, files = secured
    config = json.loads(files.physics.read_text())
    config["transport"]["auth"]["usrpwd"]["password"] = "guessed"
    config["connect"] = {"timeout_ms": 1000}
    wrong = tmp_path / "wrong.json5"
    wrong.write_text(json.dumps(config))
    started = time.monotonic()
    with pytest.raises(InputError, match="as user 'physics' within 1 s") as error:
        _as(endpoint, wrong)
    assert time.monotonic() - started < bound_s(5.0)  # a refused session that kept trying would hang
    assert "\n" not in str(error.value) and ".rs:" not in str(error.value)


def test_robot_r2_cannot_drive_r1_or_set_the_clock_and_physics_can(secured: tuple[str, BusFiles]) -> None:
    endpoint, files = secured
    with (
        _as(endpoint, files.monitor) as monitor,
        _as(endpoint, files.robot("r2")) as r2,
        _as(endpoint, files.physics) as physics,
    ):
        heard = Heard(monitor)
        own = ROBOT_CMD_VEL.key(site=SITE, robot_id="r2")
        _until(lambda: bool(heard.payloads(own)), "r2's own cmd_vel", lambda: r2.put(own, b"r2 own"))
        r1_cmd_vel, clock = ROBOT_CMD_VEL.key(site=SITE, robot_id="r1"), CLOCK.key(site=SITE)
        r2.put(r1_cmd_vel, b"r2 as r1")
        r2.put(clock, b"r2 clock")
        r2.put(own, b"r2 last")
        physics.put(clock, b"physics clock")
        _until(lambda: b"r2 last" in heard.payloads(own), "r2's put after the forged ones")
        _until(lambda: b"physics clock" in heard.payloads(clock), "physics' clock")
        assert heard.payloads(r1_cmd_vel) == []
        assert heard.payloads(clock) == [b"physics clock"]


def test_only_the_agents_answer_twins_and_only_robots_reach_physics_requests(
    secured: tuple[str, BusFiles],
) -> None:
    endpoint, files = secured
    asked: list[str] = []
    twin_key, attach_key = COMPONENT_TWIN.key(site=SITE, key="k1"), PHYSICS_ATTACH.key(site=SITE)
    with (
        _as(endpoint, files.agents) as agents,
        _as(endpoint, files.observer) as observer,
        _as(endpoint, files.physics) as physics,
        _as(endpoint, files.robot("r1")) as r1,
        agents.declare_queryable(
            COMPONENT_TWIN.key(site=SITE, key="*"), lambda q: q.reply(twin_key, b"agent")
        ),
        observer.declare_queryable(twin_key, lambda q: q.reply(twin_key, b"impostor")),
        physics.declare_queryable(attach_key, lambda q: (asked.append("asked"), q.reply(attach_key, b"ok"))),
    ):

        def replies(session: zenoh.Session, selector: str) -> list[bytes]:
            return [r.ok.payload.to_bytes() for r in session.get(selector, timeout=1.0) if r.ok is not None]

        _until(lambda: replies(r1, attach_key) == [b"ok"], "physics answering the robot")
        _until(lambda: b"agent" in replies(r1, COMPONENT_TWIN.key(site=SITE, key="*")), "the agents' twin")
        assert replies(r1, COMPONENT_TWIN.key(site=SITE, key="*")) == [b"agent"]
        before = len(asked)
        assert replies(observer, attach_key) == []
        assert len(asked) == before, "the observer's request reached physics"


@contextmanager
def _port_taken(endpoint: str) -> Iterator[None]:
    """A plain TCP listener holding ``endpoint``'s port for the length of the ``with``."""
    host, port = endpoint.removeprefix("tcp/").rsplit(":", 1)
    with socket.socket() as holder:
        holder.bind((host, int(port)))
        holder.listen()
        yield


def test_the_router_says_in_one_line_when_it_cannot_listen(tmp_path: Path) -> None:
    files = write_bus_credentials(tmp_path, ("r1",))
    busy = f"tcp/127.0.0.1:{free_port()}"
    with _port_taken(busy):
        for listen, said in (("garbage", "not a Zenoh endpoint"), (busy, "the address is in use")):
            command = ["bus", "--listen", listen, "--bus-config", str(files.router), "--seconds", "5"]
            done = subprocess.run(
                [sys.executable, "-P", "-m", "bimbot.cli", *command],
                capture_output=True,
                text=True,
                timeout=bound_s(60),
                check=False,
            )
            assert done.returncode == 2, done.stderr
            lines = done.stderr.strip().splitlines()
            assert len(lines) == 1 and said in lines[0], done.stderr
