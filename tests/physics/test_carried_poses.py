"""In the plan fidelity a carried load's pose goes out when it is taken up, then at most once a second of
sim time, and at once when it is set down or another robot takes it; every other message always."""

from __future__ import annotations

from bimbot.services.physics.carried_poses import CARRIED_POSE_EVERY_S, CarriedPoses
from bimbot.shared.messages import ClockMsg, ComponentPoseMsg, PoseMsg


def _pose(at_s: float, attached_to: str | None, guid: str = "beam") -> ComponentPoseMsg:
    pose = PoseMsg(position_m=(at_s, 0.0, 1.0), quat_xyzw=(0.0, 0.0, 0.0, 1.0))
    return ComponentPoseMsg(guid=guid, pose=pose, sim_time_s=at_s, attached_to=attached_to, fixed=False)


def test_a_load_on_its_way_goes_out_now_and_then_and_when_set_down() -> None:
    poses = CarriedPoses()
    periods = [round(0.2 * k, 1) for k in range(16)]  # 3 s of carrying at 0.2 s a period
    sent = [at_s for at_s in periods if poses.due(_pose(at_s, "r1"))]
    assert sent == [0.0, 1.0, 2.0, 3.0]
    assert CARRIED_POSE_EVERY_S == 1.0  # what the list above reckons with
    assert poses.due(_pose(3.2, None))  # set down: at once
    assert poses.due(_pose(3.4, "r2"))  # taken up again: at once


def test_another_robot_taking_the_load_is_said_at_once() -> None:
    poses = CarriedPoses()
    assert poses.due(_pose(0.0, "r1"))
    assert not poses.due(_pose(0.2, "r1"))
    assert poses.due(_pose(0.4, "crane"))


def test_loads_are_reckoned_apart_and_other_messages_always_go() -> None:
    poses = CarriedPoses()
    assert poses.due(_pose(0.0, "r1", "a")) and poses.due(_pose(0.2, "r2", "b"))
    assert not poses.due(_pose(0.4, "r1", "a"))
    assert poses.due(ClockMsg(sim_time_s=0.4, step=2, real_time_factor=1.0))
    assert poses.due(_pose(0.4, None, "c"))
