"""Benchmark of the smart-component agents: 10,000 agents on one machine, over a real Zenoh bus.

Run: ``.venv/bin/python bench/agents.py`` (``--components``, ``--processes``, ``--events`` to vary).

Input: a synthetic manifest made in code. One steel beam component (the shape of a converted one) is
replicated with deterministic random GlobalIds on a grid of target poses. No conversion is run, because
the agents only read the manifest. Then:

1. a router (``bimbot bus``) and the agent processes (``bimbot agents --shard i/P``) start as subprocesses;
   time until all N liveliness tokens are seen by a subscriber in this process (target ≤ 30 s);
2. resident memory per agent: (Σ RSS of the agent processes − P × RSS of a 1-agent process) / N;
3. latency from a state change to a subscriber in another process. This process sends ``release`` events
   at a steady rate to a sample of components; each agent stamps ``wall_time_s`` when it changes state,
   and this process subtracts it from the arrival time (same host clock) (target p99 ≤ 20 ms). The event →
   state round trip is printed too;
4. the raw Zenoh round trip in the same run, for reference: ping → a pong process → back, with
   payloads the size of a state message;
5. a burst: ``release`` to every remaining component at once, and the time until every state has arrived.

Times depend on the machine; the bench prints its core count.
"""

from __future__ import annotations

import argparse
import os
import queue
import random
import signal
import subprocess
import sys
import tempfile
import threading
import time
import uuid
from collections.abc import Callable
from pathlib import Path

import ifcopenshell.guid
import zenoh

from bimbot.shared.bus import BusOptions, encode, open_session
from bimbot.shared.identifiers import guid_to_folder, guid_to_key
from bimbot.shared.manifest import (
    BoundingBox,
    CollisionMethod,
    Component,
    ComponentFiles,
    Inertia,
    InertiaSource,
    Manifest,
    MassSource,
    Pose,
    SourceModel,
    write_manifest,
)
from bimbot.shared.messages import (
    ALIVE_KEY,
    COMPONENT_EVENT_KEY,
    COMPONENT_STATE_KEY,
    ComponentEvent,
    ComponentEventMsg,
    ComponentStateMsg,
    key,
)
from bimbot.supervisor import free_port

ALIVE_TARGET_S = 30.0
P99_TARGET_S = 0.020
SITE = "bench-site"
PING_KEY = "bimbot/bench/ping"
PONG_KEY = "bimbot/bench/pong"


def beam(guid: str, x_m: float, y_m: float) -> Component:
    """A 3 m steel beam (IPE-like mass and inertia) with its target at (x, y, 3 m)."""
    folder = guid_to_folder(guid)
    model_dir = f"models/{folder}"
    return Component(
        guid=guid,
        key=guid_to_key(guid),
        folder=folder,
        ifc_class="IfcBeam",
        name="Beam",
        storey="Level 1",
        material="S275",
        target_pose_world=Pose(
            position_m=(x_m, y_m, 3.0), quat_xyzw=(0.0, 0.0, 0.0, 1.0), rpy_rad=(0.0, 0.0, 0.0)
        ),
        bbox_world=BoundingBox(min_m=(x_m, y_m, 3.0), max_m=(x_m + 3.0, y_m + 0.1, 3.2)),
        bbox_local=BoundingBox(min_m=(0.0, 0.0, 0.0), max_m=(3.0, 0.1, 0.2)),
        volume_m3=0.0085,
        watertight=True,
        mass_kg=66.7,
        mass_source=MassSource.MATERIAL_DENSITY_TABLE,
        com_local_m=(1.5, 0.05, 0.1),
        inertia_kg_m2=Inertia(ixx=0.05, ixy=0.0, ixz=0.0, iyy=50.1, iyz=0.0, izz=50.0),
        inertia_source=InertiaSource.MESH,
        collision_method=CollisionMethod.PROFILE_DECOMPOSITION,
        collision_parts=3,
        files=ComponentFiles(
            model_dir=model_dir,
            sdf_file=f"{model_dir}/model.sdf",
            config_file=f"{model_dir}/model.config",
            split_ifc=f"{model_dir}/{guid}.ifc",
            visual_dae=f"{model_dir}/meshes/visual.dae",
            visual_obj=f"{model_dir}/meshes/visual.obj",
            visual_glb=f"{model_dir}/meshes/visual.glb",
            collision=[f"{model_dir}/meshes/collision_{i}.obj" for i in range(3)],
        ),
    )


def synthetic_manifest(count: int, seed: int = 20) -> Manifest:
    rng = random.Random(seed)
    guids = [ifcopenshell.guid.compress(uuid.UUID(int=rng.getrandbits(128)).hex) for _ in range(count)]
    side = max(1, int(count**0.5))
    return Manifest(
        generator="bench/agents.py",
        site=SITE,
        source=SourceModel(path="synthetic.ifc", schema_name="IFC4", sha256="0" * 64, length_unit_m=1.0),
        local_origin_m=(0.0, 0.0, 0.0),
        world_file=f"worlds/{SITE}.world",
        sequence_file="sequence.xml",
        sequence_source="derived",
        components=[beam(guid, 4.0 * (i % side), 4.0 * (i // side)) for i, guid in enumerate(guids)],
    )


def rss_bytes(pid: int) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) * 1024
    return 0


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, max(0, round(q / 100 * (len(ordered) - 1))))]


def cli(*args: str, log: Path) -> subprocess.Popen[bytes]:
    with log.open("ab") as out:
        return subprocess.Popen([sys.executable, "-m", "bimbot.cli", "-q", *args], stdout=out, stderr=out)


def stop(proc: subprocess.Popen[bytes], timeout_s: float = 20.0) -> float:
    """SIGTERM, wait; seconds it took."""
    started = time.perf_counter()
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout_s)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    return time.perf_counter() - started


class Watcher:
    """Liveliness tokens and state messages seen by this process (callbacks only enqueue)."""

    def __init__(self, session: zenoh.Session, site: str) -> None:
        self.items: queue.Queue[tuple[str, float, object]] = queue.Queue()
        self.alive: set[str] = set()
        self.states: list[tuple[float, bytes]] = []
        self._declarations = [
            session.liveliness().declare_subscriber(
                key(ALIVE_KEY, site=site, kind="component", id="*"),
                lambda s: self.items.put(("alive", 0.0, (str(s.key_expr), s.kind == zenoh.SampleKind.PUT))),
                history=True,
            ),
            session.declare_subscriber(
                key(COMPONENT_STATE_KEY, site=site, key="*"),
                lambda s: self.items.put(("state", time.time(), s.payload.to_bytes())),
            ),
        ]

    def pump_until(self, condition: Callable[[], bool], timeout_s: float) -> bool:
        deadline = time.monotonic() + timeout_s
        while not condition():
            try:
                tag, stamp, item = self.items.get(timeout=max(0.0, min(0.05, deadline - time.monotonic())))
            except queue.Empty:
                if time.monotonic() >= deadline:
                    return False
                continue
            if tag == "alive":
                name, alive = item  # type: ignore[misc]
                (self.alive.add if alive else self.alive.discard)(name)
            else:
                self.states.append((stamp, item))  # type: ignore[arg-type]
        return True


def wait_alive(watcher: Watcher, count: int, timeout_s: float) -> float | None:
    started = time.perf_counter()
    ok = watcher.pump_until(lambda: len(watcher.alive) >= count, timeout_s)
    return time.perf_counter() - started if ok else None


def release_messages(manifest: Manifest, indices: list[int]) -> list[tuple[str, str, ComponentEventMsg]]:
    out = []
    for index in indices:
        component = manifest.components[index]
        message = ComponentEventMsg(
            guid=component.guid,
            event=ComponentEvent.RELEASE,
            source="bench",
            event_id=f"bench-{index}",
            sim_time_s=1.0,
            wall_time_s=0.0,
        )
        out.append((component.guid, key(COMPONENT_EVENT_KEY, site=SITE, key=component.key), message))
    return out


def measure_latency(
    session: zenoh.Session, watcher: Watcher, manifest: Manifest, indices: list[int], rate_hz: float
) -> tuple[list[float], list[float], int]:
    """(state change → subscriber, event → state round trip, missing) in seconds, for paced releases."""
    sent_at: dict[str, float] = {}
    period = 1.0 / rate_hz
    watcher.states.clear()
    next_time = time.perf_counter()
    for guid, key_expr, message in release_messages(manifest, indices):
        while time.perf_counter() < next_time:
            watcher.pump_until(lambda: True, 0)  # keep draining (cheap)
            time.sleep(min(0.0005, max(0.0, next_time - time.perf_counter())))
        stamped = message.model_copy(update={"wall_time_s": time.time()})
        sent_at[guid] = stamped.wall_time_s
        session.put(key_expr, encode(stamped))
        next_time += period
    released: dict[str, tuple[float, ComponentStateMsg]] = {}
    parsed = 0

    def all_released() -> bool:
        nonlocal parsed
        for stamp, payload in watcher.states[parsed:]:
            parsed += 1
            msg = ComponentStateMsg.model_validate_json(payload)
            if msg.event == "release" and msg.guid in sent_at:
                released[msg.guid] = (stamp, msg)
        return len(released) >= len(sent_at)

    watcher.pump_until(all_released, 30.0)
    one_way = [stamp - msg.wall_time_s for stamp, msg in released.values()]
    round_trip = [stamp - sent_at[guid] for guid, (stamp, _) in released.items()]
    return one_way, round_trip, len(sent_at) - len(released)


def pong(endpoint: str) -> int:
    """The echo side of the raw round trip (``--pong ENDPOINT``), run as its own process."""
    stop_event = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop_event.set())
    with open_session(BusOptions(connect=(endpoint,))) as session:
        publisher = session.declare_publisher(PONG_KEY)
        _sub = session.declare_subscriber(PING_KEY, lambda s: publisher.put(s.payload))  # echo only, no state
        session.liveliness().declare_token("bimbot/bench/alive/pong")
        stop_event.wait()
    return 0


def raw_round_trip(session: zenoh.Session, count: int, size: int) -> list[float]:
    replies: queue.Queue[float] = queue.Queue()
    _sub = session.declare_subscriber(PONG_KEY, lambda s: replies.put(time.perf_counter()))
    publisher = session.declare_publisher(PING_KEY)
    payload = b"x" * size
    times = []
    for _ in range(count):
        started = time.perf_counter()
        publisher.put(payload)
        try:
            times.append(replies.get(timeout=2.0) - started)
        except queue.Empty:
            continue
    _sub.undeclare()
    publisher.undeclare()
    return times


def line(label: str, value: str, target: str = "", ratio: float | None = None) -> None:
    extra = f"   target {target}, ratio {ratio:.2f}" if ratio is not None else ""
    sys.stdout.write(f"{label:<44} {value}{extra}\n")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--components", type=int, default=10_000)
    parser.add_argument("--processes", type=int, default=2)
    parser.add_argument(
        "--events", type=int, default=2_000, help="paced release events for the latency figures"
    )
    parser.add_argument("--rate-hz", type=float, default=500.0, help="pace of those events")
    parser.add_argument("--pings", type=int, default=2_000)
    parser.add_argument(
        "--mode",
        choices=("client", "peer"),
        default="peer",
        help="Zenoh mode of the agent processes (default peer, as every service; client: all via the router)",
    )
    parser.add_argument("--pong", metavar="ENDPOINT", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.pong:
        return pong(args.pong)

    work = Path(tempfile.mkdtemp(prefix="bench_agents_"))
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    log = work / "processes.log"
    started = time.perf_counter()
    manifest = synthetic_manifest(args.components)
    write_manifest(manifest, work)
    base_dir = work / "baseline"
    base_dir.mkdir()
    write_manifest(synthetic_manifest(1, seed=99), base_dir)
    sys.stdout.write(
        f"agents bench: {args.components} agents in {args.processes} {args.mode}-mode processes, "
        f"{os.cpu_count()} cores; "
        f"synthetic manifest ({(work / 'manifest.json').stat().st_size / 1e6:.1f} MB) "
        f"written in {time.perf_counter() - started:.1f} s; logs in {log}\n"
    )
    procs: list[subprocess.Popen[bytes]] = []
    router = cli("bus", "--listen", endpoint, log=log)
    try:
        with open_session(BusOptions(connect=(endpoint,))) as session:
            watcher = Watcher(session, SITE)
            # A 1-agent process (same site): the fixed cost of an agent process (interpreter, zenoh, …).
            baseline = cli(
                "agents", "--build", str(base_dir), "--connect", endpoint, "--mode", args.mode, log=log
            )
            wait_alive(watcher, 1, 30.0)
            time.sleep(1.0)
            baseline_rss = rss_bytes(baseline.pid)
            stop(baseline)
            watcher.pump_until(lambda: not watcher.alive, 10.0)
            watcher.states.clear()

            t0 = time.perf_counter()
            for shard in range(1, args.processes + 1):
                procs.append(
                    cli(
                        "agents",
                        "--build",
                        str(work),
                        "--shard",
                        f"{shard}/{args.processes}",
                        "--connect",
                        endpoint,
                        log=log,
                    )
                )
            alive_s = wait_alive(watcher, args.components, 120.0)
            if alive_s is not None:
                alive_s = time.perf_counter() - t0
            time.sleep(1.0)
            rss = [rss_bytes(proc.pid) for proc in procs]
            per_agent = (sum(rss) - args.processes * baseline_rss) / args.components

            rng = random.Random(5)
            order = list(range(args.components))
            rng.shuffle(order)
            sample, rest = order[: args.events], order[args.events :]
            one_way, round_trip, missing = measure_latency(session, watcher, manifest, sample, args.rate_hz)

            with subprocess.Popen(
                [sys.executable, __file__, "--pong", endpoint],
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
            ) as echo:
                ready = list(session.liveliness().get("bimbot/bench/alive/**", timeout=5))
                deadline = time.monotonic() + 10
                while not ready and time.monotonic() < deadline:
                    time.sleep(0.2)
                    ready = list(session.liveliness().get("bimbot/bench/alive/**", timeout=5))
                time.sleep(0.3)
                state_size = len(watcher.states[0][1]) if watcher.states else 300
                rtt = raw_round_trip(session, args.pings, state_size)
                stop(echo)

            watcher.states.clear()
            burst_start = time.perf_counter()
            for _, key_expr, message in release_messages(manifest, rest):
                session.put(key_expr, encode(message.model_copy(update={"wall_time_s": time.time()})))
            got = watcher.pump_until(lambda: len(watcher.states) >= len(rest), 60.0)
            burst_s = time.perf_counter() - burst_start

            stop_s = [stop(proc) for proc in procs]
            procs.clear()

        sys.stdout.write("\n")
        if alive_s is None:
            line("all agents alive", f"NOT within 120 s ({len(watcher.alive)} seen)")
        else:
            line(
                f"all {args.components} agents alive",
                f"{alive_s:.2f} s",
                f"≤ {ALIVE_TARGET_S:g} s",
                alive_s / ALIVE_TARGET_S,
            )
        line("RSS of the agent processes", " + ".join(f"{r / 1e6:.0f} MB" for r in rss))
        line("RSS of a 1-agent process (fixed cost)", f"{baseline_rss / 1e6:.0f} MB")
        line("resident memory per agent", f"{per_agent / 1e3:.1f} KB")
        if one_way:
            p50, p99 = percentile(one_way, 50), percentile(one_way, 99)
            line(f"state change → subscriber, p50 ({len(one_way)} changes)", f"{p50 * 1e3:.2f} ms")
            line(
                "state change → subscriber, p99",
                f"{p99 * 1e3:.2f} ms",
                f"≤ {P99_TARGET_S * 1e3:g} ms",
                p99 / P99_TARGET_S,
            )
            line("state change → subscriber, max", f"{max(one_way) * 1e3:.2f} ms")
            line(
                "event → state round trip, p50 / p99",
                f"{percentile(round_trip, 50) * 1e3:.2f} / {percentile(round_trip, 99) * 1e3:.2f} ms",
            )
        line("state changes missing", str(missing))
        if rtt:
            rtt_p50, rtt_p99 = percentile(rtt, 50), percentile(rtt, 99)
            line(
                f"raw Zenoh round trip, p50 / p99 ({len(rtt)} pings)",
                f"{rtt_p50 * 1e3:.2f} / {rtt_p99 * 1e3:.2f} ms",
            )
            if one_way:
                line(
                    "  one-way ≈ RTT/2, p50; agent p50 / that",
                    f"{rtt_p50 / 2 * 1e3:.2f} ms; {p50 / (rtt_p50 / 2):.1f}×",
                )
        rate = len(rest) / burst_s if got and burst_s > 0 else 0.0
        line(
            f"burst: {len(rest)} releases at once",
            f"all states in {burst_s:.2f} s ({rate:.0f}/s)"
            if got
            else f"{len(watcher.states)} states in 60 s",
        )
        line("SIGTERM → exit, per process", ", ".join(f"{s:.2f} s" for s in stop_s))
        return 0
    finally:
        for proc in procs:
            stop(proc)
        stop(router)


if __name__ == "__main__":
    sys.exit(main())
