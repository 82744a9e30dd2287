"""The shard journal: replay, torn lines, and a restarted host resuming every agent without repeating work."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from agent_builders import GUIDS, event, manifest, pose_of

from bimbot.services.component_agents.agent import AgentConfig
from bimbot.services.component_agents.host import AgentHost, Outgoing
from bimbot.services.component_agents.journal import (
    Journal,
    JournalBusyError,
    JournalRecord,
    journal_path,
    replay,
)
from bimbot.shared.identifiers import guid_to_key
from bimbot.shared.messages import (
    COMPONENT_EVENT_KEY,
    COMPONENT_POSE_KEY,
    ComponentEvent,
    ComponentState,
    ComponentStateMsg,
    key,
)

S = ComponentState
E = ComponentEvent
NOW = 1_000.0
SITE = manifest().site


def record(guid: str, source: S, dest: S, event_id: str | None, attempt: int = 0) -> JournalRecord:
    change = ComponentStateMsg(
        guid=guid,
        previous=source,
        state=dest,
        event=dest.value,
        sim_time_s=1.0,
        wall_time_s=NOW,
        attempt=attempt,
    )
    return JournalRecord(change=change, event_id=event_id)


def send(host: AgentHost, guid: str, name: E, **kwargs: object) -> list[Outgoing]:
    msg = event(guid, name, **kwargs)  # type: ignore[arg-type]
    return host.on_event(key(COMPONENT_EVENT_KEY, site=SITE, key=guid_to_key(guid)), msg, NOW)


def test_journal_path_names_the_shard(tmp_path: Path) -> None:
    assert journal_path(tmp_path, 2, 4) == tmp_path / "agents-2of4.jsonl"


def test_replay_of_a_missing_journal_is_empty(tmp_path: Path) -> None:
    result = replay(tmp_path / "none.jsonl")
    assert result.last == {}
    assert result.lines == 0


def test_replay_gives_the_last_record_per_guid_and_every_applied_event_id(tmp_path: Path) -> None:
    path = tmp_path / "j.jsonl"
    with Journal(path) as journal:
        journal.append(record(GUIDS[0], S.PLANNED, S.RELEASED, "a"))
        journal.append(record(GUIDS[1], S.PLANNED, S.RELEASED, "b"))
        journal.append(record(GUIDS[0], S.RELEASED, S.PICKING, "c"))
        journal.append(record(GUIDS[0], S.VERIFYING, S.MISPLACED, None, attempt=1))
    result = replay(path)
    assert result.lines == 4
    assert result.last[GUIDS[0]].change.state is S.MISPLACED
    assert result.last[GUIDS[1]].change.state is S.RELEASED
    assert result.event_ids == {GUIDS[0]: {"a", "c"}, GUIDS[1]: {"b"}}
    assert [r.change.state for r in result.records[GUIDS[0]]] == [S.RELEASED, S.PICKING, S.MISPLACED]


def test_a_torn_last_line_is_skipped_and_cut_off_on_reopen(tmp_path: Path) -> None:
    path = tmp_path / "j.jsonl"
    with Journal(path) as journal:
        journal.append(record(GUIDS[0], S.PLANNED, S.RELEASED, "a"))
        journal.append(record(GUIDS[0], S.RELEASED, S.PICKING, "b"))
    whole = path.read_bytes()
    line = record(GUIDS[0], S.PICKING, S.TRANSPORTING, "c").model_dump_json().encode()
    path.write_bytes(whole + line[: len(line) // 2])  # killed mid-write

    result = replay(path)
    assert result.torn_tail
    assert result.last[GUIDS[0]].change.state is S.PICKING
    assert result.event_ids[GUIDS[0]] == {"a", "b"}

    with Journal(path) as journal:
        assert journal.replayed.last[GUIDS[0]].change.state is S.PICKING
        journal.append(record(GUIDS[0], S.PICKING, S.TRANSPORTING, "c"))
    again = replay(path)
    assert not again.torn_tail
    assert again.bad_lines == 0
    assert again.last[GUIDS[0]].change.state is S.TRANSPORTING


def test_an_unreadable_line_in_the_middle_is_skipped(tmp_path: Path) -> None:
    path = tmp_path / "j.jsonl"
    lines = [
        record(GUIDS[0], S.PLANNED, S.RELEASED, "a").model_dump_json(),
        '{"not": "a record"}',
        record(GUIDS[0], S.RELEASED, S.PICKING, "b").model_dump_json(),
    ]
    path.write_text("\n".join(lines) + "\n")
    result = replay(path)
    assert (result.lines, result.bad_lines) == (2, 1)
    assert result.last[GUIDS[0]].change.state is S.PICKING


def test_fresh_clears_the_journal(tmp_path: Path) -> None:
    path = tmp_path / "j.jsonl"
    with Journal(path) as journal:
        journal.append(record(GUIDS[0], S.PLANNED, S.RELEASED, "a"))
    with Journal(path, fresh=True) as journal:
        assert journal.replayed.last == {}
    assert path.read_bytes() == b""


def test_a_journal_is_held_by_one_process_at_a_time(tmp_path: Path) -> None:
    path = tmp_path / "j.jsonl"
    with Journal(path), pytest.raises(JournalBusyError, match="another agents process"):
        Journal(path)
    with Journal(path) as journal:  # free again once closed
        journal.append(record(GUIDS[0], S.PLANNED, S.RELEASED, "a"))


def _run_first_life(path: Path) -> dict[str, str]:
    """Drive: GUIDS[0] constructed, GUIDS[1] transporting, GUIDS[2] verifying (no pose yet); then 'killed'."""
    ids: dict[str, str] = {}
    with Journal(path) as journal:
        host = AgentHost(
            manifest(), config=AgentConfig(verify_timeout_s=30.0), journal=journal, now_wall_s=NOW
        )
        for guid in GUIDS[:3]:
            for name in (E.RELEASE, E.PICK, E.ATTACH, E.ARRIVE):
                if guid == GUIDS[1] and name is E.ARRIVE:
                    break
                send(host, guid, name)
        c0 = host.agents[guid_to_key(GUIDS[0])].component
        host.on_pose(key(COMPONENT_POSE_KEY, site=SITE, key=c0.key), pose_of(c0, sim_time_s=8.0), NOW)
        ids["place0"] = "place-0"
        out = send(host, GUIDS[0], E.PLACE, sim_time_s=8.0, event_id=ids["place0"])
        assert [o.message.state for o in out] == [S.VERIFYING, S.CONSTRUCTED]
        out = send(host, GUIDS[2], E.PLACE, sim_time_s=9.0, event_id="place-2")
        assert [o.message.state for o in out] == [S.VERIFYING]
    return ids


def test_restarted_host_resumes_every_agent_in_its_last_state(tmp_path: Path) -> None:
    path = tmp_path / "agents-1of1.jsonl"
    _run_first_life(path)
    with Journal(path) as journal:
        host = AgentHost(
            manifest(), config=AgentConfig(verify_timeout_s=30.0), journal=journal, resume=journal.replayed
        )
        agents = {guid: host.agents[guid_to_key(guid)] for guid in GUIDS}
        assert agents[GUIDS[0]].state is S.CONSTRUCTED
        assert agents[GUIDS[0]].attempt == 1
        assert agents[GUIDS[1]].state is S.TRANSPORTING
        assert agents[GUIDS[1]].robot_id == "robot-1"
        assert agents[GUIDS[2]].state is S.VERIFYING
        assert agents[GUIDS[3]].state is S.PLANNED
        assert len(agents[GUIDS[0]].twin().history) == 6
        assert host.resumed == {guid_to_key(g) for g in GUIDS[:3]}

        announced = {o.message.guid: o.message for o in host.start(NOW)}
        assert {g: m.event for g, m in announced.items()} == {
            GUIDS[0]: "resume",
            GUIDS[1]: "resume",
            GUIDS[2]: "resume",
            GUIDS[3]: "start",
        }
        assert announced[GUIDS[0]].state is S.CONSTRUCTED

        # The resumed verifying agent still decides when its pose comes.
        c2 = agents[GUIDS[2]].component
        out = host.on_pose(key(COMPONENT_POSE_KEY, site=SITE, key=c2.key), pose_of(c2, sim_time_s=9.5), NOW)
        assert [o.message.state for o in out] == [S.CONSTRUCTED]
        # The resumed transporting agent goes on from where it was.
        assert [o.message.state for o in send(host, GUIDS[1], E.ARRIVE)] == [S.ASSEMBLING]


def test_nothing_is_constructed_twice_after_a_restart(tmp_path: Path) -> None:
    path = tmp_path / "agents-1of1.jsonl"
    ids = _run_first_life(path)
    with Journal(path) as journal:
        host = AgentHost(manifest(), journal=journal, resume=journal.replayed)
        c0 = host.agents[guid_to_key(GUIDS[0])].component
        # the robot repeats its place (same event id), then a confused one places again (new id)
        assert send(host, GUIDS[0], E.PLACE, sim_time_s=8.0, event_id=ids["place0"]) == []
        assert send(host, GUIDS[0], E.PLACE, sim_time_s=20.0) == []
        assert (
            host.on_pose(key(COMPONENT_POSE_KEY, site=SITE, key=c0.key), pose_of(c0, sim_time_s=21.0), NOW)
            == []
        )
    constructed = [r for r in replay(path).records[GUIDS[0]] if r.change.state is S.CONSTRUCTED]
    assert len(constructed) == 1


def test_a_version_1_journal_line_is_read_as_the_state_change_it_copied(tmp_path: Path) -> None:
    path = tmp_path / "j.jsonl"
    v1 = {
        "v": 1,
        "guid": GUIDS[0],
        "source": "verifying",
        "dest": "constructed",
        "event": "verified",
        "event_id": None,
        "cause": "ok",
        "attempt": 1,
        "robot_id": "r2",
        "sim_time_s": 9.0,
        "wall_time_s": 1.0,
        "place_sim_time_s": None,
        "position_error_m": 0.004,
        "angle_error_rad": 0.01,
        "reason": None,
    }
    path.write_text(json.dumps(v1) + "\n")
    (record,) = replay(path).records[GUIDS[0]]
    change = record.change
    assert (change.previous, change.state, change.robot_id) == (S.VERIFYING, S.CONSTRUCTED, "r2")
    assert (change.position_error_m, change.angle_error_rad, change.attempt) == (0.004, 0.01, 1)


def test_the_journal_line_is_the_published_state_change(tmp_path: Path) -> None:
    path = tmp_path / "j.jsonl"
    written = record(GUIDS[0], S.PLANNED, S.RELEASED, "a")
    with Journal(path) as journal:
        journal.append(written)
    assert replay(path).last[GUIDS[0]] == written
