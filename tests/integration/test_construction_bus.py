"""Agents and planner as real processes on a loopback Zenoh bus, with a test peer in the robot's role.

The bundled light steel frame (28 components) must end fully constructed, in an order its support graph
allows, whatever happens on the way: a misplacement, the agent process killed and restarted, garbage on
every subscribed key.
"""

from __future__ import annotations

import os
import random
import shutil
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
from robot_stand_in import RobotStandIn
from wall_clock import bound_s

from bimbot.polling import wait_until
from bimbot.shared.bus import BusOptions, open_session
from bimbot.shared.manifest import Manifest, read_manifest
from bimbot.shared.messages import ComponentState, ComponentStateMsg, TwinMsg
from bimbot.shared.support_graph import support_predecessors
from bimbot.supervisor import ServiceProcess, free_port

pytestmark = pytest.mark.integration
RUN_TIMEOUT_S = 120.0


@pytest.fixture
def build(bundled_build: Path, tmp_path: Path) -> Path:
    out = tmp_path / "build"
    shutil.copytree(bundled_build, out)
    return out


@pytest.fixture
def bus(tmp_path: Path) -> Iterator[str]:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    router = ServiceProcess("bus", ["bus", "--listen", endpoint], tmp_path)
    try:
        yield endpoint
    finally:
        router.stop()


def _agents(build: Path, endpoint: str, log_dir: Path, name: str = "agents") -> ServiceProcess:
    return ServiceProcess(name, ["agents", "--build", str(build), "--connect", endpoint], log_dir)


def _planner(build: Path, endpoint: str, log_dir: Path) -> ServiceProcess:
    args = ["planner", "--build", str(build), "--connect", endpoint, "--exit-when-done", "--resend-s", "0.5"]
    args += ["--site-info-timeout-s", "0.5"]  # no physics here: the robot stand-in plays it
    return ServiceProcess("planner", args, log_dir)


@contextmanager
def _services(build: Path, endpoint: str, log_dir: Path) -> Iterator[tuple[ServiceProcess, ServiceProcess]]:
    agents = _agents(build, endpoint, log_dir)
    planner = _planner(build, endpoint, log_dir)
    try:
        yield agents, planner
    finally:
        planner.stop()
        agents.stop()


def _constructed_order(states: list[ComponentStateMsg]) -> list[str]:
    """GUIDs in the order they became constructed (state changes only, not start-up announcements)."""
    return [s.guid for s in states if s.state == ComponentState.CONSTRUCTED and s.previous is not None]


def _assert_complete_in_support_order(manifest: Manifest, states: list[ComponentStateMsg]) -> None:
    order = _constructed_order(states)
    assert sorted(order) == sorted(c.guid for c in manifest.components), (
        "each component constructed exactly once"
    )
    position = {guid: index for index, guid in enumerate(order)}
    for guid, supports in support_predecessors(manifest.components).items():
        for support in supports:
            assert position[support] < position[guid], f"{guid} constructed before its support {support}"


def _all_twins(manifest: Manifest, endpoint: str) -> list[TwinMsg]:
    """Every twin, asked again until all answer (a new session needs a moment before its queries route)."""
    twins: list[TwinMsg] = []
    with open_session(BusOptions(connect=(endpoint,))) as session:
        deadline = time.monotonic() + bound_s(15.0)
        while len(twins) < len(manifest.components) and time.monotonic() < deadline:
            replies = session.get(f"bimbot/{manifest.site}/components/*/twin", timeout=bound_s(5.0))
            twins = [TwinMsg.model_validate_json(r.ok.payload.to_bytes()) for r in replies if r.ok]
            time.sleep(0.1)
    return twins


def _finish(planner: ServiceProcess, *services: ServiceProcess) -> int:
    try:
        code = planner.wait(timeout_s := bound_s(RUN_TIMEOUT_S))
    except Exception:
        logs = "\n".join(f"--- {s.name}\n{s.log()[-3000:]}" for s in (planner, *services))
        pytest.fail(f"the build did not finish in {timeout_s:.0f} s\n{logs}")
    return code


def test_every_component_is_constructed_in_an_order_the_support_graph_allows(
    build: Path, bus: str, tmp_path: Path
) -> None:
    manifest = read_manifest(build)
    with (
        RobotStandIn(manifest, BusOptions(connect=(bus,)), robot_ids=("r1", "r2")) as robots,
        _services(build, bus, tmp_path) as (agents, planner),
    ):
        assert _finish(planner, agents) == 0, planner.log()[-3000:]
        assert agents.alive()
    _assert_complete_in_support_order(manifest, robots.record.states)
    assert sorted(robots.record.tasks_done) == sorted(c.guid for c in manifest.components)


def test_a_misplaced_component_is_detected_and_retried_until_constructed(
    build: Path, bus: str, tmp_path: Path
) -> None:
    manifest = read_manifest(build)
    beam = next(c.guid for c in manifest.components if c.ifc_class == "IfcBeam")
    options = BusOptions(connect=(bus,))
    with (
        RobotStandIn(manifest, options, misplace_first_attempt=frozenset({beam})) as robots,
        _services(build, bus, tmp_path) as (agents, planner),
    ):
        assert _finish(planner, agents) == 0, planner.log()[-3000:]
    beam_states = [s for s in robots.record.states if s.guid == beam and s.previous is not None]
    sequence = [s.state for s in beam_states]
    assert ComponentState.MISPLACED in sequence
    misplaced_at = sequence.index(ComponentState.MISPLACED)
    assert sequence[misplaced_at + 1] == ComponentState.RELEASED  # retried
    assert sequence[-1] == ComponentState.CONSTRUCTED
    misplaced = beam_states[misplaced_at]
    assert misplaced.position_error_m is not None and misplaced.position_error_m == pytest.approx(
        0.05, abs=1e-6
    )
    assert robots.record.placements[beam] == 2
    _assert_complete_in_support_order(manifest, robots.record.states)


def test_killing_the_agent_process_mid_run_and_restarting_it_loses_nothing(
    build: Path, bus: str, tmp_path: Path
) -> None:
    manifest = read_manifest(build)
    with (
        RobotStandIn(manifest, BusOptions(connect=(bus,))) as robots,
        _services(build, bus, tmp_path) as (agents, planner),
    ):
        assert wait_until(lambda: len(_constructed_order(robots.record.states)) >= 8, bound_s(60.0)), (
            agents.log()[-3000:]
        )
        agents.kill()
        time.sleep(1.0)
        before_kill = set(_constructed_order(robots.record.states))
        restarted = _agents(build, bus, tmp_path, name="agents-restarted")
        try:
            assert _finish(planner, restarted) == 0, planner.log()[-3000:]
            twins = _all_twins(manifest, bus)
        finally:
            restarted.stop()
    # the twins' histories (the journal) are the record: a transition journaled just before the kill may
    # never have been published (the restarted agent then only announces its state)
    journaled = sorted(
        (r for twin in twins for r in twin.history), key=lambda r: (r.sim_time_s, r.wall_time_s)
    )
    _assert_complete_in_support_order(manifest, journaled)
    published = _constructed_order(robots.record.states)
    assert len(published) == len(set(published)), "a component constructed twice on the bus"
    assert {twin.guid for twin in twins} == {c.guid for c in manifest.components}
    assert all(twin.state == ComponentState.CONSTRUCTED for twin in twins)
    for twin in twins:  # the restarted process knows what happened before the kill (its journal)
        if twin.guid in before_kill:
            assert [record.state for record in twin.history][-1] == ComponentState.CONSTRUCTED
            assert len(twin.history) >= 6


def test_a_thousand_garbage_payloads_on_subscribed_keys_crash_nothing(
    build: Path, bus: str, tmp_path: Path
) -> None:
    manifest = read_manifest(build)
    rng = random.Random(7)
    site = manifest.site
    keys = [
        f"bimbot/{site}/components/{manifest.components[0].key}/event",
        f"bimbot/{site}/components/{manifest.components[1].key}/pose",
        f"bimbot/{site}/components/{manifest.components[2].key}/state",
        f"bimbot/{site}/robots/r1/state",
        f"bimbot/{site}/clock",
        f"bimbot/{site}/tasks/T0001",
    ]
    payloads = [
        lambda: os.urandom(rng.randint(0, 200)),
        lambda: b'{"schema_version": 1, "guid": 5}',
        lambda: b'{"schema_version": 99}',
        lambda: b"[" * 1000,
        lambda: b'{"sim_time_s": "' + b"x" * 100_000 + b'"}',
        lambda: b'{"robot_id": "r1", "v_mps": 1.0, "w_radps": 0.0, "sim_time_s": 0.0, "schema_version": 1}',
    ]
    with (
        open_session(BusOptions(connect=(bus,))) as session,
        RobotStandIn(manifest, BusOptions(connect=(bus,))) as robots,
        _services(build, bus, tmp_path) as (agents, planner),
    ):
        assert wait_until(lambda: len(_constructed_order(robots.record.states)) >= 3, bound_s(60.0))
        for index in range(1000):
            session.put(keys[index % len(keys)], payloads[index % len(payloads)]())
        assert _finish(planner, agents) == 0, planner.log()[-3000:]
        assert agents.alive()
    _assert_complete_in_support_order(manifest, robots.record.states)
    assert "invalid payload" in agents.log() and "invalid payload" in planner.log()
