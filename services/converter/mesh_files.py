"""Mesh files of a component model folder: the visual formats asked for and the convex collision parts.

Who reads what (checked in the readers' code):

* ``meshes/collision_<i>.obj`` — physics (one compound body of the convex parts), Gazebo (``<collision>``
  in ``model.sdf``). Always written.
* ``meshes/visual.dae`` — Gazebo: ``model.sdf``'s ``<visual>`` names it (the first visual format written,
  in the order dae, obj, glb).
* ``meshes/visual.glb`` — the rerun observer (it falls back to ``visual.obj`` when there is no GLB).
* ``meshes/visual.obj`` — physics with ``--gui`` (PyBullet draws it; without it, the collision parts).

``--formats`` chooses the visual formats (:data:`VISUAL_FORMATS`, all three by default); a format not asked
for is not written and its manifest path is empty. All files are in the component's own frame, metres.
Components that share geometry share the files: the first folder gets them written, the others get hard
links (a copy where the file system refuses links).

The writers are small and direct (numpy formatting, one ``write`` per file) instead of trimesh's exporters:
they write the same content (OBJ positions to 1e-8 m; DAE and GLB with angle-weighted vertex normals, the
GLB in float32 as glTF requires) at a fraction of the cost, which matters when a model has thousands of
components.
"""

from __future__ import annotations

import json
import os
import shutil
import struct
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from .mesh import ZERO_CROSS, TriMesh

VISUAL_DAE = "meshes/visual.dae"
VISUAL_OBJ = "meshes/visual.obj"
VISUAL_GLB = "meshes/visual.glb"
VISUAL_FORMATS: tuple[str, ...] = ("dae", "obj", "glb")  # also the preference order of model.sdf's visual
_VISUAL_FILES = {"dae": VISUAL_DAE, "obj": VISUAL_OBJ, "glb": VISUAL_GLB}
_CREATED = datetime.now(UTC).replace(microsecond=0, tzinfo=None).isoformat()


def collision_file(index: int) -> str:
    return f"meshes/collision_{index}.obj"


def parse_formats(text: str) -> tuple[str, ...]:
    """``"dae,glb"`` → ``("dae", "glb")`` in :data:`VISUAL_FORMATS` order; ValueError names unknown ones."""
    asked = {part.strip().lower().lstrip(".") for part in text.split(",") if part.strip()}
    unknown = sorted(asked - set(VISUAL_FORMATS))
    if unknown:
        raise ValueError(
            f"unknown visual format(s) {', '.join(unknown)}: choose from {', '.join(VISUAL_FORMATS)}"
        )
    return tuple(name for name in VISUAL_FORMATS if name in asked)


@dataclass(frozen=True)
class GeometryFiles:
    """Paths relative to a model folder; an empty visual path: that format was not written."""

    visual_dae: str
    visual_obj: str
    visual_glb: str
    collision: tuple[str, ...]

    @property
    def visual_mesh(self) -> str:
        """The visual ``model.sdf`` names (Gazebo): DAE, else OBJ, else GLB; empty when none is written."""
        return self.visual_dae or self.visual_obj or self.visual_glb

    def all(self) -> tuple[str, ...]:
        return tuple(name for name in (self.visual_dae, self.visual_obj, self.visual_glb) if name) + (
            self.collision
        )


def write_geometry_files(
    model_dir: Path,
    visual: TriMesh,
    collision_parts: tuple[TriMesh, ...],
    formats: tuple[str, ...] = VISUAL_FORMATS,
) -> GeometryFiles:
    """Write the visual mesh in ``formats`` and every collision part into ``model_dir/meshes/``."""
    files = GeometryFiles(
        VISUAL_DAE if "dae" in formats else "",
        VISUAL_OBJ if "obj" in formats else "",
        VISUAL_GLB if "glb" in formats else "",
        tuple(collision_file(index) for index in range(len(collision_parts))),
    )
    (model_dir / "meshes").mkdir(parents=True, exist_ok=True)
    normals = vertex_normals(visual) if {"dae", "glb"} & set(formats) else None
    if files.visual_dae:
        assert normals is not None
        (model_dir / files.visual_dae).write_bytes(dae_bytes(visual, normals))
    if files.visual_obj:
        write_obj(model_dir / files.visual_obj, visual)
    if files.visual_glb:
        assert normals is not None
        (model_dir / files.visual_glb).write_bytes(glb_bytes(visual, normals))
    for part, name in zip(collision_parts, files.collision, strict=True):
        write_obj(model_dir / name, part)
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


# --- formats -------------------------------------------------------------------------------------------


def obj_text(mesh: TriMesh) -> str:
    """Wavefront OBJ: positions with 8 decimals (1e-8 m, as trimesh wrote them), 1-based triangles."""
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64) + 1
    return (
        "# bimbot converter\n"
        + ("v %.8f %.8f %.8f\n" * len(vertices)) % tuple(vertices.ravel())
        + ("f %d %d %d\n" * len(faces)) % tuple(faces.ravel())
    )


def write_obj(path: Path, mesh: TriMesh) -> None:
    path.write_text(obj_text(mesh), encoding="ascii")


def read_obj(path: Path) -> TriMesh:
    """A mesh :func:`write_obj` wrote (``v`` and triangle ``f`` lines, 1-based)."""
    vertices: list[list[float]] = []
    faces: list[list[int]] = []
    for line in path.read_text(encoding="ascii").splitlines():
        if line.startswith("v "):
            vertices.append([float(value) for value in line.split()[1:4]])
        elif line.startswith("f "):
            faces.append([int(value.split("/")[0]) - 1 for value in line.split()[1:4]])
    return TriMesh(
        np.array(vertices, dtype=float).reshape(-1, 3), np.array(faces, dtype=np.int64).reshape(-1, 3)
    )


def vertex_normals(mesh: TriMesh) -> np.ndarray:
    """Unit vertex normals: face normals weighted by the corner angle at the vertex (trimesh's rule)."""
    triangles = mesh.triangles
    normals = np.zeros((len(mesh.vertices), 3))
    valid = mesh.valid_faces
    if valid.any():
        tri = triangles[valid]
        angles = np.empty((len(tri), 3))
        for corner in range(3):
            u = tri[:, (corner + 1) % 3] - tri[:, corner]
            v = tri[:, (corner + 2) % 3] - tri[:, corner]
            cosine = np.einsum("ij,ij->i", u, v) / (np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1))
            angles[:, corner] = np.arccos(np.clip(cosine, -1.0, 1.0))
        contributions = angles[:, :, None] * mesh.face_normals[valid][:, None, :]
        np.add.at(normals, mesh.faces[valid].ravel(), contributions.reshape(-1, 3))
    lengths = np.linalg.norm(normals, axis=1)
    nonzero = lengths > ZERO_CROSS  # contributions that cancel out leave no direction, as in trimesh
    normals[nonzero] /= lengths[nonzero, None]
    return normals


def dae_bytes(mesh: TriMesh, normals: np.ndarray) -> bytes:
    """COLLADA 1.4.1 with one triangle mesh (positions, vertex normals) and one default material, laid out
    as trimesh's exporter laid it out (so Gazebo reads it as before)."""
    positions = " ".join(f"{value:.9g}" for value in np.asarray(mesh.vertices, dtype=np.float64).ravel())
    normal_text = " ".join(f"{value:.7g}" for value in normals.ravel())
    faces = np.asarray(mesh.faces, dtype=np.int64)
    indices = " ".join(map(str, np.repeat(faces.ravel(), 2)))
    count = len(mesh.vertices)
    colour = "<color>0.0 0.0 0.0 1.0</color>"
    return f"""<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset>
    <created>{_CREATED}</created>
    <modified>{_CREATED}</modified>
    <up_axis>Y_UP</up_axis>
  </asset>
  <library_effects>
    <effect id="effect0" name="effect0">
      <profile_COMMON>
        <technique sid="common">
          <phong>
            <emission>{colour}</emission>
            <ambient>{colour}</ambient>
            <diffuse>{colour}</diffuse>
            <specular>{colour}</specular>
            <shininess><float>0.0</float></shininess>
            <reflective>{colour}</reflective>
            <reflectivity><float>0.0</float></reflectivity>
            <transparent>{colour}</transparent>
            <transparency><float>1.0</float></transparency>
          </phong>
        </technique>
      </profile_COMMON>
    </effect>
  </library_effects>
  <library_geometries>
    <geometry id="geometry0" name="geometry0">
      <mesh>
        <source id="verts-array">
          <float_array count="{3 * count}" id="verts-array-array">{positions}</float_array>
          <technique_common>
            <accessor count="{count}" source="#verts-array-array" stride="3">
              <param type="float" name="X"/>
              <param type="float" name="Y"/>
              <param type="float" name="Z"/>
            </accessor>
          </technique_common>
        </source>
        <source id="normals-array">
          <float_array count="{3 * count}" id="normals-array-array">{normal_text}</float_array>
          <technique_common>
            <accessor count="{count}" source="#normals-array-array" stride="3">
              <param type="float" name="X"/>
              <param type="float" name="Y"/>
              <param type="float" name="Z"/>
            </accessor>
          </technique_common>
        </source>
        <vertices id="verts-array-vertices">
          <input semantic="POSITION" source="#verts-array"/>
        </vertices>
        <triangles count="{len(faces)}" material="material0">
          <input offset="0" semantic="VERTEX" source="#verts-array-vertices"/>
          <input offset="1" semantic="NORMAL" source="#normals-array"/>
          <p>{indices}</p>
        </triangles>
      </mesh>
    </geometry>
  </library_geometries>
  <library_materials>
    <material id="material0" name="defaultmaterial">
      <instance_effect url="#effect0"/>
    </material>
  </library_materials>
  <library_visual_scenes>
    <visual_scene id="scene">
      <node id="node0" name="node0">
        <instance_geometry url="#geometry0">
          <bind_material>
            <technique_common>
              <instance_material symbol="material0" target="#material0"/>
            </technique_common>
          </bind_material>
        </instance_geometry>
      </node>
    </visual_scene>
  </library_visual_scenes>
  <scene>
    <instance_visual_scene url="#scene"/>
  </scene>
</COLLADA>
""".encode()


def glb_bytes(mesh: TriMesh, normals: np.ndarray) -> bytes:
    """Binary glTF 2.0: one mesh, one primitive (uint32 indices, float32 positions and normals)."""
    indices = np.ascontiguousarray(mesh.faces, dtype="<u4").tobytes()
    positions32 = np.ascontiguousarray(mesh.vertices, dtype="<f4")
    normals32 = np.ascontiguousarray(normals, dtype="<f4")
    views = [indices, positions32.tobytes(), normals32.tobytes()]
    offsets = np.cumsum([0] + [len(view) for view in views[:-1]]).tolist()

    def bounds(values: np.ndarray) -> dict[str, list[float]]:
        if len(values) == 0:
            return {}
        return {"max": values.max(axis=0).tolist(), "min": values.min(axis=0).tolist()}

    flat_indices = np.asarray(mesh.faces).ravel()
    document = {
        "asset": {"version": "2.0", "generator": "bimbot converter"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"name": "geometry_0", "mesh": 0}],
        "meshes": [
            {
                "name": "geometry_0",
                "primitives": [{"attributes": {"POSITION": 1, "NORMAL": 2}, "indices": 0, "mode": 4}],
            }
        ],
        "accessors": [
            {
                "bufferView": 0,
                "componentType": 5125,
                "count": int(flat_indices.size),
                "type": "SCALAR",
                **(
                    {"max": [int(flat_indices.max())], "min": [int(flat_indices.min())]}
                    if flat_indices.size
                    else {}
                ),
            },
            {"bufferView": 1, "componentType": 5126, "count": len(positions32), "type": "VEC3"}
            | bounds(positions32),
            {"bufferView": 2, "componentType": 5126, "count": len(normals32), "type": "VEC3"}
            | bounds(normals32),
        ],
        "buffers": [{"byteLength": sum(len(view) for view in views)}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": offset, "byteLength": len(view)}
            for offset, view in zip(offsets, views, strict=True)
        ],
    }
    json_chunk = json.dumps(document, separators=(",", ":")).encode()
    json_chunk += b" " * (-len(json_chunk) % 4)
    binary = b"".join(views)
    binary += b"\0" * (-len(binary) % 4)
    length = 12 + 8 + len(json_chunk) + 8 + len(binary)
    return b"".join(
        (
            struct.pack("<4sII", b"glTF", 2, length),
            struct.pack("<I4s", len(json_chunk), b"JSON"),
            json_chunk,
            struct.pack("<I4s", len(binary), b"BIN\0"),
            binary,
        )
    )
