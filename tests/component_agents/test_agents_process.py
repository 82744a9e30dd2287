"""`bimbot agents` as a process on a real Zenoh bus: liveliness, protocol, twins, garbage, a cut bus, stop,
restart."""

from __future__ import annotations

import json
import queue
import random
import re
import signal
import time
import uuid
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
import zenoh
from wall_clock import bound_s

from bimbot.services.component_agents.agent import PLANNER_EVENTS
from bimbot.shared.bus import BusOptions, encode, open_session
from bimbot.shared.manifest import Component, read_manifest
from bimbot.shared.messages import (
    ALIVE_KEY,
    CLOCK_KEY,
    COMPONENT_EVENT_KEY,
    COMPONENT_POSE_KEY,
    COMPONENT_STATE_KEY,
    COMPONENT_TWIN_KEY,
    ClockMsg,
    ComponentEvent,
    ComponentEventMsg,
    ComponentPoseMsg,
    ComponentState,
    ComponentStateMsg,
    PoseMsg,
    TwinMsg,
    key,
)
from bimbot.supervisor import free_port, running

pytestmark = pytest.mark.integration

S = ComponentState
E = ComponentEvent
N_COMPONENTS = 28
GARBAGE = 1_000


class Observer:
    """The test's view of the bus: liveliness tokens and state messages (callbacks only enqueue)."""

    def __init__(self, session: zenoh.Session, site: str) -> None:
        self.session = session
        self.site = site
        self._queue: queue.Queue[tuple[str, object]] = queue.Queue()
        self.alive: set[str] = set()
        self.states: list[ComponentStateMsg] = []
        self._subscribers = [
            session.liveliness().declare_subscriber(
                key(ALIVE_KEY, site=site, kind="component", id="*"),
                lambda s: self._queue.put(("alive", (str(s.key_expr), s.kind == zenoh.SampleKind.PUT))),
                history=True,
            ),
            session.declare_subscriber(
                key(COMPONENT_STATE_KEY, site=site, key="*"),
                lambda s: self._queue.put(("state", s.payload.to_bytes())),
            ),
        ]

    def wait_for(self, condition: Callable[[], bool], timeout_s: float, what: str) -> None:
        """Take bus input until ``condition``, at most ``timeout_s`` (on the reference machine: scaled)."""
        timeout_s = bound_s(timeout_s)
        deadline = time.monotonic() + timeout_s
        while not condition():
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise AssertionError(f"timed out after {timeout_s:.1f} s waiting for {what}")
            try:
                tag, item = self._queue.get(timeout=min(remaining, 0.05))
            except queue.Empty:
                continue
            if tag == "alive":
                name, alive = item  # type: ignore[misc]
                (self.alive.add if alive else self.alive.discard)(name)
            else:
                self.states.append(ComponentStateMsg.model_validate_json(item))  # type: ignore[arg-type]

    def seen(self, guid: str, state: S, event: str | None = None) -> bool:
        return any(m.guid == guid and m.state is state and event in (None, m.event) for m in self.states)

    def send(
        self, component: Component, name: E, expect: S, *, sim_time_s: float = 1.0, event_id: str = ""
    ) -> str:
        """At-least-once delivery: repeat the same event id until the expected state is seen."""
        sender = "planner" if name in PLANNER_EVENTS else "robot-t"  # who may send it
        message = ComponentEventMsg(
            guid=component.guid,
            event=name,
            source=sender,
            robot_id=None if sender == "planner" else sender,
            event_id=event_id or str(uuid.uuid4()),
            sim_time_s=sim_time_s,
            wall_time_s=time.time(),
        )
        for _ in range(20):
            self.session.put(key(COMPONENT_EVENT_KEY, site=self.site, key=component.key), encode(message))
            try:
                self.wait_for(lambda: self.seen(component.guid, expect, name.value), 0.5, f"{name.value}")
                return message.event_id
            except AssertionError:
                continue
        raise AssertionError(f"{component.guid} never reached {expect.value} after {name.value}")

    def twins(self, component_key: str, timeout_s: float = 5.0) -> list[TwinMsg]:
        replies = self.session.get(
            key(COMPONENT_TWIN_KEY, site=self.site, key=component_key), timeout=bound_s(timeout_s)
        )
        return [TwinMsg.model_validate_json(reply.ok.payload.to_bytes()) for reply in replies if reply.ok]


def garbage_payloads(component: Component, site: str, count: int) -> Iterator[tuple[str, bytes]]:
    """(key, payload): random bytes, broken JSON, other models' JSON, huge strings, bad values."""
    rng = random.Random(1234)
    keys = [
        key(COMPONENT_EVENT_KEY, site=site, key=component.key),
        key(COMPONENT_POSE_KEY, site=site, key=component.key),
        key(CLOCK_KEY, site=site),
        key(COMPONENT_EVENT_KEY, site=site, key="no_such_component"),
    ]
    clock = ClockMsg(sim_time_s=1.0, step=1, real_time_factor=1.0).model_dump_json()
    pose = ComponentPoseMsg(
        guid=component.guid, pose=PoseMsg(position_m=(0, 0, 0), quat_xyzw=(0, 0, 0, 1)), sim_time_s=1.0
    ).model_dump_json()
    event = json.loads(
        ComponentEventMsg(
            guid=component.guid, event=E.PLACE, source="x", event_id="x", sim_time_s=1.0, wall_time_s=0.0
        ).model_dump_json()
    )
    kinds: list[Callable[[], bytes]] = [
        lambda: rng.randbytes(rng.randint(0, 300)),
        lambda: rng.choice([b"{", b"[]", b"null", b'{"schema_version": 1', b"\xff\xfe", b"", b"NaN", b'"x"']),
        lambda: clock.encode() if rng.random() < 0.5 else pose.encode(),  # valid JSON of another model
        lambda: b'"' + b"x" * rng.randint(100_000, 1_000_000) + b'"',
        lambda: json.dumps({**event, "guid": "x" * 200_000}).encode(),
        lambda: json.dumps(
            {**event, "event": rng.choice(["explode", "verified", "constructed", 7])}
        ).encode(),
        lambda: json.dumps({**event, "schema_version": 99}).encode(),
        lambda: json.dumps(
            {**event, "event_id": str(rng.random()), "guid": "2xxxxxxxxxxxxxxxxxxxxx"}
        ).encode(),
        lambda: pose.replace("[0.0,0.0,0.0,1.0]", "[0.0,0.0,0.0,0.0]").encode(),  # no orientation
        lambda: pose.replace('"sim_time_s":1.0', '"sim_time_s":NaN').encode(),
    ]
    for index in range(count):
        yield keys[index % len(keys)], kinds[(index // len(keys)) % len(kinds)]()


def test_agents_process_on_a_real_bus(agents_build: Path, tmp_path: Path) -> None:
    manifest = read_manifest(agents_build)
    site = manifest.site
    assert len(manifest.components) == N_COMPONENTS
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    run_dir = tmp_path / "run"
    state_dir = run_dir / "state"  # the journal's place in a run folder
    agents_args = [
        "agents",
        "--build",
        str(agents_build),
        "--run-dir",
        str(run_dir),
        "--connect",
        endpoint,
    ]
    subject, other = manifest.components[5], manifest.components[9]

    with (
        running("bus", ["bus", "--listen", endpoint], tmp_path),
        running("agents", agents_args, tmp_path) as agents,
        open_session(BusOptions(connect=(endpoint,))) as session,
    ):
        bus = Observer(session, site)
        bus.wait_for(lambda: len(bus.alive) == N_COMPONENTS, 30.0, "28 liveliness tokens")
        assert bus.alive == {
            key(ALIVE_KEY, site=site, kind="component", id=c.key) for c in manifest.components
        }

        # Drive one component through the protocol; it verifies its own placement.
        for name, expect in ((E.RELEASE, S.RELEASED), (E.PICK, S.PICKING), (E.ATTACH, S.TRANSPORTING)):
            bus.send(subject, name, expect)
        bus.send(subject, E.ARRIVE, S.ASSEMBLING, sim_time_s=5.0)
        target = subject.target_pose_world
        placed = ComponentPoseMsg(
            guid=subject.guid,
            pose=PoseMsg(position_m=target.position_m, quat_xyzw=target.quat_xyzw),
            sim_time_s=6.0,
        )
        session.put(key(COMPONENT_POSE_KEY, site=site, key=subject.key), encode(placed))
        place_id = bus.send(subject, E.PLACE, S.VERIFYING, sim_time_s=6.0)
        # no physics on this bus: the site's tolerances never come, so the agent judges with its own once
        # its verification bound (5 s of wall time) is over
        bus.wait_for(lambda: bus.seen(subject.guid, S.CONSTRUCTED, "verified"), 15.0, "constructed")
        mine = [m.state for m in bus.states if m.guid == subject.guid and m.event not in ("start", "resume")]
        assert mine == [S.RELEASED, S.PICKING, S.TRANSPORTING, S.ASSEMBLING, S.VERIFYING, S.CONSTRUCTED]

        # Twins: one, then all.
        (twin,) = bus.twins(subject.key)
        assert (twin.guid, twin.state, twin.attempt, len(twin.history)) == (subject.guid, S.CONSTRUCTED, 1, 6)
        assert twin.current_pose == placed.pose
        everyone = bus.twins("*")
        assert sorted(t.key for t in everyone) == sorted(c.key for c in manifest.components)

        # Garbage on every subscribed key crashes nothing and changes nothing.
        blocking = zenoh.CongestionControl.BLOCK  # not dropped on a busy machine: the count below needs them
        for key_expr, payload in garbage_payloads(subject, site, GARBAGE):
            session.put(key_expr, payload, congestion_control=blocking)
        session.delete(key(COMPONENT_EVENT_KEY, site=site, key=subject.key))
        (twin,) = bus.twins(subject.key, timeout_s=20.0)  # answered after the garbage in the agents' queue
        assert agents.poll() is None
        assert (twin.state, len(twin.history)) == (S.CONSTRUCTED, 6)
        bus.send(other, E.RELEASE, S.RELEASED)

        # The bus cut: physics' token goes and comes back; every agent says its state again (a state message
        # sent meanwhile may never have arrived), the constructed one and the released one too.
        physics_alive = key(ALIVE_KEY, site=site, kind="physics", id="main")
        session.liveliness().declare_token(physics_alive).undeclare()
        token = session.liveliness().declare_token(physics_alive)
        bus.wait_for(lambda: bus.seen(subject.guid, S.CONSTRUCTED, "restate"), 10.0, "the state again")
        bus.wait_for(lambda: bus.seen(other.guid, S.RELEASED, "restate"), 5.0, "the second state again")
        token.undeclare()

        # SIGTERM: a clean, quick exit.
        started = time.monotonic()
        agents.send_signal(signal.SIGTERM)
        assert agents.wait(bound_s(10)) == 0
        assert time.monotonic() - started < bound_s(3.0)
        invalid = re.search(r"(\d+) invalid payloads were received", (tmp_path / "agents.log").read_text())
        assert invalid is not None
        assert int(invalid.group(1)) >= GARBAGE // 4  # the garbage did arrive (most of it is invalid)
        bus.wait_for(lambda: not bus.alive, 5.0, "liveliness tokens to go")

        # Restart: every agent resumes its last state from the journal; nothing is constructed twice.
        assert list(state_dir.glob("agents-*.jsonl")), "the journal lives in the run folder's state/"
        bus.states.clear()
        with running("agents-restart", agents_args, tmp_path):
            bus.wait_for(lambda: len(bus.alive) == N_COMPONENTS, 30.0, "28 tokens after the restart")
            bus.wait_for(
                lambda: bus.seen(subject.guid, S.CONSTRUCTED, "resume"), 5.0, "the resume announcement"
            )
            bus.wait_for(
                lambda: bus.seen(other.guid, S.RELEASED, "resume"), 5.0, "the second resume announcement"
            )
            repeat = ComponentEventMsg(
                guid=subject.guid,
                event=E.PLACE,
                source="robot-t",
                event_id=place_id,
                sim_time_s=6.0,
                wall_time_s=0,
            )
            session.put(key(COMPONENT_EVENT_KEY, site=site, key=subject.key), encode(repeat))
            (twin,) = bus.twins(subject.key)
            assert (twin.state, len(twin.history)) == (S.CONSTRUCTED, 6)
            assert not [m for m in bus.states if m.guid == subject.guid and m.event == "verified"]
