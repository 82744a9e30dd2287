"""Whether a component is shaped as a bar: a rod, strut, hanger or brace, whatever class it was exported as.

Why: an authoring tool exports a family with no IFC class of its own as ``IfcBuildingElementProxy``, a
canopy's hanger rods as much as a kitchen cabinet. A joint rule with ``slender = true`` applies only to a
member of this shape, so a hanger's end drawn through the deck it carries is told from a cabinet drawn into
a floor. The shape is read from the component's collision parts: the smallest box around their vertices,
turned to fit them (trimesh's oriented bounds), whose longest side is at least :data:`BAR_RATIO` times its
next, however the bar lies (a hanger runs on the slant).
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from bimbot.shared.manifest import Component

from .overlaps import obj_vertices

_log = logging.getLogger(__name__)

BAR_RATIO = 10.0  # a bar is at least this many times longer than its section's larger side


class BarShapes:
    """Which components of a build folder are bars, read once each."""

    def __init__(self, out_dir: Path) -> None:
        self._out_dir = out_dir
        self._known: dict[str, bool] = {}

    def is_bar(self, component: Component) -> bool:
        """Whether ``component``'s oriented box is at least :data:`BAR_RATIO` times longer than wide."""
        if component.guid not in self._known:
            self._known[component.guid] = self._measure(component)
        return self._known[component.guid]

    def _measure(self, component: Component) -> bool:
        clouds = []
        for name in component.files.collision:
            try:
                clouds.append(obj_vertices(self._out_dir / name))
            except (OSError, ValueError) as error:
                _log.debug("%s: collision part %s not read (%s)", component.guid, name, error)
        if not clouds:
            return False
        points = np.unique(np.vstack(clouds).round(6), axis=0)
        if len(points) < 4:
            return False
        import trimesh.bounds  # here, not at the top: trimesh and scipy cost a command ~1 s of imports

        try:
            _, extents = trimesh.bounds.oriented_bounds(points)
        except (ValueError, RuntimeError) as error:  # flat or degenerate: no hull to fit a box to
            _log.debug("%s: no oriented box (%s)", component.guid, error)
            return False
        longest, middle = sorted((float(e) for e in extents), reverse=True)[:2]
        return longest >= BAR_RATIO * max(middle, 1e-6)
