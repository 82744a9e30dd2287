"""What the robot's last scan shows around it: local obstacles for the DWA and laser marks for planning.

Why apart from :mod:`.navigator`: the navigator and its traffic rules (:mod:`.traffic`) read the same marks,
and the executor's choice of a stand-point (:mod:`.driving`) too. A scan becomes world points once, at
the pose estimate it was taken from, and only when the robot has somewhere to go (an idle robot waits for
tasks without them):

* **local obstacles** — hits within ``local_obstacle_radius_m``, with the static map's obstacle outlines
  nearby (for what the laser misses);
* **laser marks** — hits the static map does not explain (other robots, surprises), added to the grid for
  planning. Marks may move: the DWA sees them ``dynamic_margin_m`` nearer than they are, so two robots
  closing on each other, each planning as if the other stood still, keep their distance.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from bimbot.shared.occupancy_grid import scan_endpoints_xy_m

from .nav_types import NavigatorConfig
from .site_map import SiteMap


class Surroundings:
    """The last scan as obstacles and marks (see the module doc); the navigator feeds it every scan."""

    def __init__(self, site_map: SiteMap, config: NavigatorConfig, start_xy_yaw: ArrayLike) -> None:
        self.site_map, self.config = site_map, config
        self.local_points = np.empty((0, 2))
        self.scan_hits_robot_m = np.empty((0, 2))  # the last scan's hits, robot frame (fine alignment)
        self._scan: tuple[NDArray[np.float64], NDArray[np.float64], float] | None = None  # not seen yet
        self._scan_pose = np.asarray(start_xy_yaw, float)[:3].copy()
        self.marks = np.empty((0, 2))
        self.nearest_mark_m = math.inf  # from the robot to the nearest local mark, at the scan
        self._mark_tree: cKDTree | None = None

    def take_scan(
        self,
        ranges: NDArray[np.float64],
        angles: NDArray[np.float64],
        range_max_m: float,
        pose: NDArray[np.float64],
    ) -> None:
        """A scan taken at the estimate ``pose``: its hits for the fine alignment now, its marks when a goal
        needs them (:meth:`see`)."""
        self._scan_pose = pose.copy()
        hit = np.isfinite(ranges) & (ranges < range_max_m) & (ranges > 0)
        self.scan_hits_robot_m = np.column_stack(
            [ranges[hit] * np.cos(angles[hit]), ranges[hit] * np.sin(angles[hit])]
        )
        self._scan = (ranges, angles, range_max_m)

    def see(self) -> None:
        """The last scan's local obstacles and marks, at the estimate it was taken from; computed once per
        scan."""
        if self._scan is None:
            return
        ranges, angles, range_max_m = self._scan
        self._scan = None
        hits = scan_endpoints_xy_m(self._scan_pose, ranges, angles, range_max_m)
        pose = self._scan_pose
        r = self.config.local_obstacle_radius_m
        local = hits[(np.abs(hits[:, 0] - pose[0]) < r) & (np.abs(hits[:, 1] - pose[1]) < r)]
        self.marks = self.site_map.unexplained(hits, self.config.mark_beyond_m)
        self._mark_tree = cKDTree(self.marks) if len(self.marks) else None
        moving = self.site_map.unexplained_mask(local, self.config.mark_beyond_m)
        towards = pose[:2] - local[moving]
        distance = np.maximum(np.hypot(*towards.T), 1e-9)
        shift = np.minimum(self.config.dynamic_margin_m, np.maximum(distance - 0.05, 0.0))
        local[moving] += towards * (shift / distance)[:, None]
        self.local_points = local
        self.nearest_mark_m = float(distance.min()) if len(distance) else math.inf

    def marks_near(self, points_xy_m: NDArray[np.float64], within_m: float) -> bool:
        """Whether a mark lies within ``within_m`` of any of ``points_xy_m`` (the path ahead)."""
        if self._mark_tree is None:
            return False
        distance, _ = self._mark_tree.query(points_xy_m, k=1, distance_upper_bound=within_m)
        return bool(np.isfinite(distance).any())

    def nearest_mark(self, xy_m: NDArray[np.float64], robot_within_m: float) -> NDArray[np.float64] | None:
        """The mark nearest ``xy_m``, when a mark lies within ``robot_within_m`` of the robot; else None."""
        if self._mark_tree is None or self.nearest_mark_m > robot_within_m:
            return None
        _, index = self._mark_tree.query(xy_m)
        return self.marks[index]

    def obstacles(self, pose: NDArray[np.float64]) -> NDArray[np.float64]:
        """The DWA's obstacles around ``pose``: the static outlines nearby and the local points."""
        static = self.site_map.obstacle_points_xy_m()
        r = self.config.local_obstacle_radius_m
        near = (np.abs(static[:, 0] - pose[0]) < r) & (np.abs(static[:, 1] - pose[1]) < r)
        return np.vstack([static[near], self.local_points])

    def clear_behind(self, pose: NDArray[np.float64]) -> bool:
        """Whether backing up ``backup_s`` keeps the robot as clear of obstacles as it is now."""
        points = self.obstacles(pose)
        if len(points) == 0:
            return True
        config = self.config
        distance = config.backup_speed_mps * config.backup_s
        behind = pose[:2] - distance * np.array([math.cos(pose[2]), math.sin(pose[2])])
        samples = pose[:2] + np.linspace(0.0, 1.0, 5)[1:, None] * (behind - pose[:2])
        gap = np.hypot(points[None, :, 0] - samples[:, None, 0], points[None, :, 1] - samples[:, None, 1])
        now = np.hypot(points[:, 0] - pose[0], points[:, 1] - pose[1]).min()
        return bool(gap.min() > min(config.dwa.robot_radius_m + 0.05, now - 1e-6))
