"""One number seeds a run: each service and each robot draws from a stream of its own derived from it.

``bimbot run --seed N`` passes ``N`` to physics (odometry noise, placement precision, position fixes: one
stream per robot inside physics) and to every robot, whose particle filter draws from
:func:`robot_stream` — the seed and the robot's id — so two robots never share draws and a robot's draws
do not depend on how many others are on site. CRC-32, not ``hash``: Python salts ``hash`` per process.
"""

from __future__ import annotations

import zlib

DEFAULT_SEED = 0


def robot_stream(seed: int, robot_id: str) -> list[int]:
    """The entropy of ``robot_id``'s own random stream under the run's ``seed`` (``numpy.random.
    default_rng`` takes it as is)."""
    if seed < 0:
        raise ValueError(f"a seed is a whole number ≥ 0, got {seed}")
    return [seed, zlib.crc32(robot_id.encode("utf-8"))]
