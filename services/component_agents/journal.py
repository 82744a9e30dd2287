"""An agent process's journal: one JSON line per applied transition, so a restarted process resumes.

Each shard writes its own append-only file, ``<state dir>/agents-<i>of<n>.jsonl`` (default state dir
``OUT/state``), one :class:`JournalRecord` per line, flushed per line (a killed process loses at most the
line being written; nothing is fsynced unless asked, so a power cut may lose the last lines). A record is
written *before* the state change is published, so anything the bus has seen is in the journal.

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

from pydantic import BaseModel, ConfigDict, ValidationError

from bimbot.shared.messages import ComponentState, ComponentStateMsg, TransitionRecord
from bimbot.shared.reasons import Reason

_log = logging.getLogger(__name__)

JOURNAL_VERSION = 1


class JournalRecord(BaseModel):
    """One applied transition of one component."""

    model_config = ConfigDict(frozen=True, extra="forbid")
    v: int = JOURNAL_VERSION
    guid: str
    source: ComponentState
    dest: ComponentState
    event: str
    event_id: str | None = None  # the bus event that caused it; None for the agent's own verdicts
    cause: str = ""
    attempt: int = 0
    robot_id: str | None = None
    sim_time_s: float
    wall_time_s: float
    place_sim_time_s: float | None = None  # sim time of the place event, while verifying
    position_error_m: float | None = None
    angle_error_rad: float | None = None
    reason: Reason | None = None

    @classmethod
    def from_message(
        cls, message: ComponentStateMsg, event_id: str | None, place_sim_time_s: float | None
    ) -> JournalRecord:
        if message.previous is None:
            raise ValueError("only transitions are journaled (the message has no previous state)")
        return cls(
            guid=message.guid,
            source=message.previous,
            dest=message.state,
            event=message.event,
            event_id=event_id,
            cause=message.cause,
            attempt=message.attempt,
            robot_id=message.robot_id,
            sim_time_s=message.sim_time_s,
            wall_time_s=message.wall_time_s,
            place_sim_time_s=place_sim_time_s,
            position_error_m=message.position_error_m,
            angle_error_rad=message.angle_error_rad,
            reason=message.reason,
        )

    def transition(self) -> TransitionRecord:
        return TransitionRecord(
            source=self.source,
            dest=self.dest,
            event=self.event,
            cause=self.cause,
            sim_time_s=self.sim_time_s,
            attempt=self.attempt,
            reason=self.reason,
        )


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
