"""Physics' own record of the site, so a restarted physics continues the build instead of starting over.

Every control period, *before* its messages go out, physics writes ``RUN/state/physics.json``: the epoch
and clock step, every robot's ground-truth pose, odometry pose and load, and the last pose message of
every component (where it lies, whether it is fixed, which robot carries it). The record is built from the
very messages physics publishes (:meth:`SnapshotRecorder.record`), so it says exactly what the bus heard,
and because it is written before they are published, its step is never behind the last step anyone saw.

Cost: only robots and components whose message changed are re-encoded; the file is one write and an
atomic rename per period (no fsync: a killed process loses nothing that reached the page cache; a power
cut may lose the last periods, and the restarted physics then continues from the record it finds, with a
new epoch, see ``docs/architecture.md``).

A restart (:func:`bimbot.services.physics.restore.restore_site`) reads the record back with
:func:`load_snapshot`; a missing or unreadable file means a fresh start (logged).
"""

from __future__ import annotations

import logging
import os
from collections.abc import Iterable
from pathlib import Path

from pydantic import BaseModel, ConfigDict, ValidationError

from bimbot.shared.messages import ClockMsg, ComponentPoseMsg, OdomMsg, RobotPoseMsg

_log = logging.getLogger(__name__)

SNAPSHOT_NAME = "physics.json"


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


def snapshot_path(state_dir: Path) -> Path:
    return Path(state_dir) / SNAPSHOT_NAME


def load_snapshot(path: Path) -> PhysicsSnapshot | None:
    """The record at ``path``, or None when there is none or it cannot be read (said in the log)."""
    try:
        data = Path(path).read_bytes()
    except FileNotFoundError:
        return None
    except OSError as error:
        _log.warning("cannot read the physics record %s (%s): starting fresh", path, error)
        return None
    try:
        return PhysicsSnapshot.model_validate_json(data)
    except (ValidationError, ValueError) as error:
        _log.warning("the physics record %s is unreadable (%s): starting fresh", path, str(error)[:200])
        return None


class SnapshotRecorder:
    """Keeps the latest message of every robot and component (encoded once per change) and writes them."""

    def __init__(self, path: Path, epoch: int) -> None:
        self.path = Path(path)
        self.epoch = epoch
        self._clock: ClockMsg | None = None
        self._robots: dict[str, RobotPoseMsg] = {}
        self._odom: dict[str, tuple[float, float, float]] = {}
        self._components: dict[str, ComponentPoseMsg] = {}
        self._encoded: dict[str, bytes] = {}  # GUID → its JSON entry
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._tmp = self.path.with_name(self.path.name + ".tmp")

    def record(self, messages: Iterable[BaseModel]) -> None:
        """Take one period's outgoing messages (clock, odometry, robot and component poses)."""
        for message in messages:
            if isinstance(message, ComponentPoseMsg):
                previous = self._components.get(message.guid)
                if previous is None or _moved(previous, message):
                    self._components[message.guid] = message
                    self._encoded[message.guid] = message.model_dump_json().encode()
            elif isinstance(message, RobotPoseMsg):
                self._robots[message.robot_id] = message
            elif isinstance(message, OdomMsg):
                self._odom[message.robot_id] = message.pose_xy_yaw
            elif isinstance(message, ClockMsg):
                self._clock = message

    def write(self) -> None:
        """Replace the record file with what was recorded (one write, one atomic rename)."""
        clock = self._clock
        if clock is None:
            return
        robots = {
            robot_id: RobotSnapshot(pose=pose, odom_xy_yaw=self._odom.get(robot_id)).model_dump_json()
            for robot_id, pose in self._robots.items()
        }
        parts = [
            b'{"epoch":%d,"step":%d,"sim_time_s":%r,"robots":{' % (self.epoch, clock.step, clock.sim_time_s),
            b",".join(b'"%s":%s' % (robot_id.encode(), entry.encode()) for robot_id, entry in robots.items()),
            b'},"components":{',
            b",".join(b'"%s":%s' % (guid.encode(), entry) for guid, entry in self._encoded.items()),
            b"}}",
        ]
        with open(self._tmp, "wb") as stream:
            stream.write(b"".join(parts))
        os.replace(self._tmp, self.path)


def _moved(previous: ComponentPoseMsg, message: ComponentPoseMsg) -> bool:
    """Whether ``message`` says something ``previous`` did not (the sim time alone is no change)."""
    return (
        previous.pose != message.pose
        or previous.attached_to != message.attached_to
        or previous.fixed != message.fixed
    )
