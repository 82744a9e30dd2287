"""Mesh files of a component model folder (the trimesh ↔ file boundary).

Every model folder gets ``meshes/visual.dae`` (Gazebo), ``meshes/visual.obj`` (PyBullet and most tools),
``meshes/visual.glb`` (web viewers, rerun) and one ``meshes/collision_<i>.obj`` per convex part. All are in
the component's own frame, metres. Components that share geometry share the files' contents: the first
folder gets them written, the others get hard links (a copy where the file system refuses links).
"""

from __future__ import annotations

import os
import shutil
from dataclasses import dataclass
from pathlib import Path

import trimesh

VISUAL_DAE = "meshes/visual.dae"
VISUAL_OBJ = "meshes/visual.obj"
VISUAL_GLB = "meshes/visual.glb"


def collision_file(index: int) -> str:
    return f"meshes/collision_{index}.obj"


@dataclass(frozen=True)
class GeometryFiles:
    """Paths relative to a model folder."""

    visual_dae: str
    visual_obj: str
    visual_glb: str
    collision: tuple[str, ...]

    def all(self) -> tuple[str, ...]:
        return (self.visual_dae, self.visual_obj, self.visual_glb, *self.collision)


def write_geometry_files(
    model_dir: Path, visual: trimesh.Trimesh, collision_parts: tuple[trimesh.Trimesh, ...]
) -> GeometryFiles:
    files = GeometryFiles(
        VISUAL_DAE,
        VISUAL_OBJ,
        VISUAL_GLB,
        tuple(collision_file(index) for index in range(len(collision_parts))),
    )
    (model_dir / "meshes").mkdir(parents=True, exist_ok=True)
    visual.export(model_dir / files.visual_dae, file_type="dae")
    visual.export(model_dir / files.visual_obj, file_type="obj", include_normals=False, include_texture=False)
    visual.export(model_dir / files.visual_glb, file_type="glb")
    for part, name in zip(collision_parts, files.collision, strict=True):
        part.export(model_dir / name, file_type="obj", include_normals=False, include_texture=False)
    return files


def link_geometry_files(source_dir: Path, target_dir: Path, files: GeometryFiles) -> None:
    """Give ``target_dir`` the same mesh files as ``source_dir`` (hard links, else copies)."""
    (target_dir / "meshes").mkdir(parents=True, exist_ok=True)
    for name in files.all():
        target = target_dir / name
        if target.exists():
            target.unlink()
        try:
            os.link(source_dir / name, target)
        except OSError:
            shutil.copyfile(source_dir / name, target)
