"""Small geometry shared by every service: the point and quaternion types, and angle wrapping.

Units and frames as everywhere in bimbot: metres, radians, a Z-up right-handed world frame; quaternions in
pybullet's and scipy's ``(x, y, z, w)`` order (``quat_xyzw``).

The component agents' processes import this module (through :mod:`bimbot.shared.manifest`) and must not
load numpy, so numpy is imported only when an array is wrapped.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, overload

if TYPE_CHECKING:  # numpy only where arrays are wrapped: the agents' processes load this module without it
    import numpy as np
    from numpy.typing import ArrayLike, NDArray

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]  # (x, y, z, w)

_TWO_PI = 2.0 * math.pi


@overload
def wrap_angle(angle_rad: float) -> float: ...


@overload
def wrap_angle(angle_rad: ArrayLike) -> NDArray[np.float64]: ...


def wrap_angle(angle_rad: float | ArrayLike) -> float | NDArray[np.float64]:
    """Angles wrapped into [-π, π): a float for a float (plain arithmetic, cheap in per-step loops), an
    array for anything else (element-wise)."""
    if isinstance(angle_rad, float | int):
        return (angle_rad + math.pi) % _TWO_PI - math.pi
    import numpy as np  # here, not at the top: see the module doc

    return (np.asarray(angle_rad, dtype=float) + math.pi) % _TWO_PI - math.pi
