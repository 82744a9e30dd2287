"""Centre of mass and inertia from meshes against analytic boxes and cylinders; bounding-box fallback."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from ifc_builders import add_faceted, new_model
from scipy.spatial.transform import Rotation

from bimbot.services.converter.face_materials import volumes_by_style
from bimbot.services.converter.mass_properties import (
    MassProperties,
    box_inertia_per_kg,
    mass_properties,
    mesh_from_arrays,
)
from bimbot.services.converter.tessellation import tessellate
from bimbot.shared.manifest import InertiaSource


def test_box_inertia_matches_the_analytic_formula() -> None:
    extents = (2.0, 0.3, 0.5)
    mass_kg = 120.0
    props = mass_properties(trimesh.creation.box(extents))
    a, b, c = extents
    expected = mass_kg / 12.0 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])
    assert props.source == InertiaSource.MESH
    assert props.volume_m3 == pytest.approx(a * b * c)
    np.testing.assert_allclose(props.inertia_kg_m2(mass_kg), expected, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(props.com_local_m, 0.0, atol=1e-12)


def test_cylinder_inertia_matches_the_analytic_formula_within_tessellation_error() -> None:
    radius, height, mass_kg = 0.15, 3.0, 50.0
    props = mass_properties(trimesh.creation.cylinder(radius=radius, height=height, sections=256))
    ixx = mass_kg * (3 * radius**2 + height**2) / 12.0
    izz = mass_kg * radius**2 / 2.0
    np.testing.assert_allclose(np.diag(props.inertia_kg_m2(mass_kg)), [ixx, ixx, izz], rtol=2e-3)
    assert props.volume_m3 == pytest.approx(np.pi * radius**2 * height, rel=1e-3)


def test_off_centre_rotated_box_gives_com_and_full_tensor_with_products_of_inertia() -> None:
    extents = np.array([1.0, 0.2, 0.4])
    rotation = Rotation.from_euler("xyz", [0.3, -0.2, 0.9])
    mesh = trimesh.creation.box(extents)
    transform = np.eye(4)
    transform[:3, :3] = rotation.as_matrix()
    transform[:3, 3] = (1.0, 2.0, 3.0)
    mesh.apply_transform(transform)
    props = mass_properties(mesh)
    np.testing.assert_allclose(props.com_local_m, (1.0, 2.0, 3.0), atol=1e-9)
    matrix = rotation.as_matrix()
    expected = matrix @ box_inertia_per_kg(extents) @ matrix.T * 10.0
    np.testing.assert_allclose(props.inertia_kg_m2(10.0), expected, atol=1e-9)
    assert abs(expected[0, 1]) > 1e-3  # the case really has products of inertia


def test_open_mesh_gets_bounding_box_fallback_and_a_positive_volume() -> None:
    box = trimesh.creation.box((1.0, 2.0, 3.0))
    open_mesh = trimesh.Trimesh(box.vertices, box.faces[:-2], process=True)  # one face of the box removed
    props = mass_properties(open_mesh)
    assert props.source == InertiaSource.BOUNDING_BOX_FALLBACK
    assert not props.watertight
    assert props.volume_m3 == pytest.approx(6.0)
    np.testing.assert_allclose(props.inertia_per_kg_m2, box_inertia_per_kg(np.array([1.0, 2.0, 3.0])))


def test_flat_open_mesh_still_gets_a_positive_volume() -> None:
    square = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[0, 1, 2], [0, 2, 3]])
    props = mass_properties(square)
    assert props.volume_m3 > 0
    assert np.all(np.linalg.eigvalsh(props.inertia_per_kg_m2) > 0)


def test_a_mesh_not_watertight_as_a_whole_is_weighed_piece_by_piece() -> None:
    """Two closed 1 m cubes 10 m apart and a stray open triangle: the mesh is not watertight, so it used to
    weigh as its convex hull (the space between the cubes too: acad2010's roof weighed 3,167 t); each closed
    piece now counts with its own volume and an open flat one with none."""
    first = trimesh.creation.box((1.0, 1.0, 1.0))
    second = trimesh.creation.box((1.0, 1.0, 1.0))
    second.apply_translation((10.0, 0.0, 0.0))
    stray = trimesh.Trimesh([[5.0, 3.0, 0.0], [6.0, 3.0, 0.0], [5.0, 4.0, 0.0]], [[0, 1, 2]])
    mesh = trimesh.util.concatenate([first, second, stray])
    props = mass_properties(mesh)
    assert not props.watertight and props.source == InertiaSource.BOUNDING_BOX_FALLBACK
    assert props.volume_m3 == pytest.approx(2.0)
    assert trimesh.convex.convex_hull(mesh).volume > 10.0  # what it weighed before


def _frame(*, flip: tuple[int, ...] = (), leave_out: tuple[int, ...] = ()) -> tuple[list, list]:
    """A window frame as exports draw it: a 1 m square ring 0.1 m wide and 0.1 m deep (0.036 m³; its convex
    hull, the whole 1 m × 1 m × 0.1 m, is 0.1 m³), as 16 quads wound outward; ``flip``: faces wound the
    other way, ``leave_out``: faces not drawn."""
    outer, inner = (0.0, 1.0), (0.1, 0.9)
    vertices = [
        (x, y, z)
        for z in (0.0, 0.1)
        for (low, high) in (outer, inner)
        for (x, y) in ((low, low), (high, low), (high, high), (low, high))
    ]  # 0-3 outer bottom, 4-7 inner bottom, 8-11 outer top, 12-15 inner top (counter-clockwise seen from +z)
    faces = []
    for i in range(4):
        j = (i + 1) % 4
        faces.append((i, 4 + i, 4 + j, j))  # bottom ring, facing down
        faces.append((8 + i, 8 + j, 12 + j, 12 + i))  # top ring, facing up
        faces.append((i, j, 8 + j, 8 + i))  # outer side, facing out
        faces.append((4 + i, 12 + i, 12 + j, 4 + j))  # inner side, facing the opening
    faces = [face[::-1] if index in flip else face for index, face in enumerate(faces)]
    return vertices, [face for index, face in enumerate(faces) if index not in leave_out]


def _frame_body(vertices: list, faces: list) -> tuple[np.ndarray, np.ndarray]:
    """(vertices m, triangles) of an IfcWindow with this body, as ifcopenshell tessellates it."""
    small = new_model()
    window = add_faceted(small, "IfcWindow", "Frame", vertices_m=vertices, faces=faces)
    shape = tessellate(small.file, [window], threads=1).shapes[window.id()]
    return np.asarray(shape.geometry.vertices_local_m), np.asarray(shape.geometry.faces).reshape(-1, 3)


def _converted_props(vertices: list, faces: list) -> MassProperties:
    """The mass properties the converter computes for an IfcWindow with this body (tessellated by
    ifcopenshell, welded, rewound)."""
    return mass_properties(mesh_from_arrays(*_frame_body(vertices, faces)))


def test_frame_checks_its_own_volume() -> None:
    props = _converted_props(*_frame())
    assert props.watertight and props.source == InertiaSource.MESH
    assert props.volume_m3 == pytest.approx(0.036)


def test_a_closed_frame_with_faces_wound_the_wrong_way_is_rewound_into_a_solid() -> None:
    """The Revit restaurant's windows: closed frames with some faces wound inward used to be weighed as
    their convex hulls (a 1.1 m × 2.4 m window 954 kg at 1000 kg/m³, its frames 78 kg); trimesh rewinds
    them and they are solids of their own volume, with their own inertia."""
    props = _converted_props(*_frame(flip=(0, 3, 6, 13)))
    assert props.watertight and props.source == InertiaSource.MESH
    assert props.volume_m3 == pytest.approx(0.036)


def test_an_open_frame_is_weighed_with_its_hole_filled_not_as_its_convex_hull() -> None:
    """An inner side left out (and a face wound the wrong way): the mesh is open, and its convex hull (0.1 m³)
    fills the opening the frame surrounds (the restaurant's walk-in refrigerator, a box of 4 in. panels,
    weighed its whole 17 m³ hull); trimesh fills the hole and the frame weighs its own 0.036 m³."""
    props = _converted_props(*_frame(flip=(1,), leave_out=(7,)))
    assert not props.watertight and props.source == InertiaSource.BOUNDING_BOX_FALLBACK
    assert props.volume_m3 == pytest.approx(0.036)


def _t_junction_cube() -> trimesh.Trimesh:
    """A 1 m cube, wound outward, whose top face has a vertex in the middle of one edge that the side face
    beside it lacks (a T-junction, as B-rep exports draw faces): no edge there is shared by two faces, so
    the mesh is not watertight, yet its surface closes."""
    cube = trimesh.creation.box((1.0, 1.0, 1.0))
    top = [index for index, normal in enumerate(cube.face_normals) if normal[2] > 0.5]
    vertices = np.vstack(
        [cube.vertices, [[0.0, 0.5, 0.5], [0.5, 0.5, 0.5]]]
    )  # a +y edge's middle, the centre
    mid, centre = len(vertices) - 2, len(vertices) - 1
    corners = [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)]  # counter-clockwise seen from +z
    ring = [
        int(np.flatnonzero(np.all(np.isclose(cube.vertices, (x, y, 0.5)), axis=1))[0]) for x, y in corners
    ]
    ring.insert(3, mid)
    fan = [(ring[i], ring[(i + 1) % len(ring)], centre) for i in range(len(ring))]
    faces = np.vstack([np.delete(cube.faces, top, axis=0), fan])
    return trimesh.Trimesh(vertices, faces, process=False)


def test_a_surface_that_closes_at_t_junctions_is_weighed_by_its_own_integrals() -> None:
    """The Revit house's glazed doors: frame, sash and pane meet at T-junctions, so the mesh is open by its
    edges and its open pieces weighed their convex hulls (0.214 m³ against the door's 0.045 m³: 177 kg); the
    closed surface gives the exact volume, centre of mass and inertia."""
    mesh = _t_junction_cube()
    assert not mesh.is_watertight
    mesh.apply_translation((3.0, 0.0, 0.0))
    props = mass_properties(mesh)
    assert not props.watertight and props.source == InertiaSource.MESH
    assert props.volume_m3 == pytest.approx(1.0)
    np.testing.assert_allclose(props.com_local_m, (3.0, 0.0, 0.0), atol=1e-9)
    np.testing.assert_allclose(props.inertia_per_kg_m2, box_inertia_per_kg(np.ones(3)), atol=1e-9)


def test_a_surface_with_a_real_hole_or_a_body_wound_inward_keeps_the_piecewise_estimate() -> None:
    """Two checks keep the exact integrals to surfaces that really close: an open box's volume depends on
    the origin, and a closed cube wound inward inside another would subtract its volume."""
    mesh = _t_junction_cube()
    holed = trimesh.Trimesh(mesh.vertices, mesh.faces[2:], process=False)  # a side face's half left out
    assert mass_properties(holed).source == InertiaSource.BOUNDING_BOX_FALLBACK
    inner = trimesh.creation.box((0.5, 0.5, 0.5))
    inner.invert()
    both = trimesh.util.concatenate([_t_junction_cube(), inner])
    props = mass_properties(both)
    assert props.source == InertiaSource.BOUNDING_BOX_FALLBACK
    assert props.volume_m3 >= 1.0


def _t_junction_frame() -> tuple[list, list]:
    """:func:`_frame` with each side drawn as two quads split at mid-length: the top and bottom rings lack
    the split's vertices, so no edge joins the sides to them (T-junctions) and the mesh falls into four
    open pieces (two flat rings, two bands), yet its surface closes."""
    vertices, faces = _frame()
    split: list = []
    for index, face in enumerate(faces):
        if index % 4 < 2:
            split.append(face)
            continue
        a, b, c, d = face  # a-b along the bottom, c-d along the top
        m_low, m_high = len(vertices), len(vertices) + 1
        vertices.append(tuple((np.array(vertices[a]) + vertices[b]) / 2.0))
        vertices.append(tuple((np.array(vertices[c]) + vertices[d]) / 2.0))
        split += [(a, m_low, m_high, d), (m_low, b, c, m_high)]
    return vertices, split


def test_a_frame_drawn_with_t_junctions_weighs_its_own_volume_and_its_materials_their_shares() -> None:
    """Materials are weighed by the volume of the pieces of each style. Where the surface closes, the open
    pieces share what it encloses: the frame's bands weighed their holes-filled hulls, 0.164 m³ against its
    0.036 m³."""
    props = mass_properties(mesh_from_arrays(*_frame_body(*_t_junction_frame())))
    assert not props.watertight and props.source == InertiaSource.MESH
    assert props.volume_m3 == pytest.approx(0.036)
    vertices_m, faces = _frame_body(*_t_junction_frame())
    pane = trimesh.creation.box((0.8, 0.8, 0.01))
    pane.apply_translation((0.5, 0.5, 0.05))
    mesh = mesh_from_arrays(
        np.vstack([vertices_m, pane.vertices]), np.vstack([faces, pane.faces + len(vertices_m)])
    )
    styles = np.array([1] * len(faces) + [2] * len(pane.faces))
    both = mass_properties(mesh)
    assert both.volume_m3 == pytest.approx(0.0424)
    assert volumes_by_style(mesh, styles, both.volume_m3) == pytest.approx({1: 0.036, 2: 0.0064})
    assert volumes_by_style(mesh, styles)[1] == pytest.approx(0.164)  # the estimate alone
