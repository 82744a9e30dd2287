"""Benchmark: collision shapes by profile decomposition vs V-HACD, on three members built with ifcopenshell.

Run: ``.venv/bin/python bench/collision.py [--sweep] [--repeat N]``

Members (millimetre IFC4 model, tessellated by ifcopenshell in the element frame):

* an IPE 400-like I-beam, 6 m, with root fillets (finer angular deflection to get a Revit-like ~1,000
  triangles) — concave, profile path applies;
* a 400×300×20 mm base plate with four Ø30 bolt holes and a Ø120 centre hole (profile with voids) —
  concave, profile path declines, V-HACD does the work (not square: a plain ``p.vhacd`` call on a square
  plate hits V-HACD's voxel-size bug, see ``vhacd_parts``, and takes minutes);
* a 1.2×1.2×0.5 m box footing — convex.

For each: time of ``collision_from_representation`` (the profile path), of ``collision_from_mesh`` (one
hull, or ``vhacd_parts`` with its defaults on the axis-stretched mesh), and, as the reference, of a plain
``p.vhacd`` call on the mesh at its own default resolution (100,000); parts' total volume over the mesh
volume says how tight the parts are (1.00 is exact; overlapping or bloated hulls are above).
``--sweep`` also prints, for the concave members, ``vhacd_parts`` per axis stretch and plain ``p.vhacd`` per
resolution: the measurement behind ``DEFAULT_VHACD_RESOLUTION`` and ``DEFAULT_MIN_AXIS_FRACTION``.
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import os
import sys
import tempfile
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import TypeVar

import ifcopenshell
import ifcopenshell.api.context
import ifcopenshell.api.geometry
import ifcopenshell.api.root
import ifcopenshell.api.unit
import ifcopenshell.geom
import ifcopenshell.util.shape
import numpy as np
import pybullet as p
import trimesh

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bimbot.services.converter.collision import (
    collision_from_mesh,
    collision_from_representation,
    vhacd_parts,
)

UNIT_SCALE_M = 0.001
PYBULLET_DEFAULT_RESOLUTION = 100_000
SWEEP_RESOLUTIONS = (10_000, 100_000, 400_000)
SWEEP_FRACTIONS = (1.0, 0.5, 0.25)
T = TypeVar("T")
Entity = ifcopenshell.entity_instance


def _model() -> tuple[ifcopenshell.file, ifcopenshell.entity_instance]:
    model = ifcopenshell.file(schema="IFC4")
    ifcopenshell.api.root.create_entity(model, ifc_class="IfcProject", name="bench")
    ifcopenshell.api.unit.assign_unit(model, length={"is_metric": True, "raw": "MILLIMETERS"})
    parent = ifcopenshell.api.context.add_context(model, context_type="Model")
    body = ifcopenshell.api.context.add_context(
        model, context_type="Model", context_identifier="Body", target_view="MODEL_VIEW", parent=parent
    )
    return model, body


def _element(
    model: ifcopenshell.file, body: ifcopenshell.entity_instance, ifc_class: str, profile, depth_m: float
) -> ifcopenshell.entity_instance:
    element = ifcopenshell.api.root.create_entity(model, ifc_class=ifc_class)
    representation = ifcopenshell.api.geometry.add_profile_representation(
        model, context=body, profile=profile, depth=depth_m
    )
    ifcopenshell.api.geometry.assign_representation(model, product=element, representation=representation)
    return element


def _circle(
    model: ifcopenshell.file, x_mm: float, y_mm: float, radius_mm: float
) -> ifcopenshell.entity_instance:
    centre = model.createIfcAxis2Placement2D(model.createIfcCartesianPoint((x_mm, y_mm)))
    return model.createIfcCircle(centre, radius_mm)


def _members(model: ifcopenshell.file, body: ifcopenshell.entity_instance) -> list[tuple[str, Entity, float]]:
    """(name, element, mesher angular deflection in radians); keep ``model`` alive while they are used."""
    ipe = model.create_entity(
        "IfcIShapeProfileDef",
        ProfileType="AREA",
        OverallWidth=180.0,
        OverallDepth=400.0,
        WebThickness=8.6,
        FlangeThickness=13.5,
        FilletRadius=21.0,
    )
    outline = [(-200.0, -150.0), (200.0, -150.0), (200.0, 150.0), (-200.0, 150.0), (-200.0, -150.0)]
    outer = model.createIfcPolyline([model.createIfcCartesianPoint(xy) for xy in outline])
    holes = [_circle(model, x, y, 15.0) for x in (-140.0, 140.0) for y in (-90.0, 90.0)]
    holes.append(_circle(model, 0.0, 0.0, 60.0))
    plate = model.createIfcArbitraryProfileDefWithVoids("AREA", "base plate", outer, holes)
    footing = model.create_entity("IfcRectangleProfileDef", ProfileType="AREA", XDim=1200.0, YDim=1200.0)
    return [
        ("I-beam IPE400 6 m", _element(model, body, "IfcBeam", ipe, 6.0), 0.05),
        ("plate with 5 holes", _element(model, body, "IfcPlate", plate, 0.02), 0.5),
        ("box footing", _element(model, body, "IfcFooting", footing, 0.5), 0.5),
    ]


def _mesh(element: ifcopenshell.entity_instance, angular_deflection_rad: float) -> trimesh.Trimesh:
    settings = ifcopenshell.geom.settings()
    settings.set("use-world-coords", False)
    settings.set("mesher-angular-deflection", angular_deflection_rad)
    shape = ifcopenshell.geom.create_shape(settings, element)
    vertices = ifcopenshell.util.shape.get_vertices(shape.geometry)
    return trimesh.Trimesh(vertices, ifcopenshell.util.shape.get_faces(shape.geometry))


def _timed(call: Callable[[], T], repeat: int) -> tuple[T, float]:
    """Result of the last call and the best wall time in seconds over ``repeat`` calls."""
    best, result = float("inf"), None
    for _ in range(repeat):
        start = time.perf_counter()
        result = call()
        best = min(best, time.perf_counter() - start)
    return result, best  # type: ignore[return-value]


@contextlib.contextmanager
def _stdout_silenced() -> Iterator[None]:
    """File descriptor 1 to /dev/null while V-HACD prints its progress."""
    sys.stdout.flush()
    saved, devnull = os.dup(1), os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)
    try:
        yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)
        os.close(devnull)


def _raw_vhacd_parts(mesh: trimesh.Trimesh, resolution: int) -> list[trimesh.Trimesh]:
    """Hulls from a plain ``p.vhacd`` call on the mesh as it is (the naive reference)."""
    with tempfile.TemporaryDirectory() as tmp:
        src, dst, log = (str(Path(tmp) / name) for name in ("in.obj", "out.obj", "log.txt"))
        mesh.export(src)
        with _stdout_silenced():
            p.vhacd(src, dst, log, resolution=resolution)
        blocks = Path(dst).read_text().split("\no ")
    hulls = []
    for block in blocks:  # V-HACD writes each hull as an 'o' block: its own 'v' lines, then its 'f' lines
        rows = [line.split()[1:4] for line in block.splitlines() if line.startswith("v ")]
        if len(rows) >= 4:
            hulls.append(trimesh.convex.convex_hull(np.asarray(rows, dtype=float)))
    return hulls


def _volume_ratio(parts: Sequence[trimesh.Trimesh], mesh: trimesh.Trimesh) -> float:
    return sum(part.volume for part in parts) / mesh.volume


def _fresh(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """A new mesh object, so timings do not profit from trimesh's per-object caches (hull, volume)."""
    return trimesh.Trimesh(mesh.vertices.copy(), mesh.faces.copy(), process=False)


def _report(name: str, element: Entity, mesh: trimesh.Trimesh, repeat: int) -> None:
    profile, t_profile = _timed(
        lambda: collision_from_representation(element, _fresh(mesh), UNIT_SCALE_M), repeat
    )
    fallback, t_mesh = _timed(lambda: collision_from_mesh(_fresh(mesh)), repeat)
    reference, t_ref = _timed(lambda: _raw_vhacd_parts(mesh, PYBULLET_DEFAULT_RESOLUTION), 1)
    profile_text = "declined (falls back to the mesh)"
    if profile is not None:
        profile_text = f"{len(profile.parts)} parts, volume {_volume_ratio(profile.parts, mesh):.2f} × mesh"
    hull_ratio = mesh.convex_hull.volume / mesh.volume
    print(f"{name}: {len(mesh.faces)} triangles, convex hull = {hull_ratio:.2f} × mesh volume")
    print(f"  profile path: collision_from_representation {t_profile * 1e3:9.2f} ms  {profile_text}")
    print(
        f"  mesh path: collision_from_mesh                {t_mesh * 1e3:9.2f} ms  {fallback.method.value}, "
        f"{len(fallback.parts)} parts, volume {_volume_ratio(fallback.parts, mesh):.2f} × mesh"
    )
    print(
        f"  reference: p.vhacd as is, resolution {PYBULLET_DEFAULT_RESOLUTION:,}  {t_ref * 1e3:9.2f} ms  "
        f"{len(reference)} parts, volume {_volume_ratio(reference, mesh):.2f} × mesh"
    )
    chosen = t_profile if profile is not None else t_mesh
    print(
        f"  reference / profile path {t_ref / t_profile:,.0f}×, "
        f"reference / mesh path {t_ref / t_mesh:,.1f}×, "
        f"reference / collision_shape (first path that applies) {t_ref / chosen:,.0f}×"
    )


def _sweep(name: str, mesh: trimesh.Trimesh) -> None:
    print(f"  sweep for {name} (time, parts, parts' volume / mesh volume):")
    for fraction in SWEEP_FRACTIONS:
        parts, seconds = _timed(lambda f=fraction: vhacd_parts(mesh, min_axis_fraction=f), 1)
        print(
            f"    vhacd_parts, short axes stretched to {fraction:4.2f} of the longest: {seconds:6.3f} s "
            f"{len(parts):2d} parts {_volume_ratio(parts, mesh):5.2f}"
        )
    for resolution in SWEEP_RESOLUTIONS:
        raw, seconds = _timed(lambda r=resolution: _raw_vhacd_parts(mesh, r), 1)
        print(
            f"    p.vhacd as is, resolution {resolution:>7,}:                   {seconds:6.3f} s "
            f"{len(raw):2d} parts {_volume_ratio(raw, mesh):5.2f}"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sweep", action="store_true", help="V-HACD time and parts per resolution")
    parser.add_argument("--repeat", type=int, default=5, help="best of N for the fast paths")
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING)
    model, body = _model()
    for name, element, deflection in _members(model, body):
        mesh = _mesh(element, deflection)
        _report(name, element, mesh, args.repeat)
        if args.sweep and not np.isclose(mesh.convex_hull.volume, mesh.volume, rtol=0.01):
            _sweep(name, mesh)


if __name__ == "__main__":
    main()
