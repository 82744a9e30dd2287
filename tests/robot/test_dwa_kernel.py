"""The DWA's compiled kernels give what the numpy formulas give: exact arcs, a k-d tree's distances, the
cheapest admissible candidate; and the DWA step chooses the same with either way of finding clearances."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from bimbot.services.robot import dwa, dwa_kernel
from bimbot.services.robot.dwa import DwaConfig, RobotState, dwa_step
from bimbot.services.robot.nav_types import DEFAULT_DWA

RNG_SEED = 7


def test_rollouts_follow_exact_arcs_and_straight_lines() -> None:
    x, y, yaw, dt, steps = 1.0, -2.0, 0.4, 0.1, 20
    speeds, rates = np.array([0.8, 0.5]), np.array([0.5, 0.0])
    paths = dwa_kernel.rollouts(x, y, yaw, speeds, rates, steps, dt)
    t = np.arange(steps + 1) * dt
    radius = speeds[0] / rates[0]  # a circle of radius v/w about its centre left of the start heading
    centre = np.array([x - radius * math.sin(yaw), y + radius * math.cos(yaw)])
    heading = yaw + rates[0] * t
    arc = np.stack([centre[0] + radius * np.sin(heading), centre[1] - radius * np.cos(heading)], axis=1)
    np.testing.assert_allclose(paths[0, :, :2], arc, rtol=0, atol=1e-12)
    np.testing.assert_allclose(paths[0, :, 2], heading, rtol=0, atol=1e-12)
    line = np.stack([x + speeds[1] * t * math.cos(yaw), y + speeds[1] * t * math.sin(yaw)], axis=1)
    np.testing.assert_allclose(paths[1, :, :2], line, rtol=0, atol=1e-12)


def test_clearances_are_a_kd_trees_distances_to_the_last_bit() -> None:
    rng = np.random.default_rng(RNG_SEED)
    for _ in range(200):
        paths = rng.uniform(-5, 5, (int(rng.integers(1, 60)), int(rng.integers(2, 22)), 3))
        obstacles = rng.uniform(-6, 6, (int(rng.integers(1, 150)), 2))
        distance, _ = cKDTree(obstacles).query(paths[..., :2].reshape(-1, 2), k=1)
        expected = distance.reshape(paths.shape[:2]).min(axis=1) - 0.5
        assert np.array_equal(dwa_kernel.clearances(paths, obstacles, 0.5), expected)


def _numpy_choice(
    paths: np.ndarray,
    speeds: np.ndarray,
    clearance: np.ndarray,
    *,
    goal: np.ndarray,
    path: np.ndarray,
    config: DwaConfig,
) -> tuple[int, int]:
    """The costs of :class:`DwaConfig`'s docstring, written with numpy: the oracle."""
    admissible = np.flatnonzero(clearance > config.safety_margin_m)
    if not len(admissible):
        return -1, 0
    end = paths[admissible, -1]
    to_goal = goal - end[:, :2]
    heading = np.abs(
        (np.arctan2(to_goal[:, 1], to_goal[:, 0]) - end[:, 2] + math.pi) % (2 * math.pi) - math.pi
    )
    capped = np.minimum(clearance[admissible], config.clearance_cap_m)
    total = (
        config.heading_weight * heading / math.pi
        + config.goal_distance_weight * np.hypot(to_goal[:, 0], to_goal[:, 1])
        + config.clearance_weight * (config.clearance_cap_m - capped) / config.clearance_cap_m
        + config.speed_weight * (config.max_speed_mps - speeds[admissible]) / config.max_speed_mps
    )
    if len(path):
        a, b = path[:-1], path[1:]
        if len(path) == 1:
            along = np.hypot(*(end[:, :2] - path[0]).T)
        else:
            ab = b - a
            t = ((end[:, None, :2] - a[None]) * ab[None]).sum(-1) / np.maximum((ab**2).sum(1), 1e-12)
            nearest = a[None] + np.clip(t, 0.0, 1.0)[..., None] * ab[None]
            along = np.sqrt(((end[:, None, :2] - nearest) ** 2).sum(-1)).min(axis=1)
        total = total + config.path_weight * along
    return int(admissible[np.argmin(total)]), len(admissible)


def test_the_choice_is_the_cheapest_admissible_candidate() -> None:
    rng = np.random.default_rng(RNG_SEED)
    config = DwaConfig()
    weights = np.array(
        [
            config.heading_weight,
            config.goal_distance_weight,
            config.clearance_weight,
            config.speed_weight,
            config.path_weight,
        ]
    )
    limits = np.array([config.safety_margin_m, config.clearance_cap_m, config.max_speed_mps])
    for trial in range(300):
        k = int(rng.integers(1, 80))
        paths = rng.uniform(-5, 5, (k, 11, 3))
        speeds = rng.uniform(0, 1, k)
        clearance = rng.uniform(-0.5, 3.0, k)
        goal = rng.uniform(-8, 8, 2)
        path = rng.uniform(-5, 5, (int(rng.integers(0, 6)), 2)) if trial % 2 else np.zeros((0, 2))
        chosen = dwa_kernel.choose(paths, speeds, clearance, goal[0], goal[1], path, weights, limits)
        assert chosen == _numpy_choice(paths, speeds, clearance, goal=goal, path=path, config=config)


@pytest.mark.parametrize("config", [DwaConfig(), DEFAULT_DWA], ids=["defaults", "robot"])
def test_a_dwa_step_chooses_the_same_with_pairs_tried_or_a_kd_tree(
    config: DwaConfig, monkeypatch: pytest.MonkeyPatch
) -> None:
    rng = np.random.default_rng(RNG_SEED)
    cases = [
        (
            RobotState(*rng.uniform(-3, 3, 2), rng.uniform(-3, 3), rng.uniform(0, 1), rng.uniform(-1.5, 1.5)),
            rng.uniform(-8, 8, 2),
            rng.uniform(-6, 6, (int(rng.integers(1, 120)), 2)),
            rng.uniform(-6, 6, (3, 2)),
        )
        for _ in range(100)
    ]
    tried = [dwa_step(state, goal, obstacles, config, path) for state, goal, obstacles, path in cases]
    monkeypatch.setattr(dwa, "BRUTE_FORCE_PAIRS", 0)  # every clearance from a k-d tree
    tree = [dwa_step(state, goal, obstacles, config, path) for state, goal, obstacles, path in cases]
    for a, b in zip(tried, tree, strict=True):
        assert (a.v_mps, a.w_radps, a.recovery, a.n_admissible, a.min_clearance_m) == (
            b.v_mps,
            b.w_radps,
            b.recovery,
            b.n_admissible,
            b.min_clearance_m,
        )
    assert sum(not result.recovery for result in tried) > 50  # most cases had a choice to make
