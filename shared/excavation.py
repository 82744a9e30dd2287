"""The excavation the sequence and physics share: a pit under every foundation, open until it is placed.

Why shared: physics digs a pit under every component whose target reaches more than ``BELOW_GROUND_M``
below ground (:mod:`bimbot.services.physics.pits`), ``WORKING_SPACE_M`` wider than it, and what is released
with its centre over an open pit drops in. So the sequence places that foundation before what stands
over its excavation with nothing else to hold it (:mod:`.support_graph`), whether or not the model draws
the two touching: the restaurant's courtyard
floor panels and curbs are drawn 0.1-0.4 m above the 0.7 m exterior floor slab under them (the fill
between is not modelled), its handrails 0.9 m above it, and released before the slab's bays were cast
they fell into its pits, three times each, and failed. A site builds bottom-up: the excavation's
foundations are cast, the fill laid and compacted, then what stands over them.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .manifest import Component

BELOW_GROUND_M = 0.02  # a target bottom deeper than this below ground makes a pit
WORKING_SPACE_M = 0.1  # an excavation is this much wider than its foundation on every side


def over_open_pits(components: Sequence[Component], tolerance_m: float) -> list[tuple[str, str]]:
    """(foundation, component) pairs: ``component`` stands over the pit of ``foundation`` (the centre of
    its footprint within the excavation, its bottom no lower than the foundation's top less
    ``tolerance_m``), so the foundation comes first."""
    if not components:
        return []
    low = np.array([item.bbox_world.min_m for item in components])
    high = np.array([item.bbox_world.max_m for item in components])
    centre = (low[:, :2] + high[:, :2]) / 2.0
    pairs: list[tuple[str, str]] = []
    for index in np.flatnonzero(low[:, 2] < -BELOW_GROUND_M):
        x0, y0 = low[index, :2] - WORKING_SPACE_M
        x1, y1 = high[index, :2] + WORKING_SPACE_M
        over = (
            (low[:, 2] >= high[index, 2] - tolerance_m)
            & (centre[:, 0] >= x0)
            & (centre[:, 0] <= x1)
            & (centre[:, 1] >= y0)
            & (centre[:, 1] <= y1)
        )
        over[index] = False
        foundation = components[int(index)].guid
        pairs.extend((foundation, components[int(other)].guid) for other in np.flatnonzero(over))
    return pairs
