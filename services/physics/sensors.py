"""A simulated 2D laser scanner per ground robot (a tower crane has none): one scan per robot per control
period, cast by the compiled caster (:mod:`.ray_scene`, :mod:`.ray_kernel`: exact ray–shape intersections
against the same collision shapes, about a tenth of the cost) or, where it cannot stand in (a shape it
does not represent) and with ``SimConfig(compiled_laser=False)``, by Bullet's ``rayTestBatch`` as below.

Beams fan out in the robot's base frame (so they tilt with the chassis) from a mount point
``height_m`` above the ground at rest. The batch carries a collision filter mask (:mod:`.scene`) that
leaves out the ground plane, the robot's own body and the load it carries (which shares the robot's group
bit), so a scan shows the fence, yard items, the structure, other robots and their loads.

Why the default height is 0.06 m and not a Husky's usual ~0.35 m: components lie flat in the yard, and the
bundled frame's are 0.08–0.3 m high (a beam on its side, a footing), so a laser at 0.35 m would see none of
them. Placed footings (tops at z = 0) stay invisible, as they should: robots drive over them.

Each ray starts just outside the robot's rectangular footprint (:meth:`Laser.beam_starts`): cheaper (a
ray starting inside the robot tests all its links), and nearer than that is inside the robot anyway. So a
scan's minimum range is that start distance (≈ 0.36–0.63 m around a Husky), like a real scanner's.

Bullet's casts go near first, then far (:data:`NEAR_SEGMENT_M`): Bullet tests a ray against every body whose
bounding box it crosses over its whole length and only then keeps the closest hit (and pybullet applies the
filter mask after that test), so a 15 m beam through a yard costs a narrow-phase test per item along it even
when the first item is 1 m away. Every beam is therefore cast to ``NEAR_SEGMENT_M`` first, and only the
beams that hit nothing there go on to the full range, from a little before that point
(:data:`SEGMENT_OVERLAP_M`, well over the 1 mm hull margin, within which a ray starting just short of a
surface would report a hit at its own start). The closest hit is the same either way; measured over 40
random poses (`bench/physics.py` prints the scan's cost): a 180-beam scan 0.73 → 0.56 ms in the bundled
frame's yard and 2.19 → 0.88 ms in a 988-component site's, with the same error against short reference rays
(mean < 0.01 mm; Bullet's convex cast has rare mm outliers either way: max 2.7 → 2.7 and 3.6 → 3.0 mm).

ScanMsg conventions: ``angle_min_rad`` is the first beam's angle from the robot's +x axis (counter-clockwise
positive); a full circle has ``beams`` beams over [-π, π), a narrower fan ``beams`` beams from -fov/2 to
+fov/2 inclusive; a beam without a return reads ``range_max_m`` (JSON has no infinity).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .client import p
from .profiles import FINE
from .ray_scene import RayScene
from .scene import ALL_GROUPS, GROUND_GROUP, PIT_EDGE_GROUP, Frame, compose

FULL_CIRCLE_RAD = 2.0 * math.pi
NEAR_SEGMENT_M = 4.0  # beams are cast this far first; the ones that hit nothing go on (see the module doc)
SEGMENT_OVERLAP_M = 0.25  # the far segment starts this much before the near one's end


@dataclass(frozen=True)
class LaserConfig:
    beams: int = FINE.laser_beams
    fov_rad: float = FULL_CIRCLE_RAD
    range_max_m: float = 15.0
    height_m: float = 0.06  # above the ground, robot at rest
    mount_x_m: float = 0.0  # forward of the base frame origin
    decimals: int = 3  # ranges rounded to mm: shorter messages, no fake precision

    def __post_init__(self) -> None:
        if self.beams < 1 or not 0.0 < self.fov_rad <= FULL_CIRCLE_RAD or self.range_max_m <= 0.0:
            raise ValueError("laser: beams ≥ 1, 0 < fov ≤ 2π and a positive range are required")


class Laser:
    """Precomputed beam directions; :meth:`scan` casts them from a mount frame."""

    def __init__(self, config: LaserConfig) -> None:
        self.config = config
        full = config.fov_rad >= FULL_CIRCLE_RAD - 1e-9
        if full:
            self.angle_min_rad = -math.pi
            self.angle_increment_rad = FULL_CIRCLE_RAD / config.beams
        else:
            self.angle_min_rad = -config.fov_rad / 2.0
            self.angle_increment_rad = config.fov_rad / max(1, config.beams - 1)
        angles = self.angle_min_rad + self.angle_increment_rad * np.arange(config.beams)
        self._directions = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=1)

    def beam_starts(self, half_extents_xy_m: tuple[float, float], margin_m: float = 0.02) -> np.ndarray:
        """Per beam, the distance from the mount to just outside the robot's rectangular footprint.

        Rays start there: a ray that begins inside the robot tests every one of its links (≈ 3× the cost of
        a scan, measured on the Husky) only to have them filtered out. Anything nearer is inside the
        robot's own footprint, where a real scanner cannot see either.
        """
        half_x, half_y = half_extents_xy_m
        mount_x = self.config.mount_x_m
        cos, sin = self._directions[:, 0], self._directions[:, 1]
        with np.errstate(divide="ignore"):
            along_x = np.where(
                cos > 0, (half_x - mount_x) / cos, np.where(cos < 0, (-half_x - mount_x) / cos, np.inf)
            )
            along_y = np.where(np.abs(sin) > 0, half_y / np.abs(sin), np.inf)
        starts = np.minimum(along_x, along_y) + margin_m
        return np.clip(starts, 0.0, 0.5 * self.config.range_max_m)

    def mount(self, base_frame: Frame, base_height_at_rest_m: float = 0.0) -> Frame:
        """The laser's frame: on the base frame, ``height_m`` above the ground (base frame at rest height)."""
        offset = (self.config.mount_x_m, 0.0, self.config.height_m - base_height_at_rest_m)
        return compose(base_frame, (offset, (0.0, 0.0, 0.0, 1.0)))

    def scan(
        self,
        client_id: int,
        mount_frame: Frame,
        own_group: int,
        starts_m: np.ndarray | None = None,
        scene: RayScene | None = None,
    ) -> list[float]:
        """Ranges (m) from ``mount_frame``, ignoring the ground and every body in ``own_group``; rays begin
        ``starts_m`` (per beam, see :meth:`beam_starts`) from the mount. With ``scene`` (posed this period)
        the compiled caster casts them; without, or where it cannot stand in, Bullet does."""
        origin = np.asarray(mount_frame[0], dtype=float)
        rotation = np.asarray(p.getMatrixFromQuaternion(mount_frame[1]), dtype=float).reshape(3, 3)
        limit = self.config.range_max_m
        begin = np.zeros(self.config.beams) if starts_m is None else np.array(starts_m, dtype=float)
        mask = ALL_GROUPS ^ GROUND_GROUP ^ PIT_EDGE_GROUP ^ own_group
        if scene is not None:
            full = self.config.fov_rad >= FULL_CIRCLE_RAD - 1e-9
            cast = scene.cast(
                origin,
                rotation,
                angle_min=self.angle_min_rad,
                angle_increment=self.angle_increment_rad,
                full_circle=full,
                starts=begin,
                range_max=limit,
                mask=mask,
            )
            if cast is not None:
                return np.round(cast, self.config.decimals).tolist()
        return self._bullet_scan(client_id, origin, rotation, begin, mask)

    def _bullet_scan(
        self, client_id: int, origin: np.ndarray, rotation: np.ndarray, begin: np.ndarray, mask: int
    ) -> list[float]:
        """The same ranges from Bullet's batched ray test, near segment first (see the module doc)."""
        directions = self._directions @ rotation.T
        limit = self.config.range_max_m
        ranges = np.full(len(directions), limit)
        unresolved = np.ones(len(directions), dtype=bool)
        for end_m in (NEAR_SEGMENT_M, limit) if limit > NEAR_SEGMENT_M else (limit,):
            casting = np.flatnonzero(unresolved & (begin < end_m))
            if len(casting) == 0:
                continue
            near = begin[casting]
            hits = p.rayTestBatch(
                (origin + directions[casting] * near[:, None]).tolist(),
                (origin + directions[casting] * end_m).tolist(),
                collisionFilterMask=mask,
                physicsClientId=client_id,
            )
            hit = np.fromiter((h[0] >= 0 for h in hits), dtype=bool, count=len(hits))
            fraction = np.fromiter((h[2] for h in hits), dtype=float, count=len(hits))
            ranges[casting[hit]] = near[hit] + fraction[hit] * (end_m - near[hit])
            unresolved[casting[hit]] = False
            missed = casting[~hit]
            begin[missed] = np.maximum(near[~hit], end_m - SEGMENT_OVERLAP_M)
        return np.round(ranges, self.config.decimals).tolist()
