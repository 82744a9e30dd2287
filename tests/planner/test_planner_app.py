"""The planner over a real (loopback) Zenoh bus, with the test playing the component agents and one robot.

Small smoke test: the full multi-process run with real agents and robots lives in the integration tests.
"""

from __future__ import annotations

import queue
import threading
import time
from pathlib import Path

import pytest
import zenoh
from planner_builders import portal_manifest, robot_msg, state_msg, twin_msg
from wall_clock import bound_s

from bimbot.cli import main as bimbot_main
from bimbot.command_line import build_parser
from bimbot.services.planner.app import PlannerOptions, main
from bimbot.services.planner.cli import plan_source
from bimbot.services.planner.skip_requests import SkipAnswer, bus_sender
from bimbot.services.planner.sources import PlanSource, SourceKind
from bimbot.shared.bus import BusOptions, Inbox, InvalidPayloads, decode, encode, open_session
from bimbot.shared.manifest import write_manifest
from bimbot.shared.messages import (
    ALIVE_KEY,
    COMPONENT_EVENT_KEY,
    COMPONENT_STATE_KEY,
    COMPONENT_TWIN_KEY,
    PHYSICS_SKIP,
    PLANNER_PREPARING_KEY,
    PROGRESS_KEY,
    ROBOT_STATE_KEY,
    TASK_KEY,
    ComponentEvent,
    ComponentEventMsg,
    ComponentState,
    PhysicsReply,
    PreparingMsg,
    ProgressMsg,
    SkipRequest,
    TaskMsg,
    TaskStatus,
    key,
)
from bimbot.shared.sequence import write_sequence
from bimbot.shared.service_runner import resolve_build
from bimbot.shared.support_graph import derive_sequence
from bimbot.supervisor import free_port

SITE = "test-site"


@pytest.fixture
def portal_build(tmp_path: Path) -> Path:
    manifest = portal_manifest()
    write_manifest(manifest, tmp_path)
    write_sequence(derive_sequence(manifest.components), tmp_path / "sequence.xml")
    return tmp_path


def test_planner_builds_the_portal_over_the_bus_and_exits_0(portal_build: Path) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    planner_bus = BusOptions(mode="peer", connect=(), listen=(endpoint,))
    options = PlannerOptions(
        exit_when_done=True,
        agents_timeout_s=bound_s(10.0),
        resend_s=0.5,
        twin_timeout_s=0.5,
        site_info_timeout_s=0.2,
    )
    stop = threading.Event()
    result: list[int] = []
    planner = threading.Thread(
        target=lambda: result.append(
            main(planner_bus, resolve_build(portal_build), options, PlanSource(), stop)
        ),
        daemon=True,
    )
    received: queue.Queue[tuple[str, bytes]] = queue.Queue()
    invalid = InvalidPayloads()
    guids = [item.guid for item in portal_manifest().components]
    constructed: list[str] = []
    progress: list[ProgressMsg] = []
    preparing: list[tuple[str, int]] = []  # (stage, components constructed when it was heard)
    twins = dict.fromkeys(guids, ComponentState.PLANNED)
    forged: set[str] = set()
    with open_session(BusOptions(mode="peer", connect=(endpoint,), listen=())) as session:
        twin_queryable = _serve_twins(session, twins)
        callback = lambda sample: received.put((str(sample.key_expr), sample.payload.to_bytes()))  # noqa: E731
        session.declare_subscriber(key(COMPONENT_EVENT_KEY, site=SITE, key="*"), callback)
        session.declare_subscriber(key(TASK_KEY, site=SITE, task_id="*"), callback)
        session.declare_subscriber(key(PROGRESS_KEY, site=SITE), callback)
        session.declare_subscriber(key(PLANNER_PREPARING_KEY, site=SITE), callback)
        tokens = [
            session.liveliness().declare_token(key(ALIVE_KEY, site=SITE, kind="component", id=guid))
            for guid in guids
        ]
        tokens.append(session.liveliness().declare_token(key(ALIVE_KEY, site=SITE, kind="robot", id="r1")))
        planner.start()
        try:
            deadline = time.monotonic() + bound_s(20.0)
            while planner.is_alive() and time.monotonic() < deadline:
                session.put(
                    key(ROBOT_STATE_KEY, site=SITE, robot_id="r1"), encode(robot_msg("r1", (0.0, 0.0)))
                )
                try:
                    where, payload = received.get(timeout=0.2)
                except queue.Empty:
                    continue
                if "/event" in where:
                    event = decode(ComponentEventMsg, where, payload, invalid)
                    if event is not None and event.event is ComponentEvent.RELEASE:
                        _publish_state(session, event.guid, ComponentState.RELEASED, twins)
                        if event.guid == "foot_a" and not forged:  # a forger claims the beam is built
                            forged.add("beam")
                            _publish_state(session, "beam", ComponentState.CONSTRUCTED)
                elif "/tasks/" in where:
                    task = decode(TaskMsg, where, payload, invalid)
                    if (
                        task is not None
                        and task.status is TaskStatus.ASSIGNED
                        and task.guid not in constructed
                    ):
                        assert task.robot_id == "r1"
                        constructed.append(task.guid)
                        _publish_state(session, task.guid, ComponentState.CONSTRUCTED, twins)
                elif where.endswith("/planner/preparing"):
                    said = decode(PreparingMsg, where, payload, invalid)
                    preparing.extend([(said.stage, len(constructed))] if said is not None else [])
                else:
                    message = decode(ProgressMsg, where, payload, invalid)
                    progress.extend([message] if message is not None else [])
        finally:
            stop.set()
            planner.join(timeout=bound_s(10.0))
            twin_queryable.undeclare()
            for token in tokens:
                token.undeclare()
        for where, payload in _drain(received, 0.5):
            if where.endswith("/progress"):
                message = decode(ProgressMsg, where, payload, invalid)
                progress.extend([message] if message is not None else [])
    assert result == [0]
    assert sorted(constructed) == sorted(guids)
    assert constructed.index("beam") > max(constructed.index("col_a"), constructed.index("col_b"))
    assert invalid.total == 0
    assert progress[-1].done and progress[-1].percent_constructed == 100.0 and progress[-1].total == 7
    # the planner told its preparation on the bus before it handed out work
    assert ("waiting for the component agents", 0) in preparing


def _drain(received: queue.Queue[tuple[str, bytes]], timeout_s: float) -> list[tuple[str, bytes]]:
    items = []
    try:
        while True:
            items.append(received.get(timeout=timeout_s))
    except queue.Empty:
        return items


def _publish_state(
    session: object, guid: str, state: ComponentState, twins: dict[str, ComponentState] | None = None
) -> None:
    """What an agent does on a state change: its twin says so (unless forged), then it publishes it."""
    if twins is not None:
        twins[guid] = state
    message = state_msg(guid, state, event="test", robot_id="r1")
    session.put(key(COMPONENT_STATE_KEY, site=SITE, key=guid), encode(message))  # type: ignore[attr-defined]


def _serve_twins(session: zenoh.Session, twins: dict[str, ComponentState]) -> zenoh.Queryable:
    """The test's component agents answer ``components/<key>/twin`` with the state they hold."""

    def answer(query: zenoh.Query) -> None:
        wanted = str(query.key_expr).split("/")[-2]
        for guid, state in list(twins.items()):
            if wanted in ("*", guid):
                reply_key = key(COMPONENT_TWIN_KEY, site=SITE, key=guid)
                query.reply(reply_key, encode(twin_msg(guid, state)))

    return session.declare_queryable(key(COMPONENT_TWIN_KEY, site=SITE, key="*"), answer)


def test_planner_cli_reports_an_unreadable_build_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert bimbot_main(["planner", "--build", str(tmp_path / "absent")]) == 2
    [line] = capsys.readouterr().err.splitlines()
    assert line.startswith("bimbot planner: error: ") and "absent" in line


def test_planner_cli_reports_an_unknown_sequence_guid_in_one_line(
    portal_build: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.xml"
    bad.write_text('<construction_sequence><task guid="nope"/></construction_sequence>', encoding="utf-8")
    assert bimbot_main(["planner", "--build", str(portal_build), "--sequence", str(bad)]) == 2
    assert "nope" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("options", "expected"),
    [
        ([], PlanSource(SourceKind.BUILD)),
        (["--sequence", "s.xml"], PlanSource(SourceKind.SEQUENCE, Path("s.xml"))),
        (["--from-ifc"], PlanSource(SourceKind.IFC, None)),
        (["--from-ifc", "m.ifc"], PlanSource(SourceKind.IFC, Path("m.ifc"))),
        (["--derive"], PlanSource(SourceKind.DERIVE)),
    ],
)
def test_planner_cli_source_options_choose_the_plan_source(options: list[str], expected: PlanSource) -> None:
    argv = ["planner", "--build", "out", *options]
    assert plan_source(build_parser(argv).parse_args(argv)) == expected


def test_planner_cli_source_options_are_mutually_exclusive() -> None:
    argv = ["planner", "--build", "out", "--derive", "--from-ifc"]
    with pytest.raises(SystemExit):
        build_parser(argv).parse_args(argv)


def test_a_skip_request_reaches_physics_skip_with_its_payload_and_the_answer_comes_back_to_the_inbox() -> (
    None
):
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    asked: list[SkipRequest] = []
    with (
        open_session(BusOptions(mode="peer", connect=(), listen=(endpoint,))) as physics,
        open_session(BusOptions(mode="peer", connect=(endpoint,), listen=())) as planner,
    ):
        selector = PHYSICS_SKIP.key(site=SITE)

        def answer(query: zenoh.Query) -> None:
            assert query.payload is not None
            request = decode(SkipRequest, selector, query.payload.to_bytes(), InvalidPayloads())
            assert request is not None
            asked.append(request)
            reply = PhysicsReply(ok=False, reason="r1 is moving", sim_time_s=12.0)
            query.reply(selector, encode(reply))

        queryable = physics.declare_queryable(selector, answer)
        inbox = Inbox()
        request = SkipRequest(to_sim_s=86500.0, why="curing of foot_a until 86500 s")
        deadline = time.monotonic() + bound_s(5.0)
        answers: list[SkipAnswer] = []
        while time.monotonic() < deadline:  # until the peers have met: before, no reply at all
            bus_sender(planner, SITE, inbox)(request)
            answers = [item for item in inbox.drain(first_timeout_s=1.0) if isinstance(item, SkipAnswer)]
            if answers and answers[0].reply is not None:
                break
            assert all(item.error == "no reply (timeout)" for item in answers)
        queryable.undeclare()
    assert asked and asked[0] == request
    first = answers[0]
    assert first.request == request and len(answers) == 1  # one answer per question
    assert first.reply is not None and not first.reply.ok and first.reply.reason == "r1 is moving"
