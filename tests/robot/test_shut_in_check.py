"""A robot does not place what would shut another robot into a room (services/robot/shut_in_check.py):
it holds the placement while a robot that drives stands inside, asks again, and places after the
planner's bound."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any, cast

import numpy as np
import pytest

from bimbot.services.robot.shut_in_check import held, note_placing, shut_in_by, theirs_setting
from bimbot.services.robot.task_state import ExecutorConfig
from bimbot.shared.footprint import Footprint
from bimbot.shared.messages import RobotState, RobotStateMsg, TaskKind
from bimbot.shared.occupancy_grid import from_footprints, inflate
from tests.component_boxes import box_component

RADIUS_M = 0.75
ROOM = [(8.0, 2.0, 8.2, 10.0), (8.0, 13.0, 8.2, 18.0), (8.0, 2.0, 16.0, 2.2), (8.0, 17.8, 16.0, 18.0)]
ROOM.append((15.8, 2.0, 16.0, 18.0))  # closed but for a 3 m opening in its west wall, x = 8.0-8.2
GATE = Footprint(np.array([[8.0, 10.0], [8.2, 10.0], [8.2, 13.0], [8.0, 13.0]]), 0.0, 2.5)  # closes it
DEPOT = (1.0, 1.0)
INSIDE, OUTSIDE = (12.0, 10.0), (4.0, 10.0)


def _site_map(walls: list[tuple[float, float, float, float]]) -> Any:
    """A map of a 20 m × 20 m site with ``walls``, inflated by any radius asked."""
    static = from_footprints((0.0, 0.0, 20.0, 20.0), 0.1, boxes_xy_m=walls)
    return SimpleNamespace(
        inflated_grid=lambda radius_m=RADIUS_M: inflate(static, radius_m),
        loose_targets=lambda but=None: ([], []),
        set_down=lambda guid: False,
        config=SimpleNamespace(band_min_z_m=0.02, band_max_z_m=1.0, inflation_m=RADIUS_M),
    )


def _outlines() -> list:
    return GATE.outlines_meeting(0.02, 1.0)


def test_a_robot_inside_the_room_the_gate_closes_is_shut_in_one_outside_is_not() -> None:
    drivers = {"r2": (RADIUS_M, DEPOT), "r3": (RADIUS_M, DEPOT)}
    shut = shut_in_by(_site_map(ROOM), _outlines(), drivers, {"r2": INSIDE, "r3": OUTSIDE})
    assert shut == ["r2"]


def test_a_robot_walled_in_already_or_one_that_does_not_drive_is_not_this_placements_doing() -> None:
    closed = [*ROOM, (7.0, 10.0, 7.2, 13.0), (7.0, 9.8, 8.2, 10.0), (7.0, 13.0, 8.2, 13.2)]  # a lobby shut
    drivers = {"r2": (RADIUS_M, DEPOT)}
    assert shut_in_by(_site_map(closed), _outlines(), drivers, {"r2": INSIDE}) == []
    assert shut_in_by(_site_map(ROOM), _outlines(), {}, {"r4": INSIDE}) == []  # a crane: no driver


def test_a_robot_held_against_the_gates_side_counts_by_the_free_cells_near_it() -> None:
    """Stopped 0.5 m inside the opening (in the gate's inflation, as a robot that failed to reach its
    stand-point stands): still inside; 0.5 m outside it: still outside."""
    drivers = {"r2": (RADIUS_M, DEPOT)}
    assert shut_in_by(_site_map(ROOM), _outlines(), drivers, {"r2": (8.7, 11.5)}) == ["r2"]
    assert shut_in_by(_site_map(ROOM), _outlines(), drivers, {"r2": (7.5, 11.5)}) == []


def test_the_placement_waits_asks_again_and_goes_after_the_bound(caplog: pytest.LogCaptureFixture) -> None:
    config = ExecutorConfig(robot_id="r1", shut_in_wait_s=900.0, shut_in_recheck_s=5.0)
    context = SimpleNamespace(
        robot_id="r1",
        site_map=_site_map(ROOM),
        drivers={"r2": (RADIUS_M, DEPOT)},
        others_xy={"r2": INSIDE},
        others_placing={},
        sim_s=100.0,
    )
    task = SimpleNamespace(
        target=GATE,
        shut_in_since_s=None,
        shut_in_robots=[],
        retry_at_s=0.0,
        message=SimpleNamespace(guid="gate"),
        component=SimpleNamespace(name="Gate"),
    )
    with caplog.at_level("INFO"):
        assert held(cast(Any, context), cast(Any, task), config)
    assert task.shut_in_since_s == 100.0 and task.retry_at_s == 105.0
    assert "placing it now would shut in r2 at (12.0, 10.0)" in caplog.text
    context.sim_s = 500.0
    assert held(cast(Any, context), cast(Any, task), config)  # still inside: still held
    context.others_xy["r2"] = OUTSIDE
    context.sim_s = 505.0
    assert not held(cast(Any, context), cast(Any, task), config)  # out: it goes
    assert task.shut_in_since_s is None
    context.others_xy["r2"] = INSIDE
    assert held(cast(Any, context), cast(Any, task), config)
    context.sim_s = 505.0 + 900.0
    with caplog.at_level("WARNING"):
        assert not held(cast(Any, context), cast(Any, task), config)  # the bound: placed all the same
    assert "it still shuts in r2" in caplog.text


def _context(robot_id: str, others_xy: dict[str, tuple[float, float]], walls: list) -> Any:
    drivers = {other: (RADIUS_M, DEPOT) for other in others_xy}
    return SimpleNamespace(
        robot_id=robot_id, site_map=_site_map(walls), drivers=drivers, others_xy=others_xy,
        others_placing={}, sim_s=100.0,
    )  # fmt: skip


def _task(guid: str, target: Footprint) -> Any:
    message = SimpleNamespace(guid=guid)
    return SimpleNamespace(
        target=target,
        shut_in_since_s=None,
        shut_in_robots=[],
        retry_at_s=0.0,
        message=message,
        component=SimpleNamespace(name=guid),
    )


def _state(robot_id: str, state: RobotState, guid: str | None, task_id: str | None = "T1") -> RobotStateMsg:
    return RobotStateMsg(
        robot_id=robot_id, state=state, task_id=task_id, guid=guid, pose_xy_yaw=(0.0, 0.0, 0.0),
        sim_time_s=100.0, wall_time_s=1.0,
    )  # fmt: skip


def test_two_parts_set_at_once_that_close_a_room_between_them_hold_the_robot_outside(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """The race on the Revit house with three carriers: r2 set a panel from inside a room while one gap was
    open, and r1 set the stud that closed that gap at the same moment; each checked the site as it stood
    and r2 was walled in. Now r1 counts the panel r2 is setting: it holds the stud until r2 is out. r2's
    own check does not hold r2's panel (r1 stands outside), and a part that the other robot's alone
    closes the room with is that robot's check's business."""
    room = [*ROOM[:2], (8.0, 2.0, 11.0, 2.2), (14.0, 2.0, 16.0, 2.2), *ROOM[3:]]  # a 3 m gap in the south too
    south = Footprint(np.array([[11.0, 2.0], [14.0, 2.0], [14.0, 2.2], [11.0, 2.2]]), 0.0, 2.5)
    config = ExecutorConfig(robot_id="r1")
    r1 = _context("r1", {"r2": INSIDE}, room)
    stud = _task("stud", GATE)
    assert not held(r1, stud, config)  # the south gap is open: nobody is shut in by the stud alone
    r1.others_placing["r2"] = ("panel", south.outlines_meeting(0.02, 1.0))
    with caplog.at_level("INFO"):
        assert held(r1, stud, config)
    assert (
        "placing it now would shut in r2 at (12.0, 10.0) (no way out to the depot; counting what r2 set now)"
        in caplog.text
    )
    r1.others_xy["r2"] = OUTSIDE  # r2 set its panel and drove out
    r1.sim_s = 105.0
    assert not held(r1, stud, config)
    r2 = _context("r2", {"r1": OUTSIDE}, room)
    r2.others_placing["r1"] = ("stud", GATE.outlines_meeting(0.02, 1.0))
    assert not held(r2, _task("panel", south), config)  # the robot inside sets its part and drives out
    r3 = _context("r3", {"r2": INSIDE}, ROOM)  # the stud alone closes this room: r1's check holds it
    r3.others_placing["r1"] = ("stud", GATE.outlines_meeting(0.02, 1.0))
    elsewhere = Footprint(np.array([[2.0, 15.0], [3.0, 15.0], [3.0, 16.0], [2.0, 16.0]]), 0.0, 2.5)
    assert not held(r3, _task("post", elsewhere), config)


def test_what_another_robot_is_setting_counts_only_while_it_sets_a_build_tasks_part_at_its_target() -> None:
    """A part in the air over its target counts; a hand-off goes down at a staging spot, a part being
    picked up is still in the yard, and a robot that finished sets nothing."""
    context = _context("r1", {"r2": INSIDE}, ROOM)
    panel = box_component("panel", (3.0, 0.2, 2.5), (11.0, 2.0, 0.0))
    note_placing(context, _state("r2", RobotState.ASSEMBLE, "panel"), panel, TaskKind.BUILD)
    guid, outlines = context.others_placing["r2"]
    assert guid == "panel" and len(outlines) == 1
    low, high = outlines[0].min(axis=0), outlines[0].max(axis=0)
    assert np.allclose(low, (11.0, 2.0)) and np.allclose(high, (14.0, 2.2))
    note_placing(context, _state("r2", RobotState.IDLE, None, task_id=None), None, None)
    assert context.others_placing == {}
    note_placing(context, _state("r2", RobotState.WORK_IN_PLACE, "panel"), panel, TaskKind.BUILD)
    assert "r2" in context.others_placing  # laid or cast where it stands
    note_placing(context, _state("r2", RobotState.ASSEMBLE, "panel"), panel, TaskKind.HAND_OFF)
    assert context.others_placing == {}
    note_placing(context, _state("r2", RobotState.PICK_UP, "panel"), panel, TaskKind.BUILD)
    assert context.others_placing == {}


def _site_map_with_loose(walls: list, loose_box: tuple, loose_target: Footprint) -> Any:
    """:func:`_site_map` with a part judged misplaced lying in ``loose_box``, its BIM target ``loose_target``
    (the fakes of :meth:`SiteMap.inflated_grid_without` and :meth:`SiteMap.loose_targets`)."""
    with_it = _site_map([*walls, loose_box])
    without = from_footprints((0.0, 0.0, 20.0, 20.0), 0.1, boxes_xy_m=walls)
    with_it.inflated_grid_without = lambda guids, radius_m: inflate(without, radius_m)
    outlines = loose_target.outlines_meeting(0.02, 1.0)
    with_it.loose_targets = lambda but=None: ([], []) if but == "door" else (["door"], outlines)
    return with_it


def test_a_part_lying_loose_is_seen_past_as_set_at_its_target_by_its_retry() -> None:
    """A door set off its target lies across the gap a stud is to close, its doorway open: seen as it lies,
    the robot inside goes out by the doorway and the stud goes; once the door is set again in its doorway
    the robot is walled in. A part judged misplaced will be taken up and set at its target: the check sees
    the room as it will be, the door in its doorway and the gap open, so the stud shuts the robot in and
    waits."""
    room = [*ROOM[:2], (8.0, 2.0, 11.0, 2.2), (14.0, 2.0, 16.0, 2.2), *ROOM[3:]]  # the doorway: the south gap
    doorway = Footprint(np.array([[11.0, 2.0], [14.0, 2.0], [14.0, 2.2], [11.0, 2.2]]), 0.0, 2.5)
    lying_in_the_gap = (8.3, 9.8, 9.0, 13.2)
    drivers = {"r2": (RADIUS_M, DEPOT)}
    as_it_lies = _site_map([*room, lying_in_the_gap])  # what the check saw before
    as_it_lies.loose_targets = lambda but=None: ([], [])
    assert shut_in_by(as_it_lies, _outlines(), drivers, {"r2": INSIDE}) == []  # out by the doorway
    site_map = _site_map_with_loose(room, lying_in_the_gap, doorway)
    assert shut_in_by(site_map, _outlines(), drivers, {"r2": INSIDE}, placing="stud") == ["r2"]
    assert shut_in_by(site_map, _outlines(), drivers, {"r2": OUTSIDE}, placing="stud") == []
    elsewhere = Footprint(np.array([[2.0, 15.0], [3.0, 15.0], [3.0, 16.0], [2.0, 16.0]]), 0.0, 2.5)
    assert shut_in_by(site_map, elsewhere.outlines_meeting(0.02, 1.0), drivers, {"r2": INSIDE}) == []


def test_a_held_part_that_goes_because_the_robot_inside_is_walled_in_already_says_so(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """A held part goes when it shuts nobody in: the robot drove out, or it is walled in already by what
    was set since (not this part's doing). The log says which, so that a robot walled in later can be
    traced to the parts that did it."""
    config = ExecutorConfig(robot_id="r1")
    context = _context("r1", {"r2": INSIDE}, ROOM)
    stud = _task("stud", GATE)
    assert held(context, stud, config) and stud.shut_in_robots == ["r2"]
    closed = [*ROOM, (7.0, 10.0, 7.2, 13.0), (7.0, 9.8, 8.2, 10.0), (7.0, 13.0, 8.2, 13.2)]  # a lobby shut
    context.site_map = _site_map(closed)
    context.sim_s = 110.0
    with caplog.at_level("INFO"):
        assert not held(context, stud, config)
    assert "at 110 s of sim time: it shuts nobody in now (r2 walled in already, not by it)" in caplog.text
    assert stud.shut_in_robots == []


def test_two_parts_that_each_close_the_same_gap_are_both_held_for_the_robot_inside() -> None:
    """A mullion and the glazing panel it frames close the same opening, each alone. Each check left the
    robot inside to the other's ("theirs alone shuts it in"), both parts went, and r2 was walled in to
    the end of the run. A part that alone shuts a robot in is held by its own check."""
    config = ExecutorConfig(robot_id="r1")
    glazing = Footprint(np.array([[8.05, 10.0], [8.15, 10.0], [8.15, 13.0], [8.05, 13.0]]), 0.0, 2.5)
    r1 = _context("r1", {"r2": INSIDE}, ROOM)
    r1.others_placing["r3"] = ("glazing", glazing.outlines_meeting(0.02, 1.0))
    assert held(r1, _task("mullion", GATE), config)
    r3 = _context("r3", {"r2": INSIDE}, ROOM)
    r3.others_placing["r1"] = ("mullion", GATE.outlines_meeting(0.02, 1.0))
    assert held(r3, _task("glazing", glazing), config)


def test_a_part_set_down_already_is_on_the_map_not_theirs_to_check() -> None:
    """A robot holding a part it has set down (its connection being made) is still setting it by its
    state, but the part stands: its own check is done. It is counted as the site, not as theirs."""
    r1 = _context("r1", {"r2": INSIDE}, ROOM)
    r1.others_placing["r4"] = ("door", GATE.outlines_meeting(0.02, 1.0))
    assert theirs_setting(r1, "stud")[0] == ["r4"]
    r1.site_map.set_down = lambda guid: guid == "door"
    assert theirs_setting(r1, "stud") == ([], [])
