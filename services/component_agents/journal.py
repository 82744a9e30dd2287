"""An agent process's journal: one JSON line per applied transition, so a restarted process resumes.

Each shard writes its own append-only file, ``<state dir>/agents-<i>of<n>.jsonl`` (default state dir
``OUT/state``), one :class:`JournalRecord` per line: the published :class:`ComponentStateMsg` itself,
nested (lines of journal version 1, which copied its fields flat, are still read). Lines are flushed one
by one (a killed process loses at most the line being written; nothing is fsynced unless asked, so a power
cut may lose the last lines). A record is written *before* the state change is published, so anything the
bus has seen is in the journal.

:func:`replay` reads it back: per GUID the last record (its state, attempt, robot), the full list of
records (the twin's history) and the applied ``event_id``s (repeats stay ignored after a restart). A torn
last line, left by a kill in the middle of a write, is skipped and cut off when the journal is reopened;
an unreadable line elsewhere is skipped with a warning. The writer holds an exclusive ``flock`` on the file,
so the same shard started twice fails at once instead of interleaving two histories.

The journal grows with the build, not with run time: poses are not journaled, and a component makes a
handful of transitions (seven for a first-time placement, five more per retry).
"""

from __future__ import annotations

import fcntl
import logging
import os
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType

from pydantic import BaseModel, ConfigDict, ValidationError, model_validator

from bimbot.shared.messages import ComponentStateMsg

_log = logging.getLogger(__name__)

JOURNAL_VERSION = 2  # 2: the state change nested as published (``change``); 1: its fields copied flat
_V1_RENAMED = {"source": "previous", "dest": "state"}
_JOURNAL_ONLY = ("v", "event_id", "place_sim_time_s")


class JournalRecord(BaseModel):
    """One applied transition of one component: the state change exactly as published, plus what only a
    restart needs (the bus event it applied, the place time while verifying)."""

    model_config = ConfigDict(frozen=True, extra="forbid")
    v: int = JOURNAL_VERSION
    change: ComponentStateMsg
    event_id: str | None = None  # the bus event that caused it; None for the agent's own verdicts
    place_sim_time_s: float | None = None  # sim time of the place event, while verifying

    @model_validator(mode="before")
    @classmethod
    def _read_older_lines(cls, data: object) -> object:
        """A version 1 line (flat, ``source``/``dest``) becomes a nested change; the nested change is read
        under the current message schema (the journal has its own version ``v``)."""
        if not isinstance(data, dict):
            return data
        if "change" not in data:
            change = {
                _V1_RENAMED.get(name, name): value
                for name, value in data.items()
                if name not in _JOURNAL_ONLY
            }
            data = {**{name: data[name] for name in _JOURNAL_ONLY if name in data}, "change": change}
        change = data["change"]
        if isinstance(change, dict) and "schema_version" in change:
            data = {
                **data,
                "change": {name: value for name, value in change.items() if name != "schema_version"},
            }
        return data

    @classmethod
    def from_message(
        cls, message: ComponentStateMsg, event_id: str | None, place_sim_time_s: float | None
    ) -> JournalRecord:
        if message.previous is None:
            raise ValueError("only transitions are journaled (the message has no previous state)")
        return cls(change=message, event_id=event_id, place_sim_time_s=place_sim_time_s)

    @property
    def guid(self) -> str:
        return self.change.guid


@dataclass
class Replay:
    """What a journal says: per GUID the last record, every record in order, and the applied event ids."""

    last: dict[str, JournalRecord] = field(default_factory=dict)
    records: dict[str, list[JournalRecord]] = field(default_factory=dict)
    event_ids: dict[str, set[str]] = field(default_factory=dict)
    lines: int = 0
    bad_lines: int = 0
    torn_tail: bool = False
    good_size_bytes: int = 0  # bytes up to the end of the last complete line


def journal_path(state_dir: Path, shard: int, n_shards: int) -> Path:
    """``<state_dir>/agents-<shard>of<n_shards>.jsonl`` (shards numbered 1..n)."""
    return Path(state_dir) / f"agents-{shard}of{n_shards}.jsonl"


def replay(path: Path) -> Replay:
    """Read a journal (a missing file is an empty journal)."""
    result = Replay()
    path = Path(path)
    if not path.exists():
        return result
    data = path.read_bytes()
    complete_end = data.rfind(b"\n") + 1  # 0 when there is no complete line
    if complete_end < len(data):
        result.torn_tail = True
        _log.warning(
            "%s: ignoring a torn last line (%d bytes; killed mid-write?)", path, len(data) - complete_end
        )
    result.good_size_bytes = complete_end
    for number, line in enumerate(data[:complete_end].splitlines(), start=1):
        if not line.strip():
            continue
        try:
            record = JournalRecord.model_validate_json(line)
        except (ValidationError, ValueError) as error:
            result.bad_lines += 1
            _log.warning(
                "%s:%d: unreadable journal line skipped (%s)", path, number, str(error).splitlines()[0]
            )
            continue
        result.lines += 1
        result.last[record.guid] = record
        result.records.setdefault(record.guid, []).append(record)
        if record.event_id is not None:
            result.event_ids.setdefault(record.guid, set()).add(record.event_id)
    return result


class JournalBusyError(OSError):
    """Another process holds the journal: the same shard is already running."""


class Journal:
    """Append-only writer, locked (``flock``) for one process at a time. Opening replays the file, cuts a
    torn tail and keeps the result in ``replayed``; ``fresh`` empties the journal first."""

    def __init__(self, path: Path, fresh: bool = False, fsync: bool = False) -> None:
        self.path = Path(path)
        self.fsync = fsync
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._file = self.path.open("ab")
        try:
            fcntl.flock(self._file.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError as error:
            self._file.close()
            raise JournalBusyError(
                f"{self.path} is held by another agents process (is this shard already running?)"
            ) from error
        if fresh:
            _log.info("%s: --fresh, previous journal cleared", self.path)
            self._file.truncate(0)
        self.replayed = replay(self.path)
        if self.replayed.torn_tail:
            self._file.truncate(self.replayed.good_size_bytes)
        self.written = 0

    def append(self, record: JournalRecord) -> None:
        self._file.write(record.model_dump_json().encode("utf-8") + b"\n")
        self._file.flush()
        if self.fsync:
            os.fsync(self._file.fileno())
        self.written += 1

    def close(self) -> None:
        if not self._file.closed:
            self._file.close()

    def __enter__(self) -> Journal:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()
