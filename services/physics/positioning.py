"""A positioning sensor on site: a robotic total station that tracks two prisms on every ground robot.

Why: a robot localises by odometry and its laser against the map (AMCL); where nothing stands within its
laser's range — the middle of a large, still empty footprint, where the first footings go — the laser has
nothing to match and the estimate drifts on odometry alone (on the 988-component site robots set footings
0.1–1.7 m off). Real sites set foundations out from a total station or RTK GNSS; robots that place
components do the same. Physics plays the instrument: each control period it measures the true position of
each ground robot's base origin and, from two prisms a robot length apart along its axis, which way it
faces, and adds Gaussian noise: the instrument's standard deviation on the position, √2 of it over the
prisms' baseline on the heading (3 mm and a 1 m robot: 0.24°). Position alone would not do: a robot
places at arm's length, where a heading 1° off moves the component 26 mm. Its line of sight is not
modelled: it stands high enough to see every robot. A tower crane needs none (it stands where it was built).

On in the rehearsal profile (``bimbot run``, the demo, compose: 3 mm), off in ``fine`` and with
``--total-station-mm 0``: the paper's robots localise by laser alone, as the bundled frame can be built.
"""

from __future__ import annotations

import math

import numpy as np

from bimbot.shared.messages import PositionFixMsg

STREAM = 7  # the noise's own random stream, apart from odometry's (seeded per robot as [seed, index])


class TotalStation:
    """Noisy fixes of robot positions, one seeded stream per robot (reproducible like odometry)."""

    def __init__(self, std_m: float, seed: int) -> None:
        if not std_m > 0.0:
            raise ValueError("a total station's standard deviation must be > 0 m")
        self.std_m, self._seed = std_m, seed
        self._rngs: dict[str, np.random.Generator] = {}

    def fix(
        self, robot_id: str, true_xy_yaw: tuple[float, float, float], baseline_m: float, now_s: float
    ) -> PositionFixMsg:
        """The fix of ``robot_id``, truly at ``true_xy_yaw``, whose two prisms stand ``baseline_m`` apart,
        at sim time ``now_s``."""
        rng = self._rngs.get(robot_id)
        if rng is None:
            rng = self._rngs[robot_id] = np.random.default_rng([self._seed, STREAM, len(self._rngs)])
        yaw_std_rad = math.sqrt(2.0) * self.std_m / baseline_m
        dx, dy = rng.normal(0.0, self.std_m, 2)
        dyaw = float(rng.normal(0.0, yaw_std_rad))
        x, y, yaw = true_xy_yaw
        return PositionFixMsg(
            robot_id=robot_id,
            position_xy_m=(x + float(dx), y + float(dy)),
            std_m=self.std_m,
            yaw_rad=math.remainder(yaw + dyaw, 2.0 * math.pi),
            yaw_std_rad=yaw_std_rad,
            sim_time_s=now_s,
        )
