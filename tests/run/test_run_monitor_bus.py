"""The run monitor over a real (loopback) Zenoh bus: a forged ``constructed`` changes nothing unless the
component's twin says so, and the end-of-run audit asks every twin and physics' poses.

Three peer sessions: the agents' side (a twin queryable answering from a dict, as the agents would), a
forger publishing state messages, and the run's monitor; physics' ``physics/poses`` is a small queryable
on the agents' session.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

import pytest
import zenoh
from run_builders import GUIDS, manifest, poses, state, twin, walk
from wall_clock import bound_s

from bimbot.run.monitor import RunMonitor
from bimbot.shared.bus import BusOptions, encode, open_session
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import (
    COMPONENT_STATE,
    COMPONENT_TWIN,
    PHYSICS_POSES,
    ROBOT_STATE,
    ComponentState,
    ComponentStateMsg,
    RobotState,
    RobotStateMsg,
    SitePosesMsg,
    TwinMsg,
)
from bimbot.shared.report.fleet import lane_label
from bimbot.supervisor import free_port

S = ComponentState
SITE_MANIFEST = manifest()
BEAM, OTHER = GUIDS[0], GUIDS[1]


@dataclass
class FakeSite:
    """What the agents' twins and physics say; the queryables answer from here (tests set it)."""

    twins: dict[str, TwinMsg] = field(default_factory=dict)
    poses: SitePosesMsg | None = None
    twin_queries: int = 0
    lock: threading.Lock = field(default_factory=threading.Lock)

    def answer_twins(self, query: zenoh.Query) -> None:
        with self.lock:
            self.twin_queries += 1
            twins = list(self.twins.values())
        for item in twins:
            reply_key = COMPONENT_TWIN.key(site=SITE_MANIFEST.site, key=item.key)
            if query.key_expr.intersects(zenoh.KeyExpr(reply_key)):
                query.reply(reply_key, encode(item))

    def answer_poses(self, query: zenoh.Query) -> None:
        if self.poses is not None:
            query.reply(PHYSICS_POSES.key(site=SITE_MANIFEST.site), encode(self.poses))


@contextmanager
def _bus(robot_types: dict[str, str] | None = None) -> Iterator[tuple[FakeSite, zenoh.Session, RunMonitor]]:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    site = FakeSite(twins={guid: twin(SITE_MANIFEST, guid, S.PLANNED) for guid in GUIDS})
    with (
        open_session(BusOptions(connect=(), listen=(endpoint,))) as agents,
        open_session(BusOptions(connect=(endpoint,))) as forger,
        open_session(BusOptions(connect=(endpoint,))) as run,
    ):
        twins = agents.declare_queryable(
            COMPONENT_TWIN.key(site=SITE_MANIFEST.site, key="*"), site.answer_twins, complete=False
        )
        physics = agents.declare_queryable(PHYSICS_POSES.key(site=SITE_MANIFEST.site), site.answer_poses)
        monitor = RunMonitor(SITE_MANIFEST, run, robot_types=robot_types)
        time.sleep(0.5)  # the sessions meet
        try:
            yield site, forger, monitor
        finally:
            twins.undeclare()
            physics.undeclare()


def _publish(session: zenoh.Session, site_manifest: Manifest, message: ComponentStateMsg) -> None:
    key = COMPONENT_STATE.key(site=site_manifest.site, key=site_manifest.component(message.guid).key)
    session.put(key, encode(message))


def _drain_until(monitor: RunMonitor, done: Callable[[], bool], timeout_s: float = 5.0) -> bool:
    """Take the monitor's input until ``done``, at most ``timeout_s`` on the reference machine (scaled)."""
    deadline = time.monotonic() + bound_s(timeout_s)
    while time.monotonic() < deadline:
        monitor.drain(wait_s=0.05)
        if done():
            return True
    return False


def test_forged_constructed_messages_count_nothing_until_the_twin_says_so() -> None:
    with _bus() as (site, forger, monitor):
        with site.lock:
            site.twins[BEAM] = twin(SITE_MANIFEST, BEAM, S.VERIFYING)
        for message in walk(BEAM, S.VERIFYING):  # the real agent's steps, as hints
            _publish(forger, SITE_MANIFEST, message)
        for guid in GUIDS:  # forgeries: an announcement, an illegal jump, a plausible verdict
            for forged in (
                state(guid, S.CONSTRUCTED, None, "resume"),
                state(guid, S.CONSTRUCTED, S.PLANNED, "verified"),
                state(guid, S.CONSTRUCTED, S.VERIFYING, "verified"),
            ):
                _publish(forger, SITE_MANIFEST, forged)
        assert _drain_until(monitor, lambda: site.twin_queries >= len(GUIDS))
        _drain_until(monitor, lambda: False, timeout_s=0.5)  # the twins' answers come back
        assert monitor.constructed == 0 and monitor.states[BEAM] == S.VERIFYING
        assert monitor.report()["totals"]["constructed"] == 0
        assert monitor.trusted.rejected >= len(GUIDS)  # planned → constructed is not in the table

        with site.lock:
            site.twins[BEAM] = twin(SITE_MANIFEST, BEAM, S.CONSTRUCTED)
        _publish(forger, SITE_MANIFEST, walk(BEAM, S.CONSTRUCTED)[-1])  # the agent's verdict
        assert _drain_until(monitor, lambda: monitor.constructed == 1, timeout_s=5.0)
        report = monitor.report()
        beam = next(c for c in report["components"] if c["guid"] == BEAM)
        assert beam["state"] == "constructed" and beam["constructed_s"] == 6.0
        assert report["totals"]["constructed"] == 1


def test_the_audit_confirms_every_twin_and_names_a_constructed_component_physics_has_moved() -> None:
    with _bus() as (site, forger, monitor):
        with site.lock:
            site.twins[BEAM] = twin(SITE_MANIFEST, BEAM, S.CONSTRUCTED)
            site.twins[OTHER] = twin(SITE_MANIFEST, OTHER, S.CONSTRUCTED)
        site.poses = poses(SITE_MANIFEST, moved={BEAM: ((0.0, 0.02, 0.0), 0.0)})
        _publish(forger, SITE_MANIFEST, state(GUIDS[2], S.CONSTRUCTED, None, "resume"))  # a forgery
        _drain_until(monitor, lambda: False, timeout_s=0.5)
        started = time.monotonic()
        audit = monitor.audit(timeout_s=(timeout_s := bound_s(5.0)))
        assert (
            time.monotonic() - started < 0.6 * timeout_s
        )  # every twin answered at once: no waiting for the bound
        assert monitor.constructed == 2 and audit.checked == 2
        assert audit.wrong == (BEAM,) and "20.0 mm" in audit.errors[0]
        report = monitor.report()
        assert report["totals"]["constructed"] == 2 and report["totals"]["as_built_errors"] == 1
        assert report["totals"]["max_final_position_error_mm"] == pytest.approx(20.0)


def test_without_a_physics_answer_the_audit_ends_within_its_bound_and_reports_nulls() -> None:
    with _bus() as (site, _forger, monitor):
        started = time.monotonic()
        audit = monitor.audit(timeout_s=1.5)
        assert time.monotonic() - started < 1.5 + bound_s(2.5)  # its bound, and the answers' way back
        assert not audit.answered and site.twin_queries >= 1
        report = monitor.report()
        assert report["as_built"]["answered"] is False
        assert all(c["final_position_error_mm"] is None for c in report["components"])


@pytest.mark.parametrize("fleet_types", [{"r1": "carrier"}, None])
def test_a_robot_heard_before_physics_site_info_has_the_type_the_run_started_it_with(
    fleet_types: dict[str, str] | None,
) -> None:
    """A run that ends before physics' site info reaches the monitor still names its robots' types (from
    the fleet it started); without them the report could only say ``robot r1``."""
    with _bus(fleet_types) as (_site, forger, monitor):
        message = RobotStateMsg(
            robot_id="r1", state=RobotState.IDLE, pose_xy_yaw=(0.0, 0.0, 0.0), sim_time_s=1.0, wall_time_s=0.0
        )
        forger.put(ROBOT_STATE.key(site=SITE_MANIFEST.site, robot_id="r1"), encode(message))
        assert _drain_until(monitor, lambda: "r1" in monitor.report()["robots"])
        robot = monitor.report()["robots"]["r1"]
    if fleet_types is None:
        assert robot["type"] is None and lane_label("r1", robot) == "robot r1"
    else:
        assert robot["type"] == "carrier" and lane_label("r1", robot) == "r1 (carrier)"


def test_the_run_sim_time_is_the_latest_any_message_was_said_at() -> None:
    """In plan fidelity the clock jumps and its own messages lag the work they let happen: the Revit hub's
    summary said 1,633,498 s of sim time for a makespan of 1,953,578 s. A robot heard at a later time than
    any clock moves the run's sim time on."""
    with _bus() as (_site, forger, monitor):
        message = RobotStateMsg(
            robot_id="r1",
            state=RobotState.IDLE,
            pose_xy_yaw=(0.0, 0.0, 0.0),
            sim_time_s=500.0,
            wall_time_s=0.0,
        )
        forger.put(ROBOT_STATE.key(site=SITE_MANIFEST.site, robot_id="r1"), encode(message))
        assert _drain_until(monitor, lambda: monitor.sim_time_s >= 500.0)
        assert monitor.sim_time_s == 500.0


def test_the_end_of_timed_work_a_robot_said_stays_awaited_when_its_next_state_says_none() -> None:
    """The plan fidelity's clock jumps to a pour's end at once, and the robot's next state (the end asked
    of physics: no end said) can come in the same batch before the watchdog looks: the restaurant's run
    ended 'stalled' 0.6 s of sim time before a 6,865 s pour ended. What any state said is kept."""
    with _bus() as (_site, _forger, monitor):
        pouring = RobotStateMsg(
            robot_id="r5",
            state=RobotState.WORK_IN_PLACE,
            task_id="T0059",
            pose_xy_yaw=(0.0, 0.0, 0.0),
            sim_time_s=2_058_172.7,
            wall_time_s=0.0,
            busy_until_s=2_065_037.7,
        )
        monitor.apply(pouring)
        monitor.apply(pouring.model_copy(update={"sim_time_s": 2_065_036.9, "busy_until_s": None}))
        assert monitor.awaited_sim_s() == 2_065_037.7
