"""A room's content drawn through its room's floor is cut at that floor (services/converter/room_contents.py).

A fitting contained in a room (``IfcSpace``) stands on the room's floor; a part of it drawn a metre down
through the floor slab is nothing a site builds there. Converted as drawn, the two clash and the support
graph puts the fitting before its floor, by its lowest point; cut at the floor, the fitting rests on the
slab, after it. What reaches no deeper than a floor's build-up, what lies mostly under its room's floor
and what no room holds are left as drawn.
"""

from __future__ import annotations

from pathlib import Path

import ifcopenshell
import ifcopenshell.api.aggregate
import ifcopenshell.api.geometry
import ifcopenshell.api.root
import ifcopenshell.geom
import ifcopenshell.util.shape
import numpy as np
import pytest
from ifc_builders import Entity, SmallModel, add_box, new_model, place, translation

from bimbot.services.converter.convert import ConvertOptions, convert_model
from bimbot.services.converter.mesh import TriMesh
from bimbot.services.converter.room_contents import (
    RoomFloor,
    clip_triangles,
    cut_at_room_floor,
    room_floors,
)
from bimbot.services.converter.tessellation import ElementShape, Geometry, geometry_settings
from bimbot.shared.ifc_input import open_model
from bimbot.shared.manifest import Manifest
from bimbot.shared.support_graph import support_predecessors

# a stall's panel standing on the floor (1 m × 50 mm × 1.8 m, a closed box) and a bracket drawn from 1 m under
# the floor to 0.5 m above it (a 50 mm square tube: its four sides, open at its ends, as exports draw them)
FLOOR_M = 0.2  # the room's floor, on its slab and tile over the ground
BOX_FACES = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]


def _box(
    corner: tuple[float, float, float], size: tuple[float, float, float]
) -> list[tuple[float, float, float]]:
    (x, y, z), (dx, dy, dz) = corner, size
    base = [(x, y, z), (x + dx, y, z), (x + dx, y + dy, z), (x, y + dy, z)]
    return base + [(px, py, z + dz) for px, py, _ in base]


def _stall(bracket_bottom_m: float = -1.0, *, closed_bracket: bool = False) -> tuple[list, list]:
    """Vertices (metres, from the room's floor) and faces of the stall: its panel and the bracket by it."""
    vertices = _box((0.0, 0.0, 0.0), (1.0, 0.05, 1.8)) + _box((0.4, 0.1, bracket_bottom_m), (0.05, 0.05, 1.5))
    bracket = BOX_FACES if closed_bracket else BOX_FACES[2:]
    faces = BOX_FACES + [tuple(index + 8 for index in face) for face in bracket]
    return vertices, faces


def _room(small: SmallModel) -> Entity:
    """A room 4 m × 4 m, its floor at :data:`FLOOR_M`: a 50 mm tile floor (under the stall) on a 150 mm slab
    on the ground."""
    add_box(
        small, "IfcSlab", "Slab", size_m=(4.0, 4.0, 0.15), corner_m=(-1.5, -1.5, 0.0), predefined_type="FLOOR"
    )
    add_box(
        small,
        "IfcSlab",
        "Tile",
        size_m=(1.2, 0.4, 0.05),
        corner_m=(-0.1, -0.1, 0.15),
        predefined_type="FLOOR",
    )
    space = add_box(
        small, "IfcSpace", "Restroom", size_m=(4.0, 4.0, 3.0), corner_m=(-1.5, -1.5, FLOOR_M), contained=False
    )
    ifcopenshell.api.aggregate.assign_object(small.file, products=[space], relating_object=small.storey)
    return space


def _fitting(small: SmallModel, name: str, vertices: list, faces: list, container: Entity) -> Entity:
    element = ifcopenshell.api.root.create_entity(small.file, ifc_class="IfcBuildingElementProxy", name=name)
    body = ifcopenshell.api.geometry.add_mesh_representation(
        small.file, context=small.body, vertices=[vertices], faces=[faces]
    )
    ifcopenshell.api.geometry.assign_representation(small.file, product=element, representation=body)
    return place(small, element, translation(z_m=FLOOR_M), container)  # its vertices from the room's floor


def _convert(small: SmallModel, tmp_path: Path) -> Manifest:
    source = tmp_path / "model.ifc"
    small.file.write(str(source))
    return convert_model(open_model(source), source, tmp_path / "build", ConvertOptions(formats=()))


def test_a_fitting_drawn_through_the_floor_of_its_room_is_cut_at_the_floor_and_set_after_it(
    tmp_path: Path,
) -> None:
    small = new_model()
    room = _room(small)
    _fitting(small, "Stall", *_stall(), room)
    manifest = _convert(small, tmp_path)
    by_name = {component.name: component for component in manifest.components}
    stall, tile = by_name["Stall"], by_name["Tile"]
    assert stall.bbox_world.min_m[2] == pytest.approx(FLOOR_M, abs=1e-6)  # drawn from 1 m under it
    assert stall.bbox_world.max_m[2] == pytest.approx(FLOOR_M + 1.8, abs=1e-6)
    # drawn as it was, its bracket clashes with the tile and the slab, and the stall comes before both
    assert manifest.clashes == []
    assert manifest.joints == []
    assert support_predecessors(manifest.components, joints=manifest.joints)[stall.guid] == {tile.guid}
    assert any("1.000 m under the floor of the room that holds it (Restroom)" in w for w in stall.warnings)


def test_what_is_not_cut_a_room_holds_it_shallow_or_mostly_under_its_floor_or_no_room_holds_it(
    tmp_path: Path,
) -> None:
    small = new_model()
    room = _room(small)
    shallow = _fitting(small, "On the slab", *_stall(bracket_bottom_m=-0.1), room)
    sunk = _fitting(small, "Sunk", [(x, y, z - 1.7) for x, y, z in _stall()[0]], _stall()[1], room)
    wall_side = _fitting(small, "In the storey", *_stall(), small.storey)
    floors = room_floors(small.file, [shallow, sunk, wall_side])
    assert set(floors) == {shallow.id(), sunk.id()}  # the storey is no room
    assert floors[shallow.id()] == RoomFloor(pytest.approx(FLOOR_M, abs=1e-9), "Restroom")
    for element in (shallow, sunk):
        shape = _shape(element)
        assert cut_at_room_floor(shape, floors[element.id()]) == (shape, None)


def _shape(element: ifcopenshell.entity_instance) -> ElementShape:
    """The element's shape as the converter tessellates it (element frame, metres)."""
    shape = ifcopenshell.geom.create_shape(geometry_settings(), element)
    geometry = Geometry(
        "g",
        np.asarray(ifcopenshell.util.shape.get_vertices(shape.geometry), dtype=float),
        np.asarray(ifcopenshell.util.shape.get_faces(shape.geometry), dtype=np.int64),
    )
    return ElementShape(element.id(), np.asarray(ifcopenshell.util.shape.get_shape_matrix(shape)), geometry)


def test_a_closed_solid_is_capped_where_it_is_cut_and_an_open_surface_clipped() -> None:
    for closed in (True, False):
        vertices, faces = _stall(closed_bracket=closed)
        triangles = [(face[0], face[i], face[i + 1]) for face in faces for i in (1, 2)]
        shape = ElementShape(1, np.eye(4), Geometry("g", np.array(vertices, float), np.array(triangles)))
        cut, note = cut_at_room_floor(shape, RoomFloor(0.0, "Restroom"))
        assert note is not None
        mesh = TriMesh(cut.geometry.vertices_local_m, cut.geometry.faces)
        assert mesh.bounds[0][2] == pytest.approx(0.0, abs=1e-6)
        assert mesh.is_watertight is closed  # the bracket capped at the floor, or left open as drawn
        if closed:  # the panel and what stands of the bracket above the floor
            assert mesh.volume == pytest.approx(1.0 * 0.05 * 1.8 + 0.05 * 0.05 * 0.5, rel=1e-4)


def test_a_triangle_across_the_plane_keeps_its_part_above_it_wound_as_it_was() -> None:
    vertices = np.array([[0.0, 0.0, -1.0], [2.0, 0.0, 1.0], [0.0, 0.0, 1.0], [4.0, 0.0, -1.0]])
    faces = np.array([[0, 1, 2], [0, 3, 1]])  # two corners above the plane; one (both face -y)
    kept, clipped, source = clip_triangles(vertices, faces, np.array([0.0, 0.0, 1.0]), 0.0)
    assert list(source) == [1, 0, 0]  # the second's part is a triangle; the first's a quad, two triangles
    triangles = kept[clipped]
    assert triangles[:, :, 2].min() == pytest.approx(0.0)
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    assert np.all(normals[:, 1] < 0.0)  # wound as their triangles were
    areas = 0.5 * np.linalg.norm(normals, axis=1)
    assert areas[1:].sum() == pytest.approx(1.5)  # the trapezoid above z = 0 of a 2 m² triangle
    assert areas[0] == pytest.approx(1.0)  # the apex of a 4 m² triangle, half its height
    assert len(kept) == len(np.unique(clipped))  # only the vertices the faces use
