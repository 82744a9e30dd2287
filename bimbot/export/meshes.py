"""The converter's visual meshes read back for the exports (component frame, metres)."""

from __future__ import annotations

import logging
from pathlib import Path

import trimesh

_log = logging.getLogger(__name__)


def load_triangles(path: Path) -> trimesh.Trimesh | None:
    """The triangle mesh in ``path`` (an OBJ the converter wrote); None when absent, unreadable or empty."""
    if not path.is_file():
        return None
    try:
        mesh = trimesh.load(str(path), force="mesh", process=False)
    except Exception as error:  # trimesh raises many kinds (format, a loader's own bug)
        _log.warning("%s cannot be loaded (%s): exported without its shape", path, error)
        return None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        return None
    return mesh
