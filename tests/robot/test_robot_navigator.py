"""The navigator on a simulated unicycle world: reaches goals around the yard rows without touching anything,
replans around what the laser finds, localises better than dead reckoning, and gives way to other robots."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pytest
from frames import convert_small_frame

from bimbot.services.robot.dwa import DwaConfig
from bimbot.services.robot.motion import Path, carrot, turn_command, yield_point
from bimbot.services.robot.navigator import Navigator, NavStatus
from bimbot.services.robot.particle_filter import simulate_scan, wrap_angle
from bimbot.services.robot.site_map import SiteMap
from bimbot.shared.manifest import Manifest, read_manifest
from bimbot.shared.messages import OdomMsg, ScanMsg
from bimbot.shared.occupancy_grid import OccupancyGrid, distance_field_m, empty_grid, from_footprints
from bimbot.shared.site_layout import plan_site

ANGLES = np.linspace(-math.pi, math.pi, 180, endpoint=False)
RANGE_MAX_M = 15.0
DT = 0.1


@pytest.fixture(scope="module")
def frame(tmp_path_factory: pytest.TempPathFactory) -> Manifest:
    return read_manifest(convert_small_frame(tmp_path_factory.mktemp("frame")))


@pytest.fixture
def site(frame: Manifest) -> SiteMap:
    return SiteMap(plan_site(frame.components, robots=1), frame.components)


@dataclass
class World:
    """Ideal unicycle motion; odometry with a yaw-rate bias and speed noise; laser on ``truth``."""

    truth: OccupancyGrid
    pose: np.ndarray
    odom: np.ndarray = field(init=False)
    yaw_bias_radps: float = 0.02
    rng: np.random.Generator = field(default_factory=lambda: np.random.default_rng(7))
    sim_s: float = 0.0
    path: list[np.ndarray] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.odom = self.pose.copy()

    def sense(self, navigator: Navigator) -> None:
        navigator.observe_odom(
            OdomMsg(robot_id="r1", pose_xy_yaw=tuple(self.odom), v_mps=0, w_radps=0, sim_time_s=self.sim_s)
        )
        ranges = simulate_scan(self.truth, self.pose, ANGLES, RANGE_MAX_M, step_m=0.05)
        scan = ScanMsg(
            robot_id="r1",
            angle_min_rad=float(ANGLES[0]),
            angle_increment_rad=float(ANGLES[1] - ANGLES[0]),
            range_max_m=RANGE_MAX_M,
            ranges_m=ranges.tolist(),
            sim_time_s=self.sim_s,
        )
        navigator.observe_scan(scan)

    def move(self, v: float, w: float) -> None:
        self.pose = _integrate(self.pose, v, w)
        noisy_v = v * (1.0 + 0.02 * self.rng.normal())
        self.odom = _integrate(self.odom, noisy_v, w + (self.yaw_bias_radps if abs(v) > 0.01 else 0.0))
        self.sim_s += DT
        self.path.append(self.pose.copy())

    def drive(self, navigator: Navigator, max_steps: int = 1500) -> NavStatus:
        for _ in range(max_steps):
            self.sense(navigator)
            command = navigator.step(self.sim_s)
            if navigator.status in (NavStatus.REACHED, NavStatus.FAILED):
                return navigator.status
            self.move(command.v_mps, command.w_radps)
        return navigator.status


def _integrate(pose: np.ndarray, v: float, w: float) -> np.ndarray:
    mid = pose[2] + 0.5 * w * DT
    return np.array(
        [
            pose[0] + v * DT * math.cos(mid),
            pose[1] + v * DT * math.sin(mid),
            float(wrap_angle(pose[2] + w * DT)),
        ]
    )


def clearance_m(grid: OccupancyGrid, path: list[np.ndarray]) -> float:
    distance = distance_field_m(grid)
    rc = grid.world_to_cell(np.array(path)[:, :2])
    return float(distance[rc[:, 0], rc[:, 1]].min())


def start_of(site: SiteMap) -> np.ndarray:
    return np.array(site.layout.robot_starts[0], float)


def test_reaches_a_goal_behind_the_yard_rows_without_touching_anything(site: SiteMap) -> None:
    start = start_of(site)
    yard = site.layout.yard
    goal = (yard.max_xy[0] - 1.0, yard.min_xy[1] + 0.8)  # the far corner of the aisle behind the rows
    assert site.inflated_grid().is_free(*goal)
    world = World(site.laser_grid(), start)
    navigator = Navigator(site, start)
    navigator.set_goal(goal, math.pi / 2, 0.0)
    assert world.drive(navigator) is NavStatus.REACHED
    assert math.hypot(*(world.pose[:2] - goal)) < 0.45
    assert abs(float(wrap_angle(world.pose[2] - math.pi / 2))) < 0.3
    assert clearance_m(site.static_grid(), world.path) > 0.45, "the Husky's half-width is 0.34 m"


def test_replans_around_an_obstacle_only_the_laser_knows_about(site: SiteMap) -> None:
    start = start_of(site)
    goal = (start[0] + 12.0, start[1])
    box = (start[0] + 5.0, start[1] - 0.8, start[0] + 6.0, start[1] + 0.8)  # right across the straight line
    surprise = from_footprints(site.geometry.bounds_xy_m, site.config.resolution_m, boxes_xy_m=[box])
    truth = site.laser_grid().with_occupied(site.laser_grid().occupied | surprise.occupied)
    world = World(truth, start)
    navigator = Navigator(site, start)
    navigator.set_goal(goal, None, 0.0)
    assert world.drive(navigator) is NavStatus.REACHED
    assert navigator.replans >= 2, "planned once blind, again when the laser saw the box"
    assert clearance_m(surprise, world.path) > 0.45


def test_localisation_corrects_odometry_drift(site: SiteMap) -> None:
    start = start_of(site)
    world = World(site.laser_grid(), start, yaw_bias_radps=0.05)
    navigator = Navigator(site, start)
    lane_y = site.layout.yard.max_xy[1] + 1.5  # between the yard and the building
    for goal_x in (site.layout.yard.max_xy[0] - 1.0, site.layout.yard.min_xy[0]):
        navigator.set_goal((goal_x, lane_y), None, world.sim_s)
        assert world.drive(navigator) is NavStatus.REACHED
    odom_error = math.hypot(*(world.odom[:2] - world.pose[:2]))
    estimate_error = math.hypot(*(np.array(navigator.pose_xy_yaw[:2]) - world.pose[:2]))
    assert odom_error > 0.4
    assert estimate_error < 0.2
    assert navigator.localiser.updates > 10


def test_unreachable_goal_waits_then_fails(site: SiteMap) -> None:
    start = start_of(site)
    slot = next(iter(site.layout.slots.values())).footprint
    inside = np.add(slot.min_xy, slot.max_xy) / 2
    navigator = Navigator(site, start)
    navigator.set_goal(inside, None, 0.0)
    world = World(site.laser_grid(), start)
    world.sense(navigator)
    assert navigator.step(0.0).status is NavStatus.WAITING
    assert navigator.waiting_s(10.0) == pytest.approx(10.0)
    assert navigator.step(navigator.config.max_wait_s + 1.0).status is NavStatus.FAILED


def test_a_goal_covered_by_the_laser_is_reported_blocked_and_a_free_one_is_not(site: SiteMap) -> None:
    start = start_of(site)
    goal = np.array([start[0] + 6.0, start[1]])
    box = (goal[0] - 0.3, goal[1] - 0.3, goal[0] + 0.3, goal[1] + 0.3)  # something now stands on the goal
    surprise = from_footprints(site.geometry.bounds_xy_m, site.config.resolution_m, boxes_xy_m=[box])
    truth = site.laser_grid().with_occupied(site.laser_grid().occupied | surprise.occupied)
    for world_grid, blocked in ((truth, True), (site.laser_grid(), False)):
        navigator = Navigator(site, start)
        navigator.set_goal(goal, None, 0.0)
        world = World(world_grid, start)
        world.sense(navigator)
        navigator.step(0.0)
        assert navigator.goal_blocked is blocked
        assert (navigator.status is NavStatus.WAITING) is blocked


def test_the_robot_with_the_greater_id_steps_aside_and_the_other_holds(site: SiteMap) -> None:
    start = start_of(site)
    goal = (start[0] + 8.0, start[1])
    other_xy = start[:2] + np.array([1.2, 0.0])  # another robot right in front of us, not moving
    blocker = empty_grid(site.geometry.bounds_xy_m, site.config.resolution_m)
    disc = np.hypot(*(blocker.cell_to_world(np.argwhere(~blocker.occupied)) - other_xy).T) <= 0.45
    cells = np.argwhere(~blocker.occupied)[disc]
    occupied = site.laser_grid().occupied.copy()
    occupied[cells[:, 0], cells[:, 1]] = True
    truth = site.laser_grid().with_occupied(occupied)
    outcomes = {}
    for me, other in (("r2", "r1"), ("r1", "r2")):
        navigator = Navigator(site, start, robot_id=me)
        navigator.set_goal(goal, None, 0.0)
        world = World(truth, start.copy())
        for _ in range(120):  # stand still long enough to be declared stuck (we never move the world)
            world.sense(navigator)
            navigator.observe_robot(other, other_xy, world.sim_s)
            navigator.step(world.sim_s)
            world.sim_s += DT
        outcomes[me] = navigator
    aside, holding = outcomes["r2"], outcomes["r1"]
    assert aside.course.resume is not None and aside.status is NavStatus.ACTIVE
    assert math.hypot(*(aside.goal.xy - other_xy)) > math.hypot(*(start[:2] - other_xy)), "steps away"
    assert holding.course.resume is None and holding.goal.give_ways >= 1


def test_path_projection_samples_and_carrot_do_not_cut_a_corner() -> None:
    path = Path([(0.0, 0.0), (4.0, 0.0), (4.0, 4.0)])
    arc, gap = path.project((2.0, 0.5))
    assert arc == pytest.approx(2.0) and gap == pytest.approx(0.5)
    samples = path.samples(3.5, 1.0)
    np.testing.assert_allclose(samples[[0, -1]], [[3.5, 0.0], [4.0, 0.5]], atol=1e-9)
    grid = from_footprints(
        (-1.0, -1.0, 6.0, 6.0), 0.1, boxes_xy_m=[(2.0, 0.2, 3.8, 5.0)]
    )  # inside the corner
    ahead = path.samples(*path.project((1.0, 0.0))[:1], 6.0)
    target, stretch = carrot(ahead, (1.0, 0.0), 5.0, grid)
    assert target[1] < 0.45 and target[0] > 3.5, (
        "the corner hides the second leg: the carrot waits on the first"
    )
    assert np.allclose(stretch[-1], target)


def test_turn_command_respects_the_acceleration_limits_and_brakes() -> None:
    dwa = DwaConfig()
    v, w = turn_command(math.pi, 0.8, 0.0, dwa)
    assert v == pytest.approx(0.8 - dwa.max_accel_mps2 * dwa.control_period_s)
    assert w == pytest.approx(dwa.max_yaw_accel_radps2 * dwa.control_period_s)
    _, w_small = turn_command(0.01, 0.0, 1.5, dwa)
    assert w_small < 1.5, "slows down before the heading"


def test_yield_point_moves_away_from_the_other_robot() -> None:
    grid = empty_grid((0.0, 0.0, 10.0, 10.0), 0.1)
    spot = yield_point(grid, (5.0, 5.0), (6.0, 5.0))
    assert spot is not None and spot[0] < 5.0
    walled = from_footprints((0.0, 0.0, 10.0, 10.0), 0.1, boxes_xy_m=[(2.5, 0.0, 4.6, 10.0)])
    spot = yield_point(walled, (5.0, 5.0), (6.0, 5.0))
    assert spot is not None and walled.is_free(*spot) and abs(spot[1] - 5.0) > 0.5, (
        "sideways when blocked behind"
    )


def test_with_a_command_latency_the_robot_plans_from_where_its_acting_command_carries_it() -> None:
    from bimbot.services.robot.motion import unicycle

    ahead = unicycle((1.0, 2.0, 0.0), 0.5, 0.0, 0.2)
    assert ahead == pytest.approx((1.1, 2.0, 0.0))
    quarter = unicycle((0.0, 0.0, 0.0), math.pi / 2, math.pi / 2, 1.0)  # a quarter circle of radius 1
    assert quarter == pytest.approx((1.0, 1.0, math.pi / 2), abs=1e-9)


def test_the_navigator_with_a_latency_gives_its_pose_where_the_acting_command_takes_it_and_waits_to_rest(
    site: SiteMap,
) -> None:
    """With physics' one-period latency, the pose the executor sees (and a placement is commanded from) is
    the estimate carried on by the command acting meanwhile; at rest only once commanded still through the
    latency and the odometry says it stands still (a heavy robot coasts after its stop command)."""
    from dataclasses import replace

    from bimbot.services.robot.nav_types import NavigatorConfig

    config = NavigatorConfig()
    config = replace(config, command_latency_s=0.2, dwa=replace(config.dwa, control_period_s=0.2))
    start = (site.layout.robot_starts[0][0], site.layout.robot_starts[0][1], 0.0)
    navigator = Navigator(site, start, config, np.random.default_rng(0))
    navigator.observe_odom(OdomMsg(robot_id="r1", pose_xy_yaw=start, v_mps=0.0, w_radps=0.0, sim_time_s=0.0))
    navigator._command(0.5, 0.0)  # what step() sends while driving
    navigator.step(0.2)  # no goal: it commands a stop; the 0.5 m/s command acts until then
    assert navigator.pose_xy_yaw == pytest.approx((start[0] + 0.1, start[1], 0.0), abs=1e-9)
    assert not navigator.at_rest
    navigator.observe_odom(OdomMsg(robot_id="r1", pose_xy_yaw=start, v_mps=0.05, w_radps=0.0, sim_time_s=0.4))
    navigator.step(0.4)  # stopped twice, but still coasting by odometry
    assert navigator.pose_xy_yaw == pytest.approx(start, abs=1e-9) and not navigator.at_rest
    navigator.observe_odom(OdomMsg(robot_id="r1", pose_xy_yaw=start, v_mps=0.0, w_radps=0.0, sim_time_s=0.6))
    assert navigator.at_rest
