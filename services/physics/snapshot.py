"""Physics' own record of the site, so a restarted physics continues the build instead of starting over.

Every control period, *before* its messages go out, physics writes its record into the run folder's
``state/``: the epoch and clock step, every robot's ground-truth pose, odometry pose and load, and the last
pose message of every component (where it lies, whether it is fixed, which robot carries it). The record
is built from the very messages physics publishes (:meth:`SnapshotRecorder.record`), so it says exactly
what the bus heard, and because it is written before they are published, its step is never behind the
last step anyone saw.

Two files take turns (``physics-record-0.json``, ``physics-record-1.json``), each rewritten in place: a
write cut off by a kill leaves at most that file torn, and the other one holds the period before. Reading
back (:func:`load_snapshot`) takes the readable one with the higher step. That costs one ``pwrite`` and one
``ftruncate`` per period, about a tenth of a rename's cost here (``bench/physics.py`` prints the record's
share of a control period). Only robots and components whose message changed are re-encoded. Nothing is
fsynced: a killed process loses nothing that reached the page cache; a power cut may lose the last periods,
and the restarted physics then continues from the record it finds, with a new epoch (see
``docs/architecture.md``).

A restart (:func:`bimbot.services.physics.restore.restore_site`) reads the record back; no readable record
means a fresh start (logged).
"""

from __future__ import annotations

import logging
import os
from collections.abc import Iterable
from pathlib import Path

from pydantic import BaseModel, ConfigDict, ValidationError

from bimbot.shared.messages import ClockMsg, ComponentPoseMsg, OdomMsg, RobotPoseMsg

_log = logging.getLogger(__name__)

RECORD_NAMES = ("physics-record-0.json", "physics-record-1.json")  # written in turn


class RobotSnapshot(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")
    pose: RobotPoseMsg  # ground truth, with its load
    odom_xy_yaw: tuple[float, float, float] | None = None  # the odometry's integrated (noisy) pose


class PhysicsSnapshot(BaseModel):
    """The site as physics last published it."""

    model_config = ConfigDict(frozen=True, extra="forbid")
    epoch: int
    step: int
    sim_time_s: float
    robots: dict[str, RobotSnapshot]
    components: dict[str, ComponentPoseMsg]


def record_paths(state_dir: Path) -> tuple[Path, Path]:
    return Path(state_dir) / RECORD_NAMES[0], Path(state_dir) / RECORD_NAMES[1]


def clear_snapshot(state_dir: Path) -> None:
    """Forget the record (``bimbot physics --fresh``)."""
    for path in record_paths(state_dir):
        path.unlink(missing_ok=True)


def load_snapshot(state_dir: Path) -> PhysicsSnapshot | None:
    """The newest readable record in ``state_dir``, or None when there is none (said in the log when a
    file could not be read)."""
    found = [record for path in record_paths(state_dir) if (record := _read(path)) is not None]
    return max(found, key=lambda record: (record.epoch, record.step), default=None)


def _read(path: Path) -> PhysicsSnapshot | None:
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        return None
    except OSError as error:
        _log.warning("cannot read the physics record %s (%s)", path, error)
        return None
    try:
        return PhysicsSnapshot.model_validate_json(data)
    except (ValidationError, ValueError) as error:
        _log.warning("the physics record %s is unreadable (%s)", path, str(error)[:200])
        return None


class SnapshotRecorder:
    """Keeps the latest message of every robot and component (encoded once per change) and writes them."""

    def __init__(self, state_dir: Path, epoch: int) -> None:
        self.epoch = epoch
        self._clock: ClockMsg | None = None
        self._robots: dict[str, RobotPoseMsg] = {}
        self._odom: dict[str, tuple[float, float, float]] = {}
        self._components: dict[str, ComponentPoseMsg] = {}
        self._encoded: dict[str, bytes] = {}  # GUID → its JSON member (``"GUID":{…}``)
        self._components_json: bytes | None = None  # every entry joined, until one changes
        Path(state_dir).mkdir(parents=True, exist_ok=True)
        self._fds = [os.open(path, os.O_RDWR | os.O_CREAT, 0o644) for path in record_paths(state_dir)]
        self._turn = 0

    def close(self) -> None:
        for fd in self._fds:
            os.close(fd)
        self._fds = []

    def record(self, messages: Iterable[BaseModel]) -> None:
        """Take one period's outgoing messages (clock, odometry, robot and component poses)."""
        for message in messages:
            if isinstance(message, ComponentPoseMsg):
                previous = self._components.get(message.guid)
                if previous is None or _moved(previous, message):
                    self._components[message.guid] = message
                    entry = message.model_dump_json().encode()
                    self._encoded[message.guid] = b'"%s":%s' % (message.guid.encode(), entry)
                    self._components_json = None
            elif isinstance(message, RobotPoseMsg):
                self._robots[message.robot_id] = message
            elif isinstance(message, OdomMsg):
                self._odom[message.robot_id] = message.pose_xy_yaw
            elif isinstance(message, ClockMsg):
                self._clock = message

    def write(self) -> None:
        """Rewrite the older of the two record files with what was recorded."""
        clock = self._clock
        if clock is None:
            return
        robots = {
            robot_id: RobotSnapshot(pose=pose, odom_xy_yaw=self._odom.get(robot_id)).model_dump_json()
            for robot_id, pose in self._robots.items()
        }
        if self._components_json is None:  # a large site's components rarely change: joined once per change
            # (each member formatted once, when its message changed: formatting all 988 members of the
            # generated frame's record every period a carried load moved was 6 % of physics' CPU)
            self._components_json = b",".join(self._encoded.values())
        parts = [
            b'{"epoch":%d,"step":%d,"sim_time_s":%r,"robots":{' % (self.epoch, clock.step, clock.sim_time_s),
            b",".join(b'"%s":%s' % (robot_id.encode(), entry.encode()) for robot_id, entry in robots.items()),
            b'},"components":{',
            self._components_json,
            b"}}",
        ]
        fd = self._fds[self._turn]
        size = os.pwritev(fd, parts, 0)  # the parts as they are: no copy of the whole record joined first
        os.ftruncate(fd, size)
        self._turn = 1 - self._turn


def _moved(previous: ComponentPoseMsg, message: ComponentPoseMsg) -> bool:
    """Whether ``message`` says something ``previous`` did not (the sim time alone is no change)."""
    return (
        previous.pose != message.pose
        or previous.attached_to != message.attached_to
        or previous.fixed != message.fixed
    )
