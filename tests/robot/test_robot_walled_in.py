"""A robot walled in says so in its state (since when, where it stands) from the give-back that found it, and
says it no more once it has driven out to its depot; a robot that merely cannot drive is not walled in."""

from __future__ import annotations

import pytest
from fake_site import DT, FakeSite, construct_named, make_site
from site_models import ROOM_CENTRE_M, ROOM_WALLS

from bimbot.services.robot.parking import not_parked_activity
from bimbot.shared.manifest import Manifest
from bimbot.shared.messages import (
    ComponentEvent,
    ComponentPoseMsg,
    PoseMsg,
    RobotStateMsg,
)
from bimbot.shared.reasons import ReasonCode


def _state(site: FakeSite) -> RobotStateMsg:
    return site.executor.state_message(0.0)


def _open_the_room(site: FakeSite, manifest: Manifest) -> None:
    """Physics says the south wall now lies 30 m south of where it stood: the way out is open."""
    wall = next(c for c in manifest.components if c.name == "Wall R-S")
    x, y, z = wall.target_pose_world.position_m
    pose = PoseMsg(position_m=(x, y - 30.0, z), quat_xyzw=wall.target_pose_world.quat_xyzw)
    site.executor.handle(
        ComponentPoseMsg(guid=wall.guid, pose=pose, sim_time_s=site.step * DT, fixed=True, joined=True)
    )


def test_a_robot_closed_in_by_walls_says_where_and_since_when_until_it_drives_out_to_its_depot(
    room: Manifest,
) -> None:
    centre = (ROOM_CENTRE_M[0], ROOM_CENTRE_M[1], 0.0)
    site, released, task = make_site(
        room, "Column A1", start_xy_yaw=centre, park_after_s=2.0, park_retry_s=5.0
    )
    construct_named(site, room, ROOM_WALLS)
    site.run(3)
    assert _state(site).walled_in_since_s is None, "walled in, but it has not found out yet"
    site.executor.handle(released)
    site.executor.handle(task)
    site.run(600, until=lambda s: ComponentEvent.ABANDON in s.applied and s.executor.task is None)
    abandon = next(e for e in site.events if e.event is ComponentEvent.ABANDON)
    assert abandon.reason is not None and abandon.reason.code is ReasonCode.ROBOT_TRAPPED, abandon.reason
    state = _state(site)
    assert state.walled_in_since_s == pytest.approx(abandon.sim_time_s, abs=DT)
    x, y, _ = state.pose_xy_yaw
    assert abs(x - ROOM_CENTRE_M[0]) < 1.5 and abs(y - ROOM_CENTRE_M[1]) < 1.5, state.pose_xy_yaw
    site.run(200)  # its parking drives fail: still walled in, since the same time
    assert _state(site).walled_in_since_s == state.walled_in_since_s
    assert not site.executor.can_sleep()  # it tries to park again later: it must not sleep through that
    _open_the_room(site, room)
    home = site.executor.home_xy_yaw
    site.run(4000, until=lambda s: _state(s).walled_in_since_s is None)
    out = _state(site)
    assert out.walled_in_since_s is None, f"still walled in at {out.pose_xy_yaw} after {site.step * DT:.0f} s"
    assert abs(out.pose_xy_yaw[0] - home[0]) < 0.5 and abs(out.pose_xy_yaw[1] - home[1]) < 0.5, "at its depot"
    site.run(1)
    assert site.executor.can_sleep()  # parked at its depot, idle: nothing ahead of its own accord


@pytest.mark.parametrize("xy", [(1.43, -6.35), (-123.45, -678.9)])
def test_a_robot_that_cannot_park_says_what_it_means_for_the_build_in_a_progress_line(
    xy: tuple[float, float],
) -> None:
    waits = not_parked_activity(xy, walled_in=False, off_m=123.44)
    assert waits.startswith("waits at (") and "for a task" in waits  # nothing changes: it takes tasks
    assert waits.endswith("123.4 m from its depot")  # how near it came
    walled = not_parked_activity(xy, walled_in=True, off_m=0.7)
    assert walled.startswith("walled in at (") and walled.endswith(": no task until it gets out")
    assert max(len(waits), len(walled)) <= 60  # whole on the run's progress line (MAX_ACTIVITY_CHARS)
