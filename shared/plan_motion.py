"""Timed kinematic motion along a planned path, for the plan fidelity (pure; no numpy).

Why shared: in the plan fidelity a ground robot does not drive by velocity commands. Its executor plans
its A* path as before and publishes it (``PlanMsg``); the robot and physics then both pose it by this one
function of sim time: turn on the spot onto each leg at the type's turn limit, drive the leg at its speed
limit. Physics so knows when the drive ends (an event its clock can jump to) and where the robot is
meanwhile, and the two never disagree, without a second message on the bus.

Units: metres, radians, sim seconds; world (map) frame.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence
from dataclasses import dataclass

from .geometry import wrap_angle

MIN_LEG_M = 1e-6  # a leg shorter than this is no leg (the path's repeated start point)


@dataclass(frozen=True)
class Trajectory:
    """Poses at key times (turn starts and ends, leg ends); linear in between (yaw the short way)."""

    times_s: tuple[float, ...]
    poses: tuple[tuple[float, float, float], ...]  # (x, y, yaw) at each key time

    @property
    def start_s(self) -> float:
        return self.times_s[0]

    @property
    def end_s(self) -> float:
        return self.times_s[-1]

    @property
    def length_m(self) -> float:
        return sum(
            math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in zip(self.poses, self.poses[1:], strict=False)
        )

    def pose_at(self, sim_s: float) -> tuple[float, float, float]:
        """The pose at ``sim_s`` (the first before the start, the last after the end)."""
        times = self.times_s
        if sim_s <= times[0]:
            return self.poses[0]
        if sim_s >= times[-1]:
            return self.poses[-1]
        index = bisect.bisect_right(times, sim_s) - 1
        t0, t1 = times[index], times[index + 1]
        (x0, y0, a0), (x1, y1, a1) = self.poses[index], self.poses[index + 1]
        share = (sim_s - t0) / (t1 - t0) if t1 > t0 else 1.0
        turn = wrap_angle(a1 - a0)
        return (x0 + share * (x1 - x0), y0 + share * (y1 - y0), wrap_angle(a0 + share * turn))

    def distance_at(self, sim_s: float) -> float:
        """Metres driven along the path by ``sim_s``."""
        done = 0.0
        for index in range(1, len(self.poses)):
            (x0, y0, _), (x1, y1, _) = self.poses[index - 1], self.poses[index]
            if self.times_s[index] <= sim_s:
                done += math.hypot(x1 - x0, y1 - y0)
                continue
            x, y, _ = self.pose_at(sim_s)
            return done + math.hypot(x - x0, y - y0) if sim_s > self.times_s[index - 1] else done
        return done


def standing(xy_yaw: Sequence[float], sim_s: float) -> Trajectory:
    """A robot standing at ``xy_yaw`` from ``sim_s`` on."""
    x, y, yaw = (float(value) for value in xy_yaw)
    return Trajectory((sim_s,), ((x, y, yaw),))


def trajectory(
    path_xy_m: Sequence[Sequence[float]],
    start_yaw_rad: float,
    start_s: float,
    *,
    speed_mps: float,
    turn_radps: float,
) -> Trajectory:
    """The timed motion along ``path_xy_m`` from ``start_s``: per leg a turn on the spot onto it at
    ``turn_radps``, then the leg at ``speed_mps``. The robot ends facing along its last leg."""
    if not path_xy_m:
        raise ValueError("a path needs at least its start point")
    if speed_mps <= 0.0 or turn_radps <= 0.0:
        raise ValueError("a robot that drives needs a speed and a turn rate above 0")
    x, y = float(path_xy_m[0][0]), float(path_xy_m[0][1])
    yaw = wrap_angle(float(start_yaw_rad))
    now = float(start_s)
    times, poses = [now], [(x, y, yaw)]
    for point in path_xy_m[1:]:
        nx, ny = float(point[0]), float(point[1])
        length = math.hypot(nx - x, ny - y)
        if length < MIN_LEG_M:
            continue
        heading = math.atan2(ny - y, nx - x)
        turn = abs(wrap_angle(heading - yaw))
        if turn > 0.0:
            now += turn / turn_radps
            yaw = heading
            times.append(now)
            poses.append((x, y, yaw))
        now += length / speed_mps
        x, y = nx, ny
        times.append(now)
        poses.append((x, y, yaw))
    return Trajectory(tuple(times), tuple(poses))
