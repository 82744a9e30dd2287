"""A ground robot does not set a component from where it would wall itself in (services/robot/driving.py):
when, once the component stands, no stand-point within reach keeps a way back to the depot, it gives the
task back ``no_approach_pose`` (the planner then asks a crane first) instead of setting it from inside."""

from __future__ import annotations

from functools import partial
from types import SimpleNamespace
from typing import Any, cast

import numpy as np
import pytest

from bimbot.services.robot import give_back
from bimbot.services.robot.approach import ApproachConfig
from bimbot.services.robot.driving import Driving
from bimbot.services.robot.robot_context import RobotContext
from bimbot.services.robot.task_state import ExecutorConfig
from bimbot.shared.footprint import Footprint
from bimbot.shared.occupancy_grid import from_footprints, inflate
from bimbot.shared.reasons import ReasonCode

INFLATION_M = 0.75
ROOM = [(8.0, 2.0, 8.2, 10.0), (8.0, 13.0, 8.2, 18.0), (8.0, 2.0, 16.0, 2.2), (8.0, 17.8, 16.0, 18.0)]
ROOM.append((15.8, 2.0, 16.0, 18.0))  # closed but for a 3 m opening in its west wall, x = 8.0-8.2
GATE = Footprint(np.array([[8.0, 10.0], [8.2, 10.0], [8.2, 13.0], [8.0, 13.0]]), 0.0, 2.5)  # closes it


def _driving(walls: list[tuple[float, float, float, float]]) -> Driving:
    """A Driving whose robot stands on a site with ``walls`` (20 m × 20 m, its depot at (1, 1))."""
    grid = inflate(from_footprints((0.0, 0.0, 20.0, 20.0), 0.1, boxes_xy_m=walls), INFLATION_M)
    site_map = SimpleNamespace(
        inflated_grid=lambda: grid,
        config=SimpleNamespace(band_min_z_m=0.02, band_max_z_m=1.0, inflation_m=INFLATION_M),
    )
    context = SimpleNamespace(
        site_map=site_map,
        home_xy_yaw=(1.0, 1.0, 0.0),
        approach_config=ApproachConfig(reach_m=1.5, body_clearance_m=INFLATION_M),
    )
    return Driving(cast(Any, context), cast(Any, None), cast(Any, None))


def test_a_gate_set_from_outside_the_room_it_closes_leaves_the_robot_its_way_home() -> None:
    assert not _driving(ROOM)._walls_itself_in(GATE, (10.0, 11.5))


def test_a_gate_whose_outside_is_taken_walls_in_the_robot_that_would_set_it_from_inside() -> None:
    """A wall runs 0.6 m outside the opening: no stand-point outside it fits the robot, so every one within
    reach is in the room the gate closes (the Janesville restaurant's carrier set a feature wall so and
    stood walled in to the end of the run; 14 components failed robot_trapped)."""
    outside = (7.2, 8.0, 7.4, 15.0)
    assert _driving([*ROOM, outside])._walls_itself_in(GATE, (10.0, 11.5))
    reason = give_back.walls_itself_in("r2", "Gate", 1.5)
    assert reason.code is ReasonCode.NO_APPROACH_POSE and reason.robot_id == "r2"
    assert "would wall itself in setting Gate" in reason.message


def _placing(driving: Driving) -> Driving:
    """``driving`` of a robot about to set what it carries (its cycle past the pick-up), whose map counts
    the gate in its band."""
    driving.cycle = cast(Any, SimpleNamespace(state=give_back.RobotState.IDENTIFY_TARGET_LOCATION))
    driving.context.site_map.blocks = lambda footprint: True
    return driving


def test_a_drive_that_failed_inside_the_room_is_not_close_enough_to_set_the_gate_from() -> None:
    """The Revit house with three carriers: r2's drive to its stand-points failed, it stood within reach of
    the wall panel it carried, inside the room that panel closed, set it from there and stood walled in
    to the end of the run. Within reach is close enough only where a way home is left."""
    driving = _placing(_driving(ROOM))
    assert driving._leaves_from(GATE, (7.0, 11.5)), "outside the room: its way home is kept"
    assert not driving._leaves_from(GATE, (9.3, 11.5)), "inside: the gate closes it in"
    assert not driving._leaves_from(GATE, (8.9, 11.5)), "in the gate's inflation, inside: still closed in"


def test_picking_up_or_setting_what_leaves_its_band_free_is_close_enough_anywhere() -> None:
    driving = _driving(ROOM)
    driving.cycle = cast(Any, SimpleNamespace(state=give_back.RobotState.PICK_UP))
    driving.context.site_map.blocks = lambda footprint: True
    assert driving._leaves_from(GATE, (9.3, 11.5))
    placing = _placing(_driving(ROOM))
    placing.context.site_map.blocks = lambda footprint: False  # a beam above the band closes nothing
    assert placing._leaves_from(GATE, (9.3, 11.5))


def test_a_robot_walled_in_names_what_stands_beside_it() -> None:
    """The run summary's walled-in line sends the reader to the robot's log for what stands beside it;
    the reason in that log named only the depot and the target."""
    closed = [*ROOM, (8.0, 10.0, 8.2, 13.0)]  # the gate stands: the room is shut
    driving = _driving(closed)
    driving.context.navigator = SimpleNamespace(
        pose_xy_yaw=(12.0, 10.0, 0.0), config=SimpleNamespace(beside_m=1.0)
    )
    driving.context.robot_id = "r2"
    driving.context.site_map.blocks = lambda footprint: True
    driving.context.site_map.components_near = lambda xy, within_m: [("Gate", 0.4), ("Partition", 0.9)]
    driving.context.beside_words = partial(RobotContext.beside_words, driving.context)
    target = Footprint(np.array([[2.0, 10.0], [3.0, 10.0], [3.0, 11.0], [2.0, 11.0]]), 0.0, 2.5)
    reason = driving._no_approach(driving.context.site_map.inflated_grid(), target, "the target of Column")
    assert reason.code is ReasonCode.ROBOT_TRAPPED and reason.robot_id == "r2"
    assert reason.message.endswith("; beside it: Gate (0.4 m), Partition (0.9 m)")


def _picking_up(robot_xy: tuple[float, float], others_placing: dict[str, Any]) -> tuple[Driving, Any]:
    """A Driving whose robot at ``robot_xy`` is to take up a door lying in the room (its pick-up), with
    what the other robots are setting now; and its task."""
    driving = _driving(ROOM)
    driving.cycle = cast(Any, SimpleNamespace(state=give_back.RobotState.PICK_UP))
    context = driving.context
    site_map = context.site_map
    site_map.blocks = lambda footprint: True
    site_map.planning_grid = lambda marks, margin_m: site_map.inflated_grid()
    site_map.layout = SimpleNamespace(structure=None)
    site_map.set_down = lambda guid: False  # the others' parts are in the air still
    goals: list[tuple[float, float]] = []
    context.navigator = SimpleNamespace(
        see=lambda: None,
        marks=None,
        config=SimpleNamespace(dynamic_margin_m=0.0),
        pose_xy_yaw=(*robot_xy, 0.0),
        set_goal=lambda xy, yaw, sim_s: goals.append(tuple(xy)),
    )
    context.goals = goals
    context.robot_id, context.sim_s, context.others_placing = "r2", 100.0, others_placing
    context.config = ExecutorConfig(robot_id="r2")
    task = SimpleNamespace(
        message=SimpleNamespace(guid="door"),
        component=SimpleNamespace(ifc_class="IfcDoor", name="Door"),
        failed_xy_m=[],
        retry_at_s=0.0,
        traffic_since_s=None,
        misses=0,
    )
    return driving, task


def test_a_robot_does_not_drive_into_a_room_the_parts_others_are_setting_now_will_close() -> None:
    """The Revit house with three carriers: r2 drove into a room to take up a door the crane had misplaced
    there while r1 and r3 set the two studs that closed it (their checks passed with r2 outside): walled
    in for 19 min. Now the parts being set count as standing: it waits outside, as for traffic. Already
    inside, it works on (the others' checks wait for it)."""
    door = Footprint(np.array([[12.0, 9.0], [13.0, 9.0], [13.0, 9.5], [12.0, 9.5]]), 0.0, 0.1)
    stud = {"r1": ("stud", GATE.outlines_meeting(0.02, 1.0))}
    driving, task = _picking_up((4.0, 10.0), {})
    assert driving.approach(task, door) and len(driving.context.goals) == 1  # nothing being set: it goes
    driving, task = _picking_up((4.0, 10.0), stud)
    assert not driving.approach(task, door)
    assert driving.context.goals == [] and task.traffic_since_s == 100.0  # waits, as for traffic
    driving, task = _picking_up((12.0, 12.0), stud)
    assert driving.approach(task, door) and len(driving.context.goals) == 1


def test_a_robot_that_finds_itself_walled_in_while_parking_names_what_stands_beside_it(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """A new user's trial: the run summary says the walled-in robot's log names what stands beside it, but
    r2, walled in while it drove to its depot (no task in hand), logged only that its depot was cut off."""
    from bimbot.services.robot.task_cycle import TaskCycle

    context = SimpleNamespace(
        robot_id="r2",
        sim_s=284404.5,
        navigator=SimpleNamespace(pose_xy_yaw=(1.64, 8.05, 0.0), config=SimpleNamespace(beside_m=1.0)),
        site_map=SimpleNamespace(
            config=SimpleNamespace(inflation_m=INFLATION_M),
            components_near=lambda xy, within_m: [("Stud 167106", 0.6), ("Door 166070", 1.2)],
        ),
    )
    context.beside_words = partial(RobotContext.beside_words, context)
    cycle = TaskCycle(cast(Any, context))
    cycle.say_state_soon = lambda: None  # type: ignore[method-assign]
    with caplog.at_level("WARNING"):
        cycle.walled_in("it cannot drive to its depot")
    assert cycle.walled_in_since_s == 284404.5
    assert "it cannot drive to its depot; beside it: Stud 167106 (0.6 m), Door 166070 (1.2 m)" in caplog.text
