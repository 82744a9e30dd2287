"""Poses over a run, per component and per robot, for the animated exports (USD).

From the run's rerun recording when there is one (what the observer logged: ``world/components/<guid>``
and ``world/robots/<id>`` transforms on the ``sim_time`` timeline); else from the journal and the
manifest: a component appears at its BIM target when it was placed (its yard and carried poses are only
in the recording), robots have no poses.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from bimbot.export.sim_schedule import SimSchedule
from bimbot.shared.geometry import Quat, Vec3
from bimbot.shared.manifest import Manifest

NS_PER_S = 1e9
COMPONENTS_ROOT = "/world/components/"
ROBOTS_ROOT = "/world/robots/"


@dataclass(frozen=True)
class PoseSample:
    time_s: float
    position_m: Vec3
    quat_xyzw: Quat


@dataclass
class RunPoses:
    """Per component GUID and per robot id, pose samples in time order; ``source`` says where from."""

    source: str
    components: dict[str, list[PoseSample]] = field(default_factory=dict)
    robots: dict[str, list[PoseSample]] = field(default_factory=dict)
    appears_s: dict[str, float] = field(default_factory=dict)  # journal only: when it was placed


def poses_from_recording(path: Path, guids: Mapping[str, str], robot_ids: Mapping[str, str]) -> RunPoses:
    """Samples from an ``.rrd``; ``guids``/``robot_ids``: the recording's path part → GUID / robot id."""
    from rerun.chunk import RrdReader

    poses = RunPoses(source=f"recording {path.name}")
    for chunk in RrdReader(path).store().stream():
        entity = str(chunk.entity_path)
        if entity.startswith(COMPONENTS_ROOT):
            target, key = poses.components, guids.get(entity[len(COMPONENTS_ROOT) :])
        elif entity.startswith(ROBOTS_ROOT):
            target, key = poses.robots, robot_ids.get(entity[len(ROBOTS_ROOT) :])
        else:
            continue
        batch = chunk.to_record_batch()
        names = batch.schema.names
        if key is None or "Transform3D:translation" not in names or "Transform3D:quaternion" not in names:
            continue
        times = batch.column("sim_time").to_pylist() if "sim_time" in names else [None] * batch.num_rows
        translations = batch.column("Transform3D:translation").to_pylist()
        rotations = batch.column("Transform3D:quaternion").to_pylist()
        for time, translation, rotation in zip(times, translations, rotations, strict=True):
            if not translation or not rotation:
                continue
            time_s = time.total_seconds() if hasattr(time, "total_seconds") else (time or 0) / NS_PER_S
            position, quat = translation[0], rotation[0]
            target.setdefault(key, []).append(
                PoseSample(
                    time_s, (position[0], position[1], position[2]), (quat[0], quat[1], quat[2], quat[3])
                )
            )
    for samples in (*poses.components.values(), *poses.robots.values()):
        samples.sort(key=lambda sample: sample.time_s)
    return poses


def poses_from_journal(manifest: Manifest, schedule: SimSchedule) -> RunPoses:
    """Each placed component at its BIM target from the time it was placed (no recording)."""
    poses = RunPoses(source="journal")
    by_guid = {component.guid: component for component in manifest.components}
    for work in schedule.components:
        place = next((step for step in work.steps if step.name == "place"), None)
        placed_s = place.finish_s if place is not None else work.finish_s
        if work.state != "constructed" or placed_s is None:
            continue
        target = by_guid[work.guid].target_pose_world
        poses.components[work.guid] = [PoseSample(placed_s, target.position_m, target.quat_xyzw)]
        poses.appears_s[work.guid] = placed_s
    return poses


def run_poses(manifest: Manifest, schedule: SimSchedule, recording: Path | None) -> RunPoses:
    """From the recording when there is one, else from the journal."""
    if recording is None:
        return poses_from_journal(manifest, schedule)
    import rerun as rr

    guids = {rr.escape_entity_path_part(component.guid): component.guid for component in manifest.components}
    robots = {rr.escape_entity_path_part(robot_id): robot_id for robot_id in schedule.robot_types}
    return poses_from_recording(recording, guids, robots)
