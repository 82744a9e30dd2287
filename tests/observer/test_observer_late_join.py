"""An observer that joins late builds its report from the agents' twins alone, and loses nothing a live
observer saw of each constructed component: the robot that placed it and its placement error.

Pure cores only: real :class:`ComponentAgent`s driven through a build (one placed off target), their twins
turned back into messages (:func:`twin_messages`) and fed to a :class:`ReportCollector`.
"""

from __future__ import annotations

import itertools

import pytest

from bimbot.services.component_agents.agent import ComponentAgent
from bimbot.shared.bus import encode
from bimbot.shared.manifest import Component, Manifest
from bimbot.shared.messages import (
    ComponentEvent,
    ComponentEventMsg,
    ComponentPoseMsg,
    ComponentState,
    ComponentStateMsg,
    PoseMsg,
    TwinMsg,
)
from bimbot.shared.report.collector import ReportCollector, twin_messages

E = ComponentEvent
NOW = 1_000.0
_ids = itertools.count()


def _event(guid: str, name: ComponentEvent, robot_id: str, sim_time_s: float) -> ComponentEventMsg:
    """The event as its sender sends it: the release from the planner, the rest from the robot."""
    sender = "planner" if name is E.RELEASE else robot_id
    return ComponentEventMsg(
        guid=guid,
        event=name,
        source=sender,
        event_id=f"ev-{next(_ids)}",
        robot_id=None if sender == "planner" else robot_id,
        sim_time_s=sim_time_s,
        wall_time_s=NOW,
    )


def _placed(component: Component, offset_m: float, sim_time_s: float) -> ComponentPoseMsg:
    target = component.target_pose_world
    position = (target.position_m[0] + offset_m, *target.position_m[1:])
    pose = PoseMsg(position_m=position, quat_xyzw=target.quat_xyzw)
    return ComponentPoseMsg(guid=component.guid, pose=pose, sim_time_s=sim_time_s, fixed=True)


def _build(component: Component, robot_id: str, offset_m: float, t0: float) -> tuple[TwinMsg, list]:
    """One agent through release → … → verified; its twin and every state message it published."""
    agent = ComponentAgent(component)
    published: list[ComponentStateMsg] = []
    for index, name in enumerate((E.RELEASE, E.PICK, E.ATTACH, E.ARRIVE)):
        published += agent.apply_event(_event(component.guid, name, robot_id, t0 + index), NOW)
    published += agent.observe_pose(_placed(component, offset_m, t0 + 4.0), NOW)
    published += agent.apply_event(_event(component.guid, E.PLACE, robot_id, t0 + 4.0), NOW)
    assert published[-1].state is ComponentState.CONSTRUCTED
    return agent.twin(), published


def _entries(collector: ReportCollector) -> dict[str, dict]:
    return {entry["guid"]: entry for entry in collector.report()["components"]}


@pytest.fixture
def built(frame_manifest: Manifest) -> list[tuple[TwinMsg, list]]:
    first, second = frame_manifest.components[:2]
    return [_build(first, "r1", 0.004, 1.0), _build(second, "r2", 0.0, 10.0)]


def test_a_twin_history_is_the_state_messages_its_agent_published(built: list[tuple[TwinMsg, list]]) -> None:
    for twin, published in built:
        assert twin.history == published
        assert TwinMsg.model_validate_json(encode(twin)).history == published  # over the wire, too


def test_a_late_report_from_twins_alone_has_each_components_robot_and_placement_error(
    frame_manifest: Manifest, built: list[tuple[TwinMsg, list]]
) -> None:
    live, late = ReportCollector(frame_manifest), ReportCollector(frame_manifest)
    for twin, published in built:
        for message in published:
            live.add(message)
        for message in twin_messages(twin):
            late.add(message)
    late_entries, live_entries = _entries(late), _entries(live)
    first, second = (twin.guid for twin, _ in built)
    assert late_entries[first]["robot_ids"] == ["r1"] and late_entries[second]["robot_ids"] == ["r2"]
    assert late_entries[first]["position_error_mm"] == pytest.approx(4.0)
    assert late_entries[second]["position_error_mm"] == pytest.approx(0.0, abs=1e-6)
    for guid in (first, second):
        assert late_entries[guid]["state"] == "constructed"
        for field in ("robot_ids", "position_error_mm", "angle_error_deg", "released_s", "constructed_s"):
            assert late_entries[guid][field] == live_entries[guid][field], field
