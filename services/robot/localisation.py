"""AMCL-style localisation of one robot on the site map: a particle filter fed by odometry and the laser,
and by a positioning sensor's fixes where the site has one (a robotic total station, fused with the scan
of the same period: :func:`.particle_filter.fix_update`).

Why: odometry drifts (physics disturbs every increment), so the robot's pose comes from matching its laser
against the map, as AMCL does under ROS move_base. The estimate between filter updates is the last
filter estimate composed with the odometry since then (AMCL's map→odom correction), so it moves smoothly
every control step. The filter itself (:mod:`.particle_filter`: odometry motion model, likelihood field of
the scan against :meth:`.site_map.SiteMap.laser_grid`, low-variance resampling) runs only after the
robot moved ``update_min_d_m`` or turned ``update_min_a_rad`` (AMCL's ``update_min_d/a``): a robot
standing still does not collapse its particles onto one scan, and a moving one pays for an update every
other control step at full speed. The likelihood field is rebuilt when the map changes (one distance
transform). Initialised around the start pose physics reports (:class:`bimbot.shared.messages.SiteInfoMsg`).

A scan may be **deferred** (``observe_scan(..., defer=True)``): it is kept with the odometry it was seen at
and the filter runs on it in :meth:`Localiser.update`, which the robot calls right after it sent its
command for the step, so the filter (the robot's heaviest work) overlaps physics stepping the next period
instead of delaying the command (docs/performance.md). The estimate is the same: the scan is matched at
the odometry it was taken at and the odometry since then is composed on top; it corrects the pose from the
next step on. A deferred scan not updated by then is taken before the next scan.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from bimbot.shared.geometry import wrap_angle

from .particle_filter import (
    LikelihoodField,
    LikelihoodFieldConfig,
    OdometryNoise,
    ParticleFilterConfig,
    PositionFix,
    init_gaussian,
    mcl_step,
)
from .site_map import SiteMap

_log = logging.getLogger(__name__)


# Physics disturbs each odometry increment by ~2 % (distance) and 2 % of the turn plus 0.004 rad/m: the motion
# model's noise is a few times that, not AMCL's generic 0.2 (measured: with alphas of 0.05 the filter random-
# walks along corridors where the laser constrains little, and ends up worse than plain odometry).
ODOMETRY_NOISE = OdometryNoise(
    alpha1_rot_from_rot=0.005,
    alpha2_rot_from_trans=0.002,
    alpha3_trans_from_trans=0.005,
    alpha4_trans_from_rot=0.002,
)


@dataclass(frozen=True)
class LocaliserConfig:
    pf: ParticleFilterConfig = field(default_factory=lambda: ParticleFilterConfig(noise=ODOMETRY_NOISE))
    particles: int = 400
    init_std_xy_m: float = 0.05
    init_std_yaw_rad: float = 0.03
    update_min_d_m: float = 0.15  # AMCL update_min_d
    update_min_a_rad: float = 0.15  # AMCL update_min_a


def compose_delta(
    base_xy_yaw: ArrayLike, prev_xy_yaw: ArrayLike, now_xy_yaw: ArrayLike
) -> NDArray[np.float64]:
    """``base`` moved by the odometry increment prev→now, the increment taken in prev's frame."""
    base, prev, now = (np.asarray(v, float) for v in (base_xy_yaw, prev_xy_yaw, now_xy_yaw))
    c, s = math.cos(prev[2]), math.sin(prev[2])
    dx, dy = now[0] - prev[0], now[1] - prev[1]
    forward, left = c * dx + s * dy, -s * dx + c * dy
    cb, sb = math.cos(base[2]), math.sin(base[2])
    return np.array(
        [
            base[0] + cb * forward - sb * left,
            base[1] + sb * forward + cb * left,
            float(wrap_angle(base[2] + now[2] - prev[2])),
        ]
    )


# ranges, angles, range max, the odometry it was taken at, and the position fix taken with it (or None)
MAX_STILL_FIXES = 25  # 5 s of fixes at a 0.2 s control period
_Scan = tuple[NDArray[np.float64], NDArray[np.float64], float, NDArray[np.float64], PositionFix | None]


class Localiser:
    """Pose estimate ``pose`` (x_m, y_m, yaw_rad, map frame) from odometry and scans (see the module doc)."""

    def __init__(
        self,
        site_map: SiteMap,
        start_xy_yaw: ArrayLike,
        config: LocaliserConfig = LocaliserConfig(),
        rng: np.random.Generator | None = None,
    ) -> None:
        self.site_map, self.config = site_map, config
        self.rng = rng or np.random.default_rng(0)
        start = np.asarray(start_xy_yaw, float)
        self.particles = init_gaussian(
            start, config.init_std_xy_m, config.init_std_yaw_rad, config.particles, self.rng
        )
        self.pose = start.copy()
        self.odom: NDArray[np.float64] | None = None
        self.updates = 0
        self._anchor_pose = start.copy()  # estimate at the last filter update
        self._anchor_odom: NDArray[np.float64] | None = None  # odometry at the last filter update
        self._field: LikelihoodField | None = None
        self._field_version = -1
        self._sensor: LikelihoodFieldConfig | None = None
        self._pending: _Scan | None = None  # a deferred scan
        self._fix: PositionFix | None = None  # the positioning sensor's fix of this period, for its scan
        self.fixes = 0  # filter updates that fused a position fix
        self._still: list[PositionFix] = []  # the fixes since the odometry last changed (standing still)
        self._still_odom: NDArray[np.float64] | None = None

    def spread(self, std_xy_m: float, std_yaw_rad: float) -> None:
        """Re-localise: draw the particles again around the estimate, this wide (AMCL's answer to a robot
        that learns it is not where it believes, here a reach refusal by physics). The next updates, as the
        robot moves, pull them back onto the pose the laser supports."""
        self.particles = init_gaussian(self.pose, std_xy_m, std_yaw_rad, self.config.particles, self.rng)
        _log.warning(
            "re-localising around %s with %.2f m / %.2f rad",
            np.round(self.pose, 2).tolist(),
            std_xy_m,
            std_yaw_rad,
        )

    def set_pose(self, pose_xy_yaw: ArrayLike, std_xy_m: float = 0.01, std_yaw_rad: float = 0.005) -> None:
        """Take ``pose_xy_yaw`` as the estimate now (a fine alignment found it): the odometry from here on
        is composed on it, and the particles are drawn again tightly around it."""
        self.pose = np.asarray(pose_xy_yaw, float).copy()
        self._anchor_pose = self.pose.copy()
        if self.odom is not None:
            self._anchor_odom = self.odom.copy()
        self._pending = None
        self.particles = init_gaussian(self.pose, std_xy_m, std_yaw_rad, self.config.particles, self.rng)

    def observe_odom(self, odom_xy_yaw: ArrayLike) -> None:
        self.odom = np.asarray(odom_xy_yaw, float)
        if self._anchor_odom is None:
            self._anchor_odom = self.odom.copy()
        self.pose = compose_delta(self._anchor_pose, self._anchor_odom, self.odom)

    def observe_fix(self, fix: PositionFix) -> None:
        """A positioning sensor's fix, taken with this period's scan: fused with it (:meth:`observe_scan`
        comes next in the same period), and kept while the robot stands still (:meth:`still_fix_pose`)."""
        self._fix = fix
        odom = self.odom
        if (
            odom is not None
            and self._still_odom is not None
            and np.allclose(odom, self._still_odom, atol=1e-4)
        ):
            self._still = [*self._still[-(MAX_STILL_FIXES - 1) :], fix]
        else:
            self._still, self._still_odom = [fix], None if odom is None else odom.copy()

    def still_fix_pose(self) -> tuple[NDArray[np.float64], int] | None:
        """The mean of the fixes taken since the robot last moved (position, and heading as a circular
        mean) and how many they are; None without fixes. Standing still before a placement, n fixes give
        the pose √n times sharper than one (a layout robot measures before it marks)."""
        if not self._still or self.odom is None or self._still_odom is None:
            return None
        if not np.allclose(self.odom, self._still_odom, atol=1e-4):
            return None  # moved since
        xy = np.mean([fix.xy_m for fix in self._still], axis=0)
        yaws = np.array([fix.yaw_rad for fix in self._still])
        yaw = math.atan2(float(np.sin(yaws).mean()), float(np.cos(yaws).mean()))
        return np.array([xy[0], xy[1], yaw]), len(self._still)

    def still_fix_std_m(self) -> float:
        """The standard deviation of :meth:`still_fix_pose`'s position (per axis): the fixes' own over √n."""
        if not self._still:
            return math.inf
        return float(np.mean([fix.std_m for fix in self._still])) / math.sqrt(len(self._still))

    def observe_scan(
        self,
        ranges_m: NDArray[np.float64],
        angles_rad: NDArray[np.float64],
        range_max_m: float,
        *,
        defer: bool = False,
    ) -> bool:
        """Run the filter on this scan if the robot moved enough since the last update; True if it ran.
        ``defer``: keep it for :meth:`update` (a scan still pending is taken first)."""
        self.update()
        fix, self._fix = self._fix, None
        if self.odom is None or self._anchor_odom is None:
            return False
        if defer:
            self._pending = (ranges_m, angles_rad, range_max_m, self.odom.copy(), fix)
            return False
        return self._filter(ranges_m, angles_rad, range_max_m, self.odom, fix)

    def update(self) -> bool:
        """Run the filter on the deferred scan, if any (and the robot moved enough); True if it ran."""
        pending, self._pending = self._pending, None
        return pending is not None and self._filter(*pending)

    def _filter(
        self,
        ranges_m: NDArray[np.float64],
        angles_rad: NDArray[np.float64],
        range_max_m: float,
        odom_at_scan: NDArray[np.float64],
        fix: PositionFix | None = None,
    ) -> bool:
        """One filter step from the last update's odometry to ``odom_at_scan`` (where the scan, and the fix
        with it, was taken); the odometry since then is composed on top of the new estimate."""
        assert self.odom is not None and self._anchor_odom is not None
        moved = math.hypot(*(odom_at_scan[:2] - self._anchor_odom[:2]))
        turned = abs(float(wrap_angle(odom_at_scan[2] - self._anchor_odom[2])))
        if moved < self.config.update_min_d_m and turned < self.config.update_min_a_rad:
            return False
        if self._field is None or self._field_version != self.site_map.version:
            # Surfaces only: inside a thick wall the distance grows again, so the likelihood peaks where the
            # laser really hits (a filled wall makes a plateau the estimate drifts along).
            geometry = self.site_map.laser_field_geometry
            self._field = LikelihoodField(
                self.site_map.laser_distance_m(), geometry.resolution_m, geometry.origin_xy_m
            )
            self._field_version = self.site_map.version
        if self._sensor is None or self._sensor.max_range_m != range_max_m:
            self._sensor = replace(self.config.pf.sensor, max_range_m=range_max_m)
        self.particles, estimate = mcl_step(
            self.particles,
            self._anchor_odom,
            odom_at_scan,
            ranges_m,
            angles_rad,
            field=self._field,
            config=replace(self.config.pf, sensor=self._sensor),
            rng=self.rng,
            fix=fix,
        )
        self.fixes += fix is not None
        self._anchor_pose, self._anchor_odom = estimate.pose_xy_yaw.copy(), odom_at_scan.copy()
        self.pose = compose_delta(self._anchor_pose, self._anchor_odom, self.odom)
        self.updates += 1
        return True
