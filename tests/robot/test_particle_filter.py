"""Monte-Carlo localisation: motion and sensor models, resampling, estimation, global convergence."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bimbot.services.robot.particle_filter import (
    LikelihoodField,
    LikelihoodFieldConfig,
    OdometryNoise,
    ParticleFilterConfig,
    ParticleSet,
    build_likelihood_field,
    effective_sample_size,
    estimate_pose,
    init_gaussian,
    init_uniform,
    low_variance_resample,
    mcl_step,
    measurement_update,
    motion_update,
    scan_log_likelihood,
    simulate_scan,
    wrap_angle,
)
from bimbot.shared.occupancy_grid import OccupancyGrid, from_footprints

ANGLES = np.linspace(-math.pi, math.pi, 180, endpoint=False)
MAX_RANGE_M = 10.0


@pytest.fixture(scope="module")
def room() -> OccupancyGrid:
    """10 m × 8 m room, asymmetric: a partial wall, a stub wall and two boxes (no pose ambiguity)."""
    walls = [(0, 0, 10, 0.2), (0, 7.8, 10, 8), (0, 0, 0.2, 8), (9.8, 0, 10, 8)]
    inner = [(3.0, 0.0, 3.2, 3.0), (6.0, 5.0, 6.2, 8.0), (7.5, 1.5, 8.5, 2.5), (1.5, 5.5, 2.5, 6.0)]
    return from_footprints((0.0, 0.0, 10.0, 8.0), 0.05, boxes_xy_m=walls + inner)


def advance(pose: np.ndarray, forward_m: float, turn_rad: float) -> np.ndarray:
    return np.array(
        [pose[0] + forward_m * math.cos(pose[2]), pose[1] + forward_m * math.sin(pose[2]), pose[2] + turn_rad]
    )


def run_mcl(
    room: OccupancyGrid,
    true_start: np.ndarray,
    guess: np.ndarray,
    moves: list[tuple[float, float]],
    seed: int,
) -> list[tuple[float, float]]:
    """Drive the true robot, feed noisy odometry and noisy scans to MCL; returns (xy error, yaw error)."""
    rng = np.random.default_rng(seed)
    world_rng = np.random.default_rng(seed + 1000)
    field = build_likelihood_field(room)
    config = ParticleFilterConfig()
    particles = init_gaussian(guess, std_xy_m=0.6, std_yaw_rad=0.4, n=1500, rng=rng)
    true_pose, odom = true_start.copy(), true_start.copy()
    errors = []
    for forward_m, turn_rad in moves:
        true_pose = advance(true_pose, forward_m, turn_rad)
        noisy_forward = forward_m * (1 + 0.05 * world_rng.normal())
        noisy_turn = turn_rad + 0.02 * world_rng.normal() + 0.02 * forward_m * world_rng.normal()
        new_odom = advance(odom, noisy_forward, noisy_turn)
        scan = simulate_scan(room, true_pose, ANGLES, MAX_RANGE_M) + world_rng.normal(0, 0.02, ANGLES.shape)
        particles, estimate = mcl_step(
            particles, odom, new_odom, scan, ANGLES, field=field, config=config, rng=rng
        )
        odom = new_odom
        xy_error = float(np.hypot(*(estimate.pose_xy_yaw[:2] - true_pose[:2])))
        yaw_error = abs(float(wrap_angle(estimate.pose_xy_yaw[2] - true_pose[2])))
        errors.append((xy_error, yaw_error))
    return errors


def test_converges_from_a_wrong_initial_guess(room: OccupancyGrid) -> None:
    true_start = np.array([1.5, 2.0, 0.3])
    guess = true_start + np.array([0.8, -0.6, math.radians(20)])  # 1 m and 20° off
    moves = [(0.15, 0.0)] * 8 + [(0.0, 0.25)] * 3 + [(0.15, 0.03)] * 8
    errors = run_mcl(room, true_start, guess, moves, seed=3)
    xy_error, yaw_error = errors[-1]
    assert xy_error < 0.2
    assert yaw_error < math.radians(5)


def test_tracking_error_stays_bounded_along_a_path(room: OccupancyGrid) -> None:
    true_start = np.array([4.5, 4.0, -0.5])
    guess = true_start + np.array([0.3, 0.2, 0.1])
    moves = [(0.2, 0.05)] * 10 + [(0.0, 0.3)] * 5 + [(0.2, -0.05)] * 15 + [(0.1, 0.2)] * 10
    errors = np.array(run_mcl(room, true_start, guess, moves, seed=5))
    assert errors[5:, 0].max() < 0.2
    assert errors[5:, 1].max() < math.radians(5)


def test_motion_update_without_noise_applies_odometry_in_each_particle_frame() -> None:
    particles = ParticleSet(np.array([[0.0, 0.0, 0.0], [1.0, 1.0, math.pi / 2]]), np.full(2, 0.5))
    no_noise = OdometryNoise(0.0, 0.0, 0.0, 0.0)
    moved = motion_update(particles, (5.0, 5.0, 0.0), (6.0, 5.0, 0.5), no_noise, np.random.default_rng(0))
    np.testing.assert_allclose(
        moved.poses_xy_yaw, [[1.0, 0.0, 0.5], [1.0, 2.0, math.pi / 2 + 0.5]], atol=1e-12
    )


def test_motion_noise_spreads_particles_around_the_odometry_motion() -> None:
    particles = ParticleSet(np.zeros((4000, 3)), np.full(4000, 1 / 4000))
    moved = motion_update(particles, (0, 0, 0), (1.0, 0, 0), OdometryNoise(), np.random.default_rng(1))
    travelled_m = np.hypot(moved.poses_xy_yaw[:, 0], moved.poses_xy_yaw[:, 1])
    assert travelled_m.mean() == pytest.approx(1.0, abs=0.02)
    assert travelled_m.std() == pytest.approx(math.sqrt(0.05), rel=0.1)  # alpha3 · trans²
    assert moved.poses_xy_yaw[:, 2].std() == pytest.approx(math.sqrt(0.05 + 0.05), rel=0.1)  # rot1 + rot2
    still = motion_update(particles, (0, 0, 0), (0, 0, 0), OdometryNoise(), np.random.default_rng(1))
    np.testing.assert_array_equal(still.poses_xy_yaw, particles.poses_xy_yaw)


def test_measurement_update_prefers_the_true_pose(room: OccupancyGrid) -> None:
    true_pose = np.array([5.0, 3.0, 1.0])
    scan = simulate_scan(room, true_pose, ANGLES, MAX_RANGE_M)
    poses = true_pose + np.array([[0.0, 0.0, 0.0], [0.3, 0.0, 0.0], [0.0, 0.0, 0.1]])
    updated = measurement_update(
        ParticleSet(poses, np.full(3, 1 / 3)),
        scan,
        ANGLES,
        build_likelihood_field(room),
        ParticleFilterConfig().sensor,
    )
    assert int(np.argmax(updated.weights)) == 0
    assert updated.weights.sum() == pytest.approx(1.0)


def test_low_variance_resampling_copies_each_particle_in_proportion_to_its_weight() -> None:
    rng = np.random.default_rng(2)
    n = 1000
    weights = rng.random(n) ** 4
    weights /= weights.sum()
    poses = np.column_stack([np.arange(n, dtype=float), np.zeros(n), np.zeros(n)])
    resampled = low_variance_resample(ParticleSet(poses, weights), rng)
    counts = np.bincount(resampled.poses_xy_yaw[:, 0].astype(int), minlength=n)
    assert counts.sum() == n
    assert np.all(np.abs(counts - n * weights) < 1.0 + 1e-9)  # systematic resampling: floor or ceil
    np.testing.assert_allclose(resampled.weights, 1 / n)


def test_effective_sample_size_spans_one_to_n() -> None:
    assert effective_sample_size(np.full(50, 1 / 50)) == pytest.approx(50)
    assert effective_sample_size(np.eye(1, 50)[0]) == pytest.approx(1)


def test_pose_estimate_uses_circular_mean_across_pi() -> None:
    poses = np.array([[1.0, 2.0, math.pi - 0.1], [3.0, 2.0, -math.pi + 0.1]])
    estimate = estimate_pose(ParticleSet(poses, np.array([0.5, 0.5])))
    np.testing.assert_allclose(estimate.pose_xy_yaw[:2], [2.0, 2.0])
    assert abs(wrap_angle(estimate.pose_xy_yaw[2] - math.pi)) < 1e-9
    assert estimate.covariance[2, 2] == pytest.approx(0.01)
    assert estimate.covariance[0, 0] == pytest.approx(1.0)
    assert estimate.std_xy_m == pytest.approx(1.0)


def test_simulated_scan_measures_distance_to_walls(room: OccupancyGrid) -> None:
    angles = np.array([0.0, math.pi / 2, math.pi])
    ranges = simulate_scan(room, (6.1, 4.0, 0.0), angles, MAX_RANGE_M)
    np.testing.assert_allclose(ranges, [3.7, 1.0, 5.9], atol=0.02)  # east wall, stub wall above, west wall
    assert simulate_scan(room, (5.0, 4.0, 0.0), angles, max_range_m=0.5).tolist() == [0.5, 0.5, 0.5]


def test_same_seed_gives_identical_particles(room: OccupancyGrid) -> None:
    def once() -> np.ndarray:
        rng = np.random.default_rng(9)
        particles = init_gaussian((2.0, 2.0, 0.0), 0.3, 0.2, 200, rng)
        scan = simulate_scan(room, (2.1, 2.0, 0.0), ANGLES, MAX_RANGE_M)
        particles, _ = mcl_step(
            particles,
            (0, 0, 0),
            (0.1, 0, 0),
            scan,
            ANGLES,
            field=build_likelihood_field(room),
            config=ParticleFilterConfig(),
            rng=rng,
        )
        return particles.poses_xy_yaw

    np.testing.assert_array_equal(once(), once())


def test_uniform_initialisation_puts_every_particle_in_free_space(room: OccupancyGrid) -> None:
    particles = init_uniform(room, 2000, np.random.default_rng(4))
    assert room.is_free_xy(particles.poses_xy_yaw[:, :2]).all()
    assert np.abs(particles.poses_xy_yaw[:, 2]).max() <= math.pi
    assert particles.weights.sum() == pytest.approx(1.0)


def _reference_log_likelihood(poses, ranges, angles, field, config):
    """The likelihood-field model written out with numpy (table 6.3 of Probabilistic Robotics, tempered)."""
    valid = np.isfinite(ranges) & (ranges > 0) & (ranges < config.max_range_m)
    r, a = ranges[valid], angles[valid]
    pick = np.linspace(0, len(r) - 1, min(len(r), config.max_beams)).round().astype(int)
    r, a = r[pick], a[pick]
    yaw = poses[:, 2:3] + a[None, :]
    col = np.floor((poses[:, 0:1] + r * np.cos(yaw) - field.origin_xy_m[0]) / field.resolution_m).astype(int)
    row = np.floor((poses[:, 1:2] + r * np.sin(yaw) - field.origin_xy_m[1]) / field.resolution_m).astype(int)
    rows, cols = field.distance_m.shape
    inside = (row >= 0) & (row < rows) & (col >= 0) & (col < cols)
    dist = field.distance_m[np.where(inside, row, 0), np.where(inside, col, 0)]
    p_hit = np.where(inside, np.exp(-0.5 * (dist / config.sigma_hit_m) ** 2), 0.0)
    p = config.z_hit * p_hit + config.z_rand / config.max_range_m
    return config.likelihood_exponent * np.log(p).sum(axis=1)


def test_the_compiled_laser_model_gives_the_models_values_for_every_kind_of_beam() -> None:
    rng = np.random.default_rng(7)
    field = LikelihoodField(rng.random((300, 200)) * 2.0, 0.05, (-3.0, -2.0))
    poses = np.column_stack([rng.uniform(-6, 14, 400), rng.uniform(-5, 16, 400), rng.uniform(-4, 4, 400)])
    ranges = rng.uniform(0.2, 12.0, 180)  # some beyond max range (10 m), some ending off the field
    ranges[::9] = np.inf
    angles = np.linspace(-np.pi, np.pi, 180, endpoint=False)
    config = LikelihoodFieldConfig()
    got = scan_log_likelihood(poses, ranges, angles, field, config)
    expected = _reference_log_likelihood(poses, ranges, angles, field, config)
    assert got.shape == (400,)
    np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-9)
    empty = scan_log_likelihood(poses, np.full(180, np.inf), angles, field, config)
    assert not empty.any(), "no valid beam: no information"
