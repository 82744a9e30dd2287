"""Load the robot's compiled kernels (A*, the laser likelihood model, the DWA) once per process, before the
first tick.

numba compiles a kernel on its first call, or loads it from its cache next to the source (0.3–0.6 s each);
on a fresh clone there is no cache yet and the first call takes seconds. A tick must never wait on that, so
an executor loads them when it is built, not on its first plan or scan.
"""

from __future__ import annotations

import functools

import numpy as np

from bimbot.shared.occupancy_grid import OccupancyGrid

from . import dwa_kernel
from .astar import plan_path
from .particle_filter import LikelihoodField, LikelihoodFieldConfig, scan_log_likelihood


@functools.cache
def warm_up_kernels() -> None:
    """Run each compiled kernel once on a tiny input; later calls return at once."""
    plan_path(OccupancyGrid(np.zeros((4, 4), bool), 1.0, (0.0, 0.0)), (0.5, 0.5), (3.5, 3.5))
    field = LikelihoodField(np.zeros((4, 4)), 1.0, (0.0, 0.0))
    scan_log_likelihood(np.zeros((1, 3)), [1.0], [0.0], field, LikelihoodFieldConfig())
    dwa_kernel.warm_up()
