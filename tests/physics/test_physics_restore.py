"""A restarted physics continues the site from its record: robots where their bodies were, loads still on
them, placed components fixed where they were placed, constructed ones (by their twins) locked, the clock
after the last published step in a new epoch."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import pytest
from physics_builders import drive, idle, pose, west_of

from bimbot.services.physics.handling_state import Phase
from bimbot.services.physics.restore import restore_site
from bimbot.services.physics.scene import footprint
from bimbot.services.physics.simulation import Simulation
from bimbot.services.physics.snapshot import PhysicsSnapshot, SnapshotRecorder, load_snapshot, record_paths
from bimbot.shared.manifest import Component, Manifest
from bimbot.shared.messages import (
    AttachRequest,
    ClockMsg,
    ComponentPoseMsg,
    ComponentState,
    PlaceRequest,
    TwinMsg,
)


def _record(sim: Simulation, recorder: SnapshotRecorder, messages: list) -> None:
    recorder.record(item.message for item in messages)
    recorder.write()


def _twin(sim: Simulation, guid: str, state: ComponentState) -> TwinMsg:
    component = sim.handling.items[guid].component
    target = component.target_pose_world
    return TwinMsg(
        guid=guid,
        key=component.key,
        ifc_class=component.ifc_class,
        name=None,
        storey=None,
        material=None,
        mass_kg=component.mass_kg,
        target_pose=pose(target.position_m, target.quat_xyzw),
        current_pose=None,
        current_pose_sim_time_s=None,
        state=state,
        attempt=1,
        robot_id="r1",
        history=[],
    )


def test_a_restarted_physics_continues_where_the_last_one_stopped(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest, tmp_path: Path
) -> None:
    first = make_sim(robots=2)
    recorder = SnapshotRecorder(tmp_path, first.epoch)
    _record(first, recorder, first.start_messages())
    footing, column, beam = (
        next(c for c in frame_manifest.components if c.ifc_class == cls)
        for cls in ("IfcFooting", "IfcColumn", "IfcBeam")
    )
    # r1 places the footing
    for robot in first.robots.values():  # reach is not under test here
        robot.description = robot.description.model_copy(update={"reach_m": 50.0})
    assert first.attach(AttachRequest(robot_id="r1", guid=footing.guid)).ok
    target = footing.target_pose_world
    first.teleport_robot("r1", west_of(footprint(footing, (target.position_m, target.quat_xyzw)), 0.8))
    placed = PlaceRequest(
        robot_id="r1", guid=footing.guid, pose=pose(target.position_m, target.quat_xyzw), duration_s=0.5
    )
    assert first.place(placed, "tag") is None
    for result in idle(first, 2.5):  # the motion, then it comes to rest in its pit
        _record(first, recorder, result.messages)
    # r2 carries the column and drives off with it
    assert first.attach(AttachRequest(robot_id="r2", guid=column.guid)).ok
    for result in drive(first, "r2", 0.5, 0.2, 3.0):
        _record(first, recorder, result.messages)
    r1, r2 = first.robot_pose("r1"), first.robot_pose("r2")
    column_pose = first.component_frame(column.guid)
    last_step = first.step

    snapshot = load_snapshot(tmp_path)
    assert snapshot is not None and snapshot.step == last_step and snapshot.epoch == 0
    second = make_sim(robots=2)
    twins = [
        _twin(second, footing.guid, ComponentState.CONSTRUCTED),
        _twin(second, beam.guid, ComponentState.CONSTRUCTED),  # constructed, but the record has no pose
    ]
    restored = restore_site(second, snapshot, twins)

    assert (second.epoch, second.step) == (1, last_step + 1)
    assert (restored.constructed, restored.fixed_from_twins) == (2, 1)
    assert second.robot_pose("r1") == pytest.approx(r1, abs=0.02)
    assert second.robot_pose("r2") == pytest.approx(r2, abs=0.02)
    assert second.handling.carrying == {"r2": column.guid}
    assert second.component_frame(column.guid)[0] == pytest.approx(column_pose[0], abs=0.05)
    for guid in (footing.guid, beam.guid):
        item = second.handling.items[guid]
        assert item.phase is Phase.JOINED and guid in second.handling.constructed
        assert item.pose[0] == pytest.approx(item.component.target_pose_world.position_m, abs=0.003)
    refused = second.attach(AttachRequest(robot_id="r1", guid=footing.guid))
    assert not refused.ok and "constructed" in refused.reason
    # the carried column still follows r2, and the clock goes on in the new epoch
    results = drive(second, "r2", 0.5, 0.0, 1.0)
    clock = results[-1].messages[0].message
    assert clock.epoch == 1 and clock.step == second.step
    moved = second.component_frame(column.guid)[0]
    assert math.dist(moved[:2], column_pose[0][:2]) > 0.2


def test_a_torn_record_falls_back_to_the_other_and_none_means_a_fresh_start(tmp_path: Path) -> None:
    assert load_snapshot(tmp_path) is None
    recorder = SnapshotRecorder(tmp_path, epoch=2)
    for step in (7, 8):
        recorder.record([ClockMsg(sim_time_s=step * 0.2, step=step, real_time_factor=0.0)])
        recorder.write()
    recorder.close()
    loaded = load_snapshot(tmp_path)
    assert loaded is not None and (loaded.epoch, loaded.step) == (2, 8)
    newest = max(record_paths(tmp_path), key=lambda path: b'"step":8' in path.read_bytes())
    newest.write_bytes(newest.read_bytes()[:20])  # a write cut off by a kill
    loaded = load_snapshot(tmp_path)
    assert loaded is not None and loaded.step == 7
    for path in record_paths(tmp_path):
        path.write_text("{not json", encoding="utf-8")
    assert load_snapshot(tmp_path) is None


def test_a_placed_component_connected_to_a_constructed_one_is_connected_again_whatever_the_record_order(
    make_sim: Callable[..., Simulation], frame_manifest: Manifest
) -> None:
    """Beam A1-A2 was connected to Beam A2-A3 (constructed) and awaited its verdict when physics died; the
    record lists it first. Put back, it is connected again (to Beam A2-A3 beside it and, by the build's
    link, to Column A1 it is framed into) and stays, instead of tipping off Column A1."""
    named = {c.name: c for c in frame_manifest.components}
    sim = make_sim(robots=0)
    beam = named["Beam A1-A2"]
    built = [named[name] for name in ("Footing A1", "Column A1", "Beam A2-A3")]

    def record(component: Component, *, joined: bool) -> ComponentPoseMsg:
        target = component.target_pose_world
        return ComponentPoseMsg(
            guid=component.guid,
            pose=pose(target.position_m, target.quat_xyzw),
            sim_time_s=100.0,
            fixed=True,
            joined=joined,
        )

    components = {beam.guid: record(beam, joined=False)}
    components.update((c.guid, record(c, joined=True)) for c in built)
    snapshot = PhysicsSnapshot(epoch=0, step=500, sim_time_s=100.0, robots={}, components=components)
    twins = [_twin(sim, c.guid, ComponentState.CONSTRUCTED) for c in built]
    twins.append(_twin(sim, beam.guid, ComponentState.VERIFYING))
    restore_site(sim, snapshot, twins)
    idle(sim, 3.0)
    message = sim.handling.pose_message(beam.guid, sim.sim_time_s)
    assert set(message.connected_to) == {named["Beam A2-A3"].guid, named["Column A1"].guid}
    assert message.drift_m is not None and message.drift_m < 0.001
    assert sim.handling.items[named["Beam A2-A3"].guid].phase is Phase.JOINED
