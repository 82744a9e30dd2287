"""A URDF's visual geometry as one triangle mesh per link, in the link's frame, ready for ``rr.Mesh3D``.

Boxes, cylinders (along z, as URDF has them) and spheres are made with ``trimesh.creation``; mesh files
(STL, OBJ, DAE, …, resolved against the URDF by :mod:`.urdf_model`) are loaded with trimesh, scaled and
placed at their visual origin. Each shape keeps its material's colour as vertex colours, so a link drawn in
one mesh still shows its parts (the Husky's black body and yellow top plate).

A mesh file that cannot be loaded (missing, a format trimesh cannot read) does not lose the link: the link
is drawn as the bounding box of its collision shapes (the box a physics engine would collide with), or a
small box at the visual's origin when it has none, and that file's warning is logged once
(:class:`LinkMeshes` remembers it). Meshes are cached by file, so robots of one type load each file once.

A mesh file of more than ``MESH_TRIANGLE_BUDGET`` triangles is thinned by vertex clustering on a
``MESH_CELL_M`` grid (vertices in one cell merge, triangles that collapse go): the recording carries each
robot's meshes once, and detail below a centimetre is not seen at site scale. pybullet_data's Husky goes
from 34 000 to 16 000 triangles (its wheels are 7 000 each).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

from .urdf_model import Geometry, Link, UrdfModel

_log = logging.getLogger(__name__)

CYLINDER_SECTIONS = 24
SPHERE_SUBDIVISIONS = 2
FALLBACK_SIZE_M = 0.2  # a link with an unreadable mesh and no collision shape: a box this big
FALLBACK_RGBA = (1.0, 0.3, 0.8, 0.8)  # magenta, see-through: "this is not the real shape"
MESH_TRIANGLE_BUDGET = 2000  # a mesh file with more triangles is thinned (see the module)
MESH_CELL_M = 0.01


@dataclass(frozen=True)
class LinkMesh:
    """A link's visual geometry in its own frame: triangles and a colour per vertex."""

    vertices_m: np.ndarray  # (n, 3) float32
    triangles: np.ndarray  # (m, 3) uint32
    vertex_colors: np.ndarray  # (n, 4) uint8
    vertex_normals: np.ndarray  # (n, 3) float32, unit (for shading)

    @property
    def bounds_m(self) -> np.ndarray:
        """``[[x_min, y_min, z_min], [x_max, y_max, z_max]]``."""
        return np.array([self.vertices_m.min(axis=0), self.vertices_m.max(axis=0)])


class LinkMeshes:
    """Builds link meshes; keeps loaded mesh files and the files that failed (each warned about once)."""

    def __init__(self) -> None:
        self._files: dict[Path, trimesh.Trimesh | None] = {}

    def model_meshes(self, model: UrdfModel) -> dict[str, LinkMesh]:
        """Every link of ``model`` that has something to draw → its mesh."""
        meshes = {}
        for link in model.links.values():
            mesh = self.link_mesh(link)
            if mesh is not None:
                meshes[link.name] = mesh
        return meshes

    def link_mesh(self, link: Link) -> LinkMesh | None:
        parts: list[tuple[trimesh.Trimesh, tuple[float, ...]]] = []
        for visual in link.visuals:
            shape = self._shape(visual)
            if shape is None:
                shape, rgba = _fallback_box(link, visual), tuple(FALLBACK_RGBA)
            else:
                rgba = visual.rgba
            parts.append((shape, rgba))
        if not parts:
            return None
        vertices, triangles, colors, normals, offset = [], [], [], [], 0
        for shape, rgba in parts:
            vertices.append(np.asarray(shape.vertices, dtype=np.float32))
            normals.append(np.asarray(shape.vertex_normals, dtype=np.float32))
            triangles.append(np.asarray(shape.faces, dtype=np.uint32) + offset)
            color = np.round(np.asarray(rgba) * 255).astype(np.uint8)
            colors.append(np.tile(color, (len(shape.vertices), 1)))
            offset += len(shape.vertices)
        return LinkMesh(*(np.concatenate(arrays) for arrays in (vertices, triangles, colors, normals)))

    def _shape(self, geometry: Geometry) -> trimesh.Trimesh | None:
        """The geometry as a mesh in its link's frame, or None when its mesh file cannot be loaded."""
        if geometry.kind == "mesh":
            loaded = self._load(geometry)
            if loaded is None:
                return None
            shape = loaded.copy()
            shape.apply_scale(geometry.scale)  # per axis
            if len(shape.faces) > MESH_TRIANGLE_BUDGET:
                shape = clustered(shape, MESH_CELL_M)
        else:
            shape = primitive(geometry)
        shape.apply_transform(geometry.origin)
        return shape

    def _load(self, geometry: Geometry) -> trimesh.Trimesh | None:
        path = geometry.mesh_file
        assert path is not None
        if path not in self._files:
            self._files[path] = _load_mesh_file(path, geometry.mesh_uri)
        return self._files[path]


def primitive(geometry: Geometry) -> trimesh.Trimesh:
    """A box, cylinder or sphere as a mesh centred on its own frame (the URDF's convention)."""
    if geometry.kind == "box":
        return trimesh.creation.box(extents=geometry.size_m)
    if geometry.kind == "cylinder":
        radius, length = geometry.size_m
        return trimesh.creation.cylinder(radius=radius, height=length, sections=CYLINDER_SECTIONS)
    if geometry.kind == "sphere":
        return trimesh.creation.icosphere(subdivisions=SPHERE_SUBDIVISIONS, radius=geometry.size_m[0])
    raise ValueError(f"not a primitive: {geometry.kind}")


def clustered(mesh: trimesh.Trimesh, cell_m: float) -> trimesh.Trimesh:
    """``mesh`` with its vertices merged per ``cell_m`` grid cell (the first vertex of a cell stands for
    it); triangles that collapse, and repeats, are dropped; the others keep their orientation."""
    cells = np.round(np.asarray(mesh.vertices) / cell_m).astype(np.int64)
    _, first, inverse = np.unique(cells, axis=0, return_index=True, return_inverse=True)
    faces = inverse.reshape(-1)[np.asarray(mesh.faces)]
    faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])]
    _, once = np.unique(np.sort(faces, axis=1), axis=0, return_index=True)
    return trimesh.Trimesh(np.asarray(mesh.vertices)[first], faces[np.sort(once)], process=False)


def _load_mesh_file(path: Path, uri: str) -> trimesh.Trimesh | None:
    try:
        mesh = trimesh.load(str(path), force="mesh")
    except Exception as exc:  # trimesh raises many kinds (missing file, format, a loader's own bug)
        _log.warning("robot mesh %s (%s) cannot be loaded (%s); its link is drawn as a box", uri, path, exc)
        return None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        _log.warning("robot mesh %s (%s) holds no triangles; its link is drawn as a box", uri, path)
        return None
    return mesh


def _fallback_box(link: Link, visual: Geometry) -> trimesh.Trimesh:
    """The bounding box of ``link``'s collision primitives; else a small box at the visual's origin."""
    shapes = []
    for collision in link.collisions:
        if collision.kind != "mesh":
            shape = primitive(collision)
            shape.apply_transform(collision.origin)
            shapes.append(shape)
    if not shapes:
        box = trimesh.creation.box(extents=(FALLBACK_SIZE_M,) * 3)
        box.apply_transform(visual.origin)
        return box
    bounds = np.array([shape.bounds for shape in shapes])
    low, high = bounds[:, 0].min(axis=0), bounds[:, 1].max(axis=0)
    box = trimesh.creation.box(extents=high - low)
    box.apply_translation((low + high) / 2)
    return box
