"""``bimbot physics`` as a process on a real Zenoh bus: info, clock, sensors, lock-step driving, an attach
refusal with its reason, garbage on every input, and a quick clean exit on SIGTERM."""

from __future__ import annotations

import contextlib
import os
import queue
import re
import shutil
import signal
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
import zenoh
from fleets import ground_fleet_file
from wall_clock import bound_s

from bimbot.shared.bus import BusOptions, InvalidPayloads, decode, encode, open_session
from bimbot.shared.fleet import default_fleet
from bimbot.shared.manifest import read_manifest
from bimbot.shared.messages import (
    ALIVE_KEY,
    CLOCK_KEY,
    PHYSICS_ATTACH_KEY,
    PHYSICS_INFO_KEY,
    PHYSICS_PLACE_KEY,
    PLANNER_PREPARING_KEY,
    ROBOT_CMD_VEL_KEY,
    ROBOT_POSE_KEY,
    ROBOT_SENSORS_KEY,
    AttachRequest,
    ClockMsg,
    CmdVelMsg,
    PhysicsReply,
    PreparingMsg,
    RobotPoseMsg,
    SensorsMsg,
    SiteInfoMsg,
    key,
)
from bimbot.supervisor import free_port, running

pytestmark = pytest.mark.integration

GARBAGE = 200


class _Listener:
    """Latest messages of a few keys, through queues (callbacks only enqueue)."""

    def __init__(self, session: zenoh.Session, keys: dict[str, str]) -> None:
        self.queues: dict[str, queue.Queue[bytes]] = {name: queue.Queue() for name in keys}
        self._subscribers = [
            session.declare_subscriber(
                key_expr, lambda sample, q=self.queues[name]: q.put(sample.payload.to_bytes())
            )
            for name, key_expr in keys.items()
        ]

    def next(self, name: str, timeout_s: float = 5.0) -> bytes:
        return self.queues[name].get(timeout=bound_s(timeout_s))

    def drain(self, name: str) -> list[bytes]:
        items = []
        while not self.queues[name].empty():
            items.append(self.queues[name].get_nowait())
        return items


def _get(
    session: zenoh.Session, key_expr: str, payload: bytes | None = None, timeout_s: float = 5.0
) -> bytes | None:
    for reply in session.get(key_expr, payload=payload, timeout=bound_s(timeout_s)):
        if reply.ok is not None:
            return reply.ok.payload.to_bytes()
    return None


def _robot_r1_up(session: zenoh.Session, site: str) -> zenoh.LivelinessToken:
    """Robot r1 comes up: its liveliness token (returned) and its answer to clock step 0."""
    token = session.liveliness().declare_token(key(ALIVE_KEY, site=site, kind="robot", id="r1"))
    cmd_key = key(ROBOT_CMD_VEL_KEY, site=site, robot_id="r1")
    session.put(cmd_key, encode(CmdVelMsg(robot_id="r1", v_mps=0.0, w_radps=0.0, sim_time_s=0.0, step=0)))
    return token


@contextlib.contextmanager
def _physics_holding(
    bundled_build: Path, tmp_path: Path, wait_s: float, planner: bool
) -> Iterator[tuple[zenoh.Session, _Listener, str]]:
    """Physics in lock-step on a bus, holding its clock at 0 for the robots (``--wait-for-robots-s``) and,
    with ``planner``, the planner; up (it answered ``physics/info``) when this yields a session, a listener
    of its clock and the site."""
    build = tmp_path / "build"
    shutil.copytree(bundled_build, build)
    site = read_manifest(build).site
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    fleet = str(ground_fleet_file(tmp_path))
    physics_args = ["physics", "--build", str(build), "--fleet", fleet, "--connect", endpoint, "--rtf", "0"]
    physics_args += ["--listen", "tcp/127.0.0.1:0", "--lock-step", "--wait-for-robots-s", f"{wait_s:.1f}"]
    physics_args += ["--wait-for-planner"] if planner else []
    with (
        running("bus", ["bus", "--listen", endpoint], tmp_path),
        running("physics", physics_args, tmp_path) as physics,
        open_session(BusOptions(connect=(endpoint,), listen=())) as session,
    ):
        listener = _Listener(session, {"clock": key(CLOCK_KEY, site=site)})
        deadline = time.monotonic() + bound_s(60.0)
        while _get(session, key(PHYSICS_INFO_KEY, site=site), timeout_s=1.0) is None:
            assert physics.poll() is None and time.monotonic() < deadline, (
                tmp_path / "physics.log"
            ).read_text()
        yield session, listener, site


def _wait_clock(listener: _Listener, step: int, timeout_s: float = 5.0) -> ClockMsg:
    """The first clock at ``step`` or later; ``timeout_s`` is a bound on the reference machine (scaled)."""
    deadline = time.monotonic() + bound_s(timeout_s)
    while time.monotonic() < deadline:
        clock = ClockMsg.model_validate_json(
            listener.queues["clock"].get(timeout=deadline - time.monotonic())
        )
        if clock.step >= step:
            return clock
    raise AssertionError(f"no clock step {step}")


def test_physics_process_serves_the_site_in_lock_step_and_survives_garbage(
    bundled_build: Path, tmp_path: Path
) -> None:
    build = tmp_path / "build"
    shutil.copytree(bundled_build, build)
    manifest = read_manifest(build)
    site = manifest.site
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    fleet_file = str(ground_fleet_file(tmp_path))  # one robot of the default type
    physics_args = ["physics", "--build", str(build), "--fleet", fleet_file, "--connect", endpoint]
    physics_args += ["--listen", "tcp/127.0.0.1:0", "--lock-step", "--rtf", "0", "--odom-noise", "0"]
    with (
        running("bus", ["bus", "--listen", endpoint], tmp_path) as bus,
        running("physics", physics_args, tmp_path) as physics,
        open_session(BusOptions(connect=(endpoint,), listen=())) as session,
    ):
        deadline = time.monotonic() + bound_s(60.0)
        info_bytes = None
        while info_bytes is None and time.monotonic() < deadline:
            assert physics.poll() is None, (tmp_path / "physics.log").read_text()
            info_bytes = _get(session, key(PHYSICS_INFO_KEY, site=site), timeout_s=1.0)
        assert info_bytes is not None, (tmp_path / "physics.log").read_text()
        info = SiteInfoMsg.model_validate_json(info_bytes)
        assert info.robot_ids == ["r1"] and info.lock_step
        fleet = default_fleet()
        assert info.robot_type_of == {"r1": fleet.default_type}
        assert info.robot_types == {fleet.default_type: fleet.types[fleet.default_type]}
        reach_m = fleet.types[fleet.default_type].reach_m

        listener = _Listener(
            session,
            {
                "clock": key(CLOCK_KEY, site=site),
                "sensors": key(ROBOT_SENSORS_KEY, site=site, robot_id="r1"),
                "pose": key(ROBOT_POSE_KEY, site=site, robot_id="r1"),
            },
        )
        sensors = decode(SensorsMsg, "sensors", listener.next("sensors"), InvalidPayloads())  # binary
        assert sensors is not None and sensors.robot_id == "r1" and sensors.odom.robot_id == "r1"
        assert sensors.scan is not None and len(sensors.scan.ranges_m) == 360

        # the clock runs free while no robot is alive: a clock and a pose are heard before r1 comes up
        seen_clock, seen_pose = listener.next("clock"), listener.next("pose")

        # Lock-step: once r1 is alive, physics advances only when r1 answers the clock.
        token = session.liveliness().declare_token(key(ALIVE_KEY, site=site, kind="robot", id="r1"))
        time.sleep(0.5)
        step = max(ClockMsg.model_validate_json(m).step for m in [seen_clock, *listener.drain("clock")])
        start = RobotPoseMsg.model_validate_json([seen_pose, *listener.drain("pose")][-1]).pose_xy_yaw
        cmd_key = key(ROBOT_CMD_VEL_KEY, site=site, robot_id="r1")
        for _ in range(20):
            command = CmdVelMsg(robot_id="r1", v_mps=0.5, w_radps=0.0, sim_time_s=0.0, step=step)
            session.put(cmd_key, encode(command))
            step = _wait_clock(listener, step + 1).step
        time.sleep(0.5)  # no answer: physics waits (up to its 10 s timeout)
        # not one step further (step 0 may come again: physics repeats it once the robots are up)
        assert all(ClockMsg.model_validate_json(m).step <= step for m in listener.drain("clock"))
        # a robot (re)started now missed the open step: physics says it again while it waits, long before
        # its timeout (a restart would otherwise cost the whole bound)
        late = _Listener(session, {"sensors": key(ROBOT_SENSORS_KEY, site=site, robot_id="r1")})
        again = decode(SensorsMsg, "sensors", late.next("sensors", timeout_s=5.0), InvalidPayloads())
        assert again is not None and again.clock.step == step
        moved = RobotPoseMsg.model_validate_json(listener.drain("pose")[-1]).pose_xy_yaw
        assert moved[0] - start[0] == pytest.approx(0.5 * 2.0, abs=0.25)  # 20 periods of 0.1 s at 0.5 m/s

        footing = next(c for c in manifest.components if c.ifc_class == "IfcFooting")
        attach = AttachRequest(robot_id="r1", guid=footing.guid)
        reply = PhysicsReply.model_validate_json(
            _get(session, key(PHYSICS_ATTACH_KEY, site=site), encode(attach))
        )
        assert not reply.ok
        assert re.fullmatch(
            rf"robot r1 \({fleet.default_type}\) is \d+\.\d\d m from {re.escape(footing.guid)}, "
            rf"reach is {reach_m:g} m",
            reply.reason,
        )

        token.undeclare()  # r1 gone: physics runs free again
        for index in range(GARBAGE // 2):
            junk = [b"", b"{", os.urandom(16), b'{"robot_id": "r1"}', b"[]", encode(info)][index % 6]
            session.put(cmd_key, junk)
            session.put(key(ROBOT_CMD_VEL_KEY, site=site, robot_id="zz"), junk)
        for index in range(GARBAGE // 4):
            for request_key in (PHYSICS_ATTACH_KEY, PHYSICS_PLACE_KEY):
                answer = _get(session, key(request_key, site=site), os.urandom(8 + index % 5))
                assert answer is not None
                garbage_reply = PhysicsReply.model_validate_json(answer)
                assert not garbage_reply.ok and garbage_reply.reason.startswith("invalid ")
        stranger = CmdVelMsg(robot_id="zz", v_mps=1.0, w_radps=0.0, sim_time_s=0.0)
        blocking = zenoh.CongestionControl.BLOCK  # not dropped on a busy machine
        session.put(
            key(ROBOT_CMD_VEL_KEY, site=site, robot_id="zz"), encode(stranger), congestion_control=blocking
        )
        # physics says so once it has taken the stranger's command (at rtf 0 ten clock steps can pass
        # before the router has forwarded it, so wait for the line, not for a number of steps)
        stranger_logged = "robot 'zz' was not spawned by physics"
        deadline = time.monotonic() + bound_s(10.0)
        while stranger_logged not in (tmp_path / "physics.log").read_text() and time.monotonic() < deadline:
            time.sleep(0.05)
        seen = max([step, *(ClockMsg.model_validate_json(m).step for m in listener.drain("clock"))])
        assert _wait_clock(listener, seen + 10, timeout_s=10.0).step > step  # still running, past all of that
        assert physics.poll() is None and bus.poll() is None

        started = time.monotonic()
        physics.send_signal(signal.SIGTERM)
        assert physics.wait(bound_s(10)) == 0, (tmp_path / "physics.log").read_text()
        assert time.monotonic() - started < bound_s(5.0)
    log = (tmp_path / "physics.log").read_text()
    assert "invalid payload" in log and "Traceback" not in log
    assert log.count(stranger_logged) == 1


@pytest.mark.parametrize("planner", [False, True])
def test_physics_holds_its_clock_at_zero_until_the_robots_are_alive(
    bundled_build: Path, tmp_path: Path, planner: bool
) -> None:
    """And with ``--wait-for-planner`` (``bimbot run``) until the planner is alive too: on the 988-component
    site its start-up took 20 s of wall time while the idle site stepped 216 s of sim time."""
    with _physics_holding(bundled_build, tmp_path, bound_s(60), planner) as (session, listener, site):
        time.sleep(1.5)  # free-running, physics would be hundreds of steps on by now
        held = [ClockMsg.model_validate_json(m).step for m in listener.drain("clock")]
        assert set(held) <= {0}
        token = _robot_r1_up(session, site)
        tokens = [token]
        if planner:
            time.sleep(1.5)  # the robot is up, the planner is not: still held
            assert {ClockMsg.model_validate_json(m).step for m in listener.drain("clock")} <= {0}
            planner_key = key(ALIVE_KEY, site=site, kind="planner", id="main")
            tokens.append(session.liveliness().declare_token(planner_key))
        assert _wait_clock(listener, 1, timeout_s=10.0).step >= 1  # everyone is up: the clock runs
        for declared in tokens:
            declared.undeclare()
    waited_for = "robot r1 and the planner" if planner else "robot r1"
    assert f"holding the clock until {waited_for} are alive" in (tmp_path / "physics.log").read_text()


def test_a_planner_that_reports_its_preparation_keeps_the_clock_held_past_the_wait_bound(
    bundled_build: Path, tmp_path: Path
) -> None:
    """The wait for the planner is bounded for a planner nobody hears from: one that reports how far its
    preparation is (a large building's access check takes minutes) is waited for, each report starting the
    bound again; once the reports stop, the bound starts the clock as before."""
    wait_s = bound_s(2.0)
    with _physics_holding(bundled_build, tmp_path, wait_s, planner=True) as (session, listener, site):
        token = _robot_r1_up(session, site)
        preparing_key = key(PLANNER_PREPARING_KEY, site=site)
        reported_until = time.monotonic() + 1.6 * wait_s  # past the bound: it would have started by now
        done = 0
        while time.monotonic() < reported_until:  # the planner works: a report every half second
            session.put(preparing_key, encode(PreparingMsg(stage="access check", done=done, total=1000)))
            done += 1
            time.sleep(0.5)
        held = {ClockMsg.model_validate_json(m).step for m in listener.drain("clock")}
        assert held <= {0}, "the clock ran while the planner still reported its preparation"
        assert _wait_clock(listener, 1, timeout_s=2.0 + 10.0).step >= 1  # silent: the bound starts the clock
        token.undeclare()
    log = (tmp_path / "physics.log").read_text()
    assert "the planner not alive after" in log and "starting without them" in log
