"""Benchmark of the navigation cores: A* global planning, one DWA step, one particle-filter update.

Run: ``.venv/bin/python bench/navigation.py``. Prints medians (and p99 for DWA) with the ratio against the
targets: A* on a 2000×2000 grid ≤ 100 ms (from the issue), a DWA step against a 10 ms reference.
Deterministic (seeded) scenes; times vary with the machine.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
from collections.abc import Callable

import numpy as np

from bimbot.services.robot.astar import plan_path, simplify_path
from bimbot.services.robot.dwa import DwaConfig, RobotState, dwa_step
from bimbot.services.robot.particle_filter import (
    LikelihoodFieldConfig,
    ParticleFilterConfig,
    build_likelihood_field,
    init_gaussian,
    mcl_step,
    simulate_scan,
)
from bimbot.shared.occupancy_grid import OccupancyGrid, from_footprints

ASTAR_TARGET_S = 0.100
DWA_REFERENCE_S = 0.010


def timed(fn: Callable[[], object], repeats: int) -> list[float]:
    """Wall-clock seconds of ``repeats`` calls."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return times


def yard_grid(n_cells: int, resolution_m: float, fill: float, wall: bool, seed: int) -> OccupancyGrid:
    """Square yard with random boxes (0.25–3 m sides) up to ``fill`` of the cells, optionally a wall with
    one 2.5 m gap across the middle; the two corners are kept clear for a corner-to-corner query."""
    rng = np.random.default_rng(seed)
    size_m = n_cells * resolution_m
    cells = np.zeros((n_cells, n_cells), dtype=bool)
    while cells.mean() < fill:
        row, col = rng.integers(0, n_cells, 2)
        height, width = rng.integers(5, 60, 2)
        cells[row : row + height, col : col + width] = True
    grid = OccupancyGrid(cells, resolution_m, (0.0, 0.0))
    boxes = [(0.0, 0.0, 1.0, 1.0), (size_m - 1.0, size_m - 1.0, size_m, size_m)]
    clear = from_footprints(grid.bounds_xy_m, resolution_m, boxes_xy_m=boxes).occupied
    cells &= ~clear
    if wall:
        mid = size_m / 2
        wall_cells = from_footprints(
            grid.bounds_xy_m, resolution_m, boxes_xy_m=[(mid - 0.25, 0.0, mid + 0.25, size_m)]
        ).occupied
        gap = from_footprints(
            grid.bounds_xy_m, resolution_m, boxes_xy_m=[(mid - 0.3, 0.9 * size_m, mid + 0.3, 0.925 * size_m)]
        ).occupied
        cells |= wall_cells & ~gap
    return grid.with_occupied(cells)


def bench_astar(repeats: int) -> None:
    print("A* global planner (numba A*, bucket queue, octile, no corner cutting), corner-to-corner query")
    plan_path(OccupancyGrid(np.zeros((8, 8), bool), 1.0, (0.0, 0.0)), (0.5, 0.5), (7.5, 7.5))  # JIT warm-up
    scenes = [
        ("2000x2000 @5cm, ~25% boxes + wall with gap", 2000, 0.05, 0.25, True),
        ("2000x2000 @5cm, ~25% boxes, no wall", 2000, 0.05, 0.25, False),
        ("1000x1000 @10cm, ~25% boxes + wall with gap", 1000, 0.10, 0.25, True),
    ]
    for label, n, res, fill, wall in scenes:
        grid = yard_grid(n, res, fill, wall, seed=0)
        size_m = n * res
        start, goal = (0.5, 0.5), (size_m - 0.5, size_m - 0.5)
        result = plan_path(grid, start, goal)
        times = timed(lambda grid=grid, start=start, goal=goal: plan_path(grid, start, goal), repeats)
        pruned_times = timed(lambda grid=grid, result=result: simplify_path(grid, result.path_xy_m), repeats)
        median = statistics.median(times)
        print(
            f"  {label}: occupied {grid.occupied.mean():.0%}, found={result.found}, "
            f"{len(result.path_cells)} cells, {result.cost_m:.1f} m"
        )
        print(
            f"    plan_path median {median * 1e3:.0f} ms over {repeats} runs "
            f"(min {min(times) * 1e3:.0f} ms) -> {median / ASTAR_TARGET_S:.2f}x the 100 ms target; "
            f"simplify_path median {statistics.median(pruned_times) * 1e3:.1f} ms"
        )


def bench_dwa(steps: int) -> None:
    config = DwaConfig()
    rng = np.random.default_rng(1)
    angles = np.linspace(-math.pi, math.pi, 360, endpoint=False)
    ranges = rng.uniform(1.0, 6.0, angles.shape)
    obstacles = np.column_stack([ranges * np.cos(angles), ranges * np.sin(angles)])
    path = np.array([[0.0, 0.0], [2.0, 1.0], [5.0, 1.5]])
    state = RobotState(0.0, 0.0, 0.2, v_mps=0.5, w_radps=0.1)
    result = dwa_step(state, (5.0, 1.5), obstacles, config, path_xy_m=path)
    times = np.array(timed(lambda: dwa_step(state, (5.0, 1.5), obstacles, config, path_xy_m=path), steps))
    median, p99 = float(np.median(times)), float(np.percentile(times, 99))
    print(
        f"DWA step: {result.n_candidates} candidate (v, w), {len(obstacles)} laser points, "
        f"{round(config.horizon_s / config.sim_dt_s)} rollout steps"
    )
    print(
        f"  median {median * 1e3:.2f} ms, p99 {p99 * 1e3:.2f} ms over {steps} steps -> "
        f"{median / DWA_REFERENCE_S:.2f}x / {p99 / DWA_REFERENCE_S:.2f}x the 10 ms reference"
    )


def bench_particle_filter(repeats: int) -> None:
    walls = [(0, 0, 20, 0.2), (0, 14.8, 20, 15), (0, 0, 0.2, 15), (19.8, 0, 20, 15)]
    inner = [(6, 0, 6.2, 6), (12, 9, 12.2, 15), (15, 3, 17, 5), (3, 10, 5, 11)]
    grid = from_footprints((0.0, 0.0, 20.0, 15.0), 0.05, boxes_xy_m=walls + inner)
    field = build_likelihood_field(grid)
    angles = np.linspace(-math.pi, math.pi, 180, endpoint=False)
    true_pose = np.array([8.0, 7.0, 0.4])
    scan = simulate_scan(grid, true_pose, angles, 10.0)
    print(f"Particle filter update (motion + likelihood field + resampling check), {len(angles)}-beam scan")
    for n_particles in (500, 2000):
        for max_beams in (180, 60):
            config = ParticleFilterConfig(sensor=LikelihoodFieldConfig(max_beams=max_beams))
            rng = np.random.default_rng(2)
            particles = init_gaussian(true_pose, 0.3, 0.1, n_particles, rng)

            def update(particles=particles, config=config, rng=rng) -> None:
                mcl_step(
                    particles, (0, 0, 0), (0.05, 0, 0.01), scan, angles, field=field, config=config, rng=rng
                )

            median = statistics.median(timed(update, repeats))
            print(f"  {n_particles} particles, {max_beams} beams used: median {median * 1e3:.2f} ms")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--astar-repeats", type=int, default=5)
    parser.add_argument("--dwa-steps", type=int, default=500)
    parser.add_argument("--pf-repeats", type=int, default=30)
    args = parser.parse_args()
    bench_astar(args.astar_repeats)
    bench_dwa(args.dwa_steps)
    bench_particle_filter(args.pf_repeats)


if __name__ == "__main__":
    main()
