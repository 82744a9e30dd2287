"""Boards drawn inside a wall's thickness are built into it (``with_host``), not set on their own.

Why: a model may draw blocking, a backing board or a nailer as a proxy lying inside the wall it belongs to
(the Janesville restaurant: a 23 mm board, 0.38 m high and 8.5 m long, 21 mm inside the face of its 190 mm
restroom walls at 2.7 m, where the toilet partitions' head rails are braced). A robot cannot set such a
board after the wall stands (it is inside it) nor before (nothing holds it in the air); a framer fixes it
between the studs as the wall goes up. So a lifted ``IfcBuildingElementProxy`` that is a board (its least
side at most :data:`BOARD_MAX_M`) and lies inside one wall (:data:`INSIDE_SHARE` of its box within the
wall's own box, in the wall's frame, clear of both its faces: a trim drawn into a wall's face is fixed on
it, :mod:`.joints`; a wall this build puts up, not existing work) becomes ``with_host``: :mod:`.guest_hosts`
then finds the wall it is embedded in and :mod:`.guest_merge` builds it into that wall. A method the
user's methods file gave is kept. Pure, over the manifest entries' boxes and poses.
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import product

import numpy as np

from bimbot.shared.construction_methods import ConstructionMethod, MethodSource
from bimbot.shared.manifest import Component

from .placement import in_pose_frame

BOARD_MAX_M = 0.10  # a board's least side
INSIDE_SHARE = 0.9  # of its box's volume within the wall's box…
COVER_M = 0.01  # …and this far from both its faces: inside it, not a trim drawn into its face
HOSTS = ("IfcWall",)
BOARDS = ("IfcBuildingElementProxy",)
# walls this build puts up: a board in existing work (in place) is new work set into it, not blocking
BUILT_HOSTS = (
    ConstructionMethod.LIFTED,
    ConstructionMethod.PANELISED,
    ConstructionMethod.LAID,
    ConstructionMethod.CAST_IN_PLACE,
)


def build_in_boards(components: Sequence[Component]) -> list[Component]:
    """``components`` with each board drawn inside a wall made ``with_host`` (see the module doc)."""
    walls = [c for c in components if c.ifc_class.startswith(HOSTS) and c.method in BUILT_HOSTS]
    if not walls:
        return list(components)
    lows = np.array([wall.bbox_world.min_m for wall in walls], dtype=float)
    highs = np.array([wall.bbox_world.max_m for wall in walls], dtype=float)
    decided: list[Component] = []
    for component in components:
        wall = _wall_of(component, walls, lows, highs)
        if wall is None:
            decided.append(component)
            continue
        note = f"a board drawn inside the thickness of {wall.name or wall.guid}: built into it as it goes up"
        update = {
            "method": ConstructionMethod.WITH_HOST,
            "method_source": MethodSource.RULE,
            "method_note": note,
        }
        decided.append(component.model_copy(update=update))
    return decided


def _wall_of(
    component: Component, walls: Sequence[Component], lows: np.ndarray, highs: np.ndarray
) -> Component | None:
    """The wall ``component`` is a board drawn inside, or None."""
    if (
        not component.ifc_class.startswith(BOARDS)
        or component.method is not ConstructionMethod.LIFTED
        or component.method_source is MethodSource.USER
    ):
        return None
    low, high = np.asarray(component.bbox_world.min_m), np.asarray(component.bbox_world.max_m)
    size = high - low
    if size.min() > BOARD_MAX_M or np.prod(size) <= 0.0:
        return None
    near = np.flatnonzero(np.all((lows <= high) & (highs >= low), axis=1))  # world boxes that meet it
    corners = np.array(list(product(*zip(low, high, strict=True))), dtype=float)
    best, best_share = None, INSIDE_SHARE
    for index in near:
        wall = walls[int(index)]
        if wall.guid == component.guid:
            continue
        share, thinner = _inside_share(corners, size.min(), wall)
        if thinner and share >= best_share:
            best, best_share = wall, share
    return best


def _inside_share(corners_world_m: np.ndarray, least_side_m: float, wall: Component) -> tuple[float, bool]:
    """(the share of the board's box, taken in the wall's frame, inside the wall's own box; whether the
    board is thinner than the wall and covered on both sides: :data:`COVER_M` from either face)."""
    local = in_pose_frame(wall.target_pose_world, corners_world_m)
    low, high = local.min(axis=0), local.max(axis=0)
    w_low, w_high = np.asarray(wall.bbox_local.min_m), np.asarray(wall.bbox_local.max_m)
    volume = float(np.prod(high - low))
    inside = float(np.prod(np.clip(np.minimum(high, w_high) - np.maximum(low, w_low), 0.0, None)))
    across = int(np.argmin(w_high - w_low))  # the wall's thickness
    covered = min(low[across] - w_low[across], w_high[across] - high[across]) >= COVER_M
    within = least_side_m < float(w_high[across] - w_low[across]) and covered
    return (inside / volume if volume > 0.0 else 0.0), within
