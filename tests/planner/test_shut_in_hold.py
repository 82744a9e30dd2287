"""A released wall is not given to a robot while placing it would shut a driving robot in a room; the hold
ends when the robot is out, or after ``HOLD_MAX_S`` of sim time."""

from __future__ import annotations

import itertools
from pathlib import Path

import pytest
from planner_builders import one_robot_site_info, robot_msg, state_msg
from site_models import ROOM_CENTRE_M, ROOM_WALLS

from bimbot.services.planner.access_hold import AccessGuard
from bimbot.services.planner.access_plan import FINE, site_robot
from bimbot.services.planner.capability import SiteRobot
from bimbot.services.planner.scheduler import Phase, PlannerCore
from bimbot.services.planner.shut_in import HOLD_MAX_S
from bimbot.services.planner.sources import plan_from_sequence
from bimbot.shared.manifest import Manifest, read_manifest
from bimbot.shared.messages import ComponentState
from bimbot.shared.robot_description import DEFAULT_ROBOT
from bimbot.shared.site_access import SiteAccess
from bimbot.shared.support_graph import derive_sequence

INSIDE_XY_M = (ROOM_CENTRE_M[0] + 0.3, ROOM_CENTRE_M[1] + 0.3)  # in the room, the column not built


@pytest.fixture(scope="module")
def room(walls_first_build: Path) -> tuple[Manifest, dict[str, str]]:
    """The generated site without Column R1: the room's four walls close an empty room."""
    manifest = read_manifest(walls_first_build)
    guid = {c.name: c.guid for c in manifest.components}
    components = [c for c in manifest.components if c.guid != guid["Column R1"]]
    return manifest.model_copy(update={"components": components}), guid


def test_the_wall_that_closes_the_room_frees_the_robot_inside(room: tuple[Manifest, dict[str, str]]) -> None:
    manifest, guid = room
    info = one_robot_site_info(manifest)
    access = SiteAccess(list(manifest.components), info.layout, site_robot(info), FINE)
    outside_xy_m = info.layout.robot_starts[0][:2]
    walls = [guid[wall] for wall in ROOM_WALLS]
    for wall in walls[:3]:
        access.place(wall)
    assert access.frees(walls[3], [INSIDE_XY_M]) == []  # not standing: it shuts in nothing
    access.place(walls[3])
    for wall in walls:  # with four standing, each one alone closes the room
        assert access.frees(wall, [outside_xy_m, INSIDE_XY_M]) == [1]
    assert access.frees(walls[0], [outside_xy_m]) == []
    # the question leaves the grid as it was
    assert not access.target_accessible(walls[0]) or access.frees(walls[0], [INSIDE_XY_M]) == [0]


def _core(manifest: Manifest, inside: str) -> PlannerCore:
    """A planner with two default robots on the site (``inside`` in the room, the other at its start), the
    walls released together (nothing is under them) and a first assignment pass made."""
    info = one_robot_site_info(manifest)
    plan = plan_from_sequence(derive_sequence(manifest.components), manifest.components, "test")
    start = info.layout.robot_starts[0]
    robots = [SiteRobot(robot_id, DEFAULT_ROBOT, start) for robot_id in ("r1", "r2")]
    guard = AccessGuard.for_site(manifest, info, plan.predecessors)
    counter = itertools.count(1)
    core = PlannerCore(
        manifest, plan, new_id=lambda: f"ev{next(counter)}", robots=robots, slots={}, access=guard
    )
    for robot in robots:
        core.robot_liveliness(robot.robot_id, True)
        where = INSIDE_XY_M if robot.robot_id == inside else start[:2]
        core.observe_robot_state(robot_msg(robot.robot_id, where))
    core.step(0.0)
    for item in manifest.components:  # the agents say released
        if core.phase(item.guid) is Phase.RELEASED:
            core.observe_component_state(state_msg(item.guid, ComponentState.RELEASED, event="release"))
    core.step(0.0)
    return core


def test_no_wall_is_given_out_while_a_robot_stands_in_the_room_it_closes(
    room: tuple[Manifest, dict[str, str]],
) -> None:
    manifest, guid = room
    core = _core(manifest, inside="r1")
    walls = [guid[wall] for wall in ROOM_WALLS]
    assert all(core.phase(wall) is Phase.RELEASED for wall in walls)
    # r1 gets out: the walls go to the robots
    core.observe_robot_state(
        robot_msg("r1", one_robot_site_info(manifest).layout.robot_starts[0][:2], sim_time_s=5)
    )
    core.step(0.0)
    assert any(core.phase(wall) is Phase.ASSIGNED for wall in walls)


def test_a_robot_that_stays_in_the_room_holds_the_walls_at_most_the_bound(
    room: tuple[Manifest, dict[str, str]],
) -> None:
    core = _core(room[0], inside="r1")
    walls = [room[1][wall] for wall in ROOM_WALLS]
    core.observe_robot_state(robot_msg("r1", INSIDE_XY_M, sim_time_s=HOLD_MAX_S / 2))
    core.step(0.0)
    assert all(core.phase(wall) is Phase.RELEASED for wall in walls)
    core.observe_robot_state(robot_msg("r1", INSIDE_XY_M, sim_time_s=HOLD_MAX_S + 1))
    core.step(0.0)
    assert any(core.phase(wall) is Phase.ASSIGNED for wall in walls)


def test_who_is_shut_in_is_answered_for_the_grid_as_it_stands_after_each_change(
    room: tuple[Manifest, dict[str, str]],
) -> None:
    """Asked, taken down, asked again: the answer follows the grid, not the robots' points as last read."""
    manifest, guid = room
    info = one_robot_site_info(manifest)
    access = SiteAccess(list(manifest.components), info.layout, site_robot(info), FINE)
    walls = [guid[wall] for wall in ROOM_WALLS]
    for wall in walls:
        access.place(wall)
    assert access.frees(walls[0], [INSIDE_XY_M]) == [0]
    access.remove(walls[2])  # the room is open again: nobody is shut in
    assert access.frees(walls[0], [INSIDE_XY_M]) == []
    access.place(walls[2])
    assert access.frees(walls[2], [INSIDE_XY_M]) == [0]
