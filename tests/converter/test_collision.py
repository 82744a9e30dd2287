"""Collision shapes of moving bodies (services/converter/collision.py)."""

from __future__ import annotations

import subprocess
import sys
import textwrap
import time
from dataclasses import dataclass
from pathlib import Path

import ifcopenshell
import ifcopenshell.api.context
import ifcopenshell.api.feature
import ifcopenshell.api.geometry
import ifcopenshell.api.root
import ifcopenshell.api.type
import ifcopenshell.api.unit
import ifcopenshell.geom
import ifcopenshell.util.data
import ifcopenshell.util.shape
import ifcopenshell.util.unit
import manifold3d
import numpy as np
import pybullet as p
import pytest
import trimesh

import bimbot.services.converter.collision as collision_module
from bimbot.services.converter.collision import (
    CollisionShape,
    collision_from_mesh,
    collision_from_representation,
    collision_shape,
    vhacd_parts,
)
from bimbot.services.converter.mesh import TriMesh
from bimbot.services.converter.mesh_files import write_obj
from bimbot.shared.manifest import MAX_COLLISION_PARTS, CollisionMethod

MM = 0.001
Entity = ifcopenshell.entity_instance


# --- fixtures: a millimetre IFC4 model, elements made with ifcopenshell.api, their ifcopenshell meshes ----


@dataclass(frozen=True)
class Model:
    file: ifcopenshell.file
    body: Entity

    def profile(self, ifc_class: str, **attributes: object) -> Entity:
        return self.file.create_entity(ifc_class, ProfileType="AREA", **attributes)

    def extrusion(self, profile: Entity, depth_m: float, **kwargs: object) -> Entity:
        return ifcopenshell.api.geometry.add_profile_representation(
            self.file, context=self.body, profile=profile, depth=depth_m, **kwargs
        )

    def element(self, ifc_class: str, representation: Entity, matrix_m: np.ndarray | None = None) -> Entity:
        element = ifcopenshell.api.root.create_entity(self.file, ifc_class=ifc_class)
        ifcopenshell.api.geometry.assign_representation(
            self.file, product=element, representation=representation
        )
        place(self.file, element, np.eye(4) if matrix_m is None else matrix_m)
        return element


def place(model: ifcopenshell.file, element: Entity, matrix_m: np.ndarray) -> None:
    # the api scales the matrix's translation in place: hand it a copy
    ifcopenshell.api.geometry.edit_object_placement(
        model, product=element, matrix=matrix_m.copy(), is_si=True
    )


def rotated_placement() -> np.ndarray:
    """A placement with a non-trivial rotation and offset, metres."""
    c, s = np.cos(0.7), np.sin(0.7)
    matrix = np.eye(4)
    matrix[:3, :3] = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ np.array(
        [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]
    )
    matrix[:3, 3] = (12.0, -3.0, 4.5)
    return matrix


@pytest.fixture
def model() -> Model:
    file = ifcopenshell.file(schema="IFC4")
    ifcopenshell.api.root.create_entity(file, ifc_class="IfcProject", name="collision tests")
    ifcopenshell.api.unit.assign_unit(file, length={"is_metric": True, "raw": "MILLIMETERS"})
    parent = ifcopenshell.api.context.add_context(file, context_type="Model")
    body = ifcopenshell.api.context.add_context(
        file, context_type="Model", context_identifier="Body", target_view="MODEL_VIEW", parent=parent
    )
    return Model(file, body)


def local_mesh(element: Entity) -> trimesh.Trimesh:
    """The element's ifcopenshell tessellation in its own placement frame, metres."""
    settings = ifcopenshell.geom.settings()
    settings.set("use-world-coords", False)
    shape = ifcopenshell.geom.create_shape(settings, element)
    vertices = ifcopenshell.util.shape.get_vertices(shape.geometry)
    return trimesh.Trimesh(vertices, ifcopenshell.util.shape.get_faces(shape.geometry))


def i_section(model: Model) -> Entity:
    return model.profile(
        "IfcIShapeProfileDef", OverallWidth=200.0, OverallDepth=400.0, WebThickness=10.0, FlangeThickness=20.0
    )


def union_bounds(parts: tuple[trimesh.Trimesh, ...]) -> np.ndarray:
    return np.array(
        [np.min([q.bounds[0] for q in parts], axis=0), np.max([q.bounds[1] for q in parts], axis=0)]
    )


def assert_convex_parts(shape: CollisionShape) -> None:
    for part in shape.parts:
        assert part.is_watertight and part.is_convex and part.volume > 0.0


def prism(
    outline_xy: list[tuple[float, float]], triangles: list[tuple[int, int, int]], height: float
) -> trimesh.Trimesh:
    """A closed prism over a counter-clockwise outline with the given triangulation of its cap."""
    n = len(outline_xy)
    bottom = np.column_stack([np.array(outline_xy), np.zeros(n)])
    vertices = np.vstack([bottom, bottom + np.array([0.0, 0.0, height])])
    faces = [(c, b, a) for a, b, c in triangles] + [(a + n, b + n, c + n) for a, b, c in triangles]
    for i in range(n):
        j = (i + 1) % n
        faces += [(i, j, j + n), (i, j + n, i + n)]
    mesh = trimesh.Trimesh(vertices, faces)
    assert mesh.is_volume
    return mesh


def l_prism() -> trimesh.Trimesh:
    """An L-shaped angle 0.1 × 0.1 m, legs 0.01 m thick, 1 m long (concave)."""
    outline = [(0.0, 0.0), (0.1, 0.0), (0.1, 0.01), (0.01, 0.01), (0.01, 0.1), (0.0, 0.1)]
    return prism(outline, [(0, 1, 2), (0, 2, 3), (0, 3, 4), (0, 4, 5)], 1.0)


# --- profile path -----------------------------------------------------------------------------------------


def test_rotated_i_beam_is_three_convex_prisms_matching_its_mesh(model: Model) -> None:
    beam = model.element("IfcBeam", model.extrusion(i_section(model), 6.0), rotated_placement())
    mesh = local_mesh(beam)
    shape = collision_from_representation(beam, mesh, MM)
    assert shape is not None
    assert shape.method is CollisionMethod.PROFILE_DECOMPOSITION and len(shape.parts) == 3
    assert_convex_parts(shape)
    np.testing.assert_allclose(union_bounds(shape.parts), mesh.bounds, atol=1e-7)
    assert sum(q.volume for q in shape.parts) == pytest.approx(mesh.volume, rel=1e-6)
    assert collision_shape(beam, mesh, MM).method is CollisionMethod.PROFILE_DECOMPOSITION


def test_filleted_i_beam_pieces_miss_only_the_fillet_volume(model: Model) -> None:
    ipe = model.profile(
        "IfcIShapeProfileDef",
        OverallWidth=150.0,
        OverallDepth=300.0,
        WebThickness=7.1,
        FlangeThickness=10.7,
        FilletRadius=15.0,
    )
    beam = model.element("IfcBeam", model.extrusion(ipe, 3.0))
    mesh = local_mesh(beam)
    shape = collision_from_representation(beam, mesh, MM)
    assert shape is not None and len(shape.parts) == 3
    fillets_m3 = 4 * (1 - np.pi / 4) * 0.015**2 * 3.0
    assert sum(q.volume for q in shape.parts) == pytest.approx(mesh.volume - fillets_m3, rel=0.01)


def test_square_hollow_column_is_four_walls(model: Model) -> None:
    shs = model.profile("IfcRectangleHollowProfileDef", XDim=200.0, YDim=200.0, WallThickness=10.0)
    column = model.element("IfcColumn", model.extrusion(shs, 3.0), rotated_placement())
    mesh = local_mesh(column)
    shape = collision_shape(column, mesh, MM)
    assert shape.method is CollisionMethod.PROFILE_DECOMPOSITION and len(shape.parts) == 4
    assert_convex_parts(shape)
    np.testing.assert_allclose(union_bounds(shape.parts), mesh.bounds, atol=1e-7)


def test_box_footing_is_one_profile_prism_and_one_hull_from_its_mesh(model: Model) -> None:
    """Expected: the representation path takes a rectangle extrusion (one prism); the mesh path one hull."""
    rectangle = model.profile("IfcRectangleProfileDef", XDim=1200.0, YDim=800.0)
    footing = model.element("IfcFooting", model.extrusion(rectangle, 0.5), rotated_placement())
    mesh = local_mesh(footing)
    shape = collision_shape(footing, mesh, MM)
    assert shape.method is CollisionMethod.PROFILE_DECOMPOSITION and len(shape.parts) == 1
    from_mesh = collision_from_mesh(mesh)
    assert from_mesh.method is CollisionMethod.CONVEX_HULL and len(from_mesh.parts) == 1
    assert from_mesh.parts[0].volume == pytest.approx(1.2 * 0.8 * 0.5)


def test_extrusion_position_is_applied(model: Model) -> None:
    """A beam extruded along its local x, the way many exporters write it."""
    representation = model.extrusion(
        i_section(model), 4.0, placement_zx_axes=((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))
    )
    beam = model.element("IfcBeam", representation, rotated_placement())
    mesh = local_mesh(beam)
    assert mesh.extents[0] == pytest.approx(4.0)
    shape = collision_from_representation(beam, mesh, MM)
    assert shape is not None
    np.testing.assert_allclose(union_bounds(shape.parts), mesh.bounds, atol=1e-7)


def test_type_representation_map_gives_the_same_parts_as_a_direct_extrusion(model: Model) -> None:
    beam_type = ifcopenshell.api.root.create_entity(model.file, ifc_class="IfcBeamType")
    ifcopenshell.api.geometry.assign_representation(
        model.file, product=beam_type, representation=model.extrusion(i_section(model), 6.0)
    )
    typed = ifcopenshell.api.root.create_entity(model.file, ifc_class="IfcBeam")
    place(model.file, typed, rotated_placement())
    ifcopenshell.api.type.assign_type(model.file, related_objects=[typed], relating_type=beam_type)
    assert typed.Representation.Representations[0].Items[0].is_a("IfcMappedItem")
    direct = model.element("IfcBeam", model.extrusion(i_section(model), 6.0), rotated_placement())

    typed_shape = collision_shape(typed, local_mesh(typed), MM)
    direct_shape = collision_shape(direct, local_mesh(direct), MM)
    assert typed_shape.method is CollisionMethod.PROFILE_DECOMPOSITION
    typed_boxes = sorted(tuple(np.round(q.bounds.ravel(), 9)) for q in typed_shape.parts)
    direct_boxes = sorted(tuple(np.round(q.bounds.ravel(), 9)) for q in direct_shape.parts)
    assert typed_boxes == direct_boxes


def test_mapped_item_origin_and_target_are_both_applied(model: Model) -> None:
    f = model.file
    solid_representation = model.extrusion(i_section(model), 2.0)
    origin = f.createIfcAxis2Placement3D(
        f.createIfcCartesianPoint((100.0, 200.0, 300.0)),
        f.createIfcDirection((0.0, 0.0, 1.0)),
        f.createIfcDirection((0.0, 1.0, 0.0)),
    )
    target = f.createIfcCartesianTransformationOperator3D(
        f.createIfcDirection((1.0, 0.0, 0.0)),
        f.createIfcDirection((0.0, 0.0, 1.0)),
        f.createIfcCartesianPoint((500.0, 50.0, 0.0)),
        None,
    )
    mapped = f.createIfcMappedItem(f.createIfcRepresentationMap(origin, solid_representation), target)
    representation = f.createIfcShapeRepresentation(model.body, "Body", "MappedRepresentation", [mapped])
    beam = model.element("IfcBeam", representation, rotated_placement())
    mesh = local_mesh(beam)
    shape = collision_from_representation(beam, mesh, MM)
    assert shape is not None and len(shape.parts) == 3
    np.testing.assert_allclose(union_bounds(shape.parts), mesh.bounds, atol=1e-7)


def test_clipped_body_falls_back_to_the_mesh_with_a_note(model: Model) -> None:
    clipping = ifcopenshell.util.data.Clipping(location=(0.0, 0.0, 5.0), normal=(0.0, 0.7071, 0.7071))
    representation = model.extrusion(i_section(model), 6.0, clippings=[clipping])
    beam = model.element("IfcBeam", representation)
    mesh = local_mesh(beam)
    assert collision_from_representation(beam, mesh, MM) is None
    shape = collision_shape(beam, mesh, MM)
    assert shape.method in (CollisionMethod.MESH_SPLIT, CollisionMethod.VHACD, CollisionMethod.CONVEX_HULL)
    assert shape.note is not None and "IfcBooleanClippingResult" in shape.note
    assert_convex_parts(shape)


def test_large_opening_makes_the_profile_pieces_disagree_with_the_mesh(model: Model) -> None:
    plate_profile = model.profile("IfcRectangleProfileDef", XDim=1000.0, YDim=1000.0)
    hole_profile = model.profile("IfcRectangleProfileDef", XDim=400.0, YDim=400.0)
    plate = model.element("IfcPlate", model.extrusion(plate_profile, 0.02))
    hole = model.element("IfcOpeningElement", model.extrusion(hole_profile, 0.1))
    place(model.file, hole, np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, -0.05], [0, 0, 0, 1]], float))
    ifcopenshell.api.feature.add_feature(model.file, feature=hole, element=plate)
    mesh = local_mesh(plate)
    assert mesh.volume == pytest.approx(0.84 * 0.02, rel=1e-6)
    assert collision_from_representation(plate, mesh, MM) is None


@pytest.mark.parametrize("ifc_class", ["IfcUShapeProfileDef", "IfcZShapeProfileDef"])
def test_pieces_that_do_not_lie_inside_the_mesh_are_rejected(model: Model, ifc_class: str) -> None:
    """A mirrored mesh has the same bounds and volume; the containment check must still catch it."""
    profile = model.profile(
        ifc_class, Depth=300.0, FlangeWidth=100.0, WebThickness=10.0, FlangeThickness=15.0
    )
    member = model.element("IfcMember", model.extrusion(profile, 2.0))
    mesh = local_mesh(member)
    assert collision_from_representation(member, mesh, MM) is not None
    mirrored = mesh.copy()
    mirrored.apply_transform(np.diag([-1.0, 1.0, 1.0, 1.0]))
    assert collision_from_representation(member, mirrored, MM) is None


def test_circular_hollow_section_is_annular_sectors(model: Model) -> None:
    chs = model.profile("IfcCircleHollowProfileDef", Radius=57.15, WallThickness=3.6)
    column = model.element("IfcColumn", model.extrusion(chs, 3.0), rotated_placement())
    mesh = local_mesh(column)
    shape = collision_shape(column, mesh, MM)
    assert shape.method is CollisionMethod.PROFILE_DECOMPOSITION and len(shape.parts) == MAX_COLLISION_PARTS
    assert_convex_parts(shape)
    # 24 sectors merged, neighbours first, into 16: still a tube, a wider sector taking in the sliver under
    # its inner chord (a hull across its bore would hold eight times the tube's volume)
    assert mesh.volume <= sum(q.volume for q in shape.parts) <= 1.2 * mesh.volume


# --- mesh path --------------------------------------------------------------------------------------------


def test_convex_box_mesh_is_one_hull() -> None:
    box = trimesh.creation.box(extents=(0.4, 0.3, 2.0))
    shape = collision_from_mesh(box)
    assert shape.method is CollisionMethod.CONVEX_HULL and len(shape.parts) == 1
    assert shape.parts[0].volume == pytest.approx(box.volume)


def test_concave_l_prism_is_cut_exactly_into_two_convex_parts() -> None:
    angle = l_prism()
    shape = collision_from_mesh(angle)
    assert shape.method is CollisionMethod.MESH_SPLIT and len(shape.parts) == 2
    assert_convex_parts(shape)
    np.testing.assert_allclose(union_bounds(shape.parts), angle.bounds, atol=1e-6)
    assert sum(q.volume for q in shape.parts) == pytest.approx(angle.volume, rel=1e-5)  # one hull: 3.1 ×


def test_frame_around_an_opening_is_cut_into_four_bars() -> None:
    """A ring needs two cuts before any hull shrinks; the splitter must still find the four bars."""
    bars = [
        trimesh.creation.box((1.0, 0.1, 0.1), trimesh.transformations.translation_matrix((0, 0, 0.7))),
        trimesh.creation.box((1.0, 0.1, 0.1), trimesh.transformations.translation_matrix((0, 0, -0.7))),
        trimesh.creation.box((0.1, 0.1, 1.3), trimesh.transformations.translation_matrix((0.45, 0, 0))),
        trimesh.creation.box((0.1, 0.1, 1.3), trimesh.transformations.translation_matrix((-0.45, 0, 0))),
    ]
    ring_volume = sum(bar.volume for bar in bars)
    frame = _ring((1.0, 0.1, 1.5), 0.1)
    shape = collision_from_mesh(frame)
    assert shape.method is CollisionMethod.MESH_SPLIT and len(shape.parts) == 4
    assert sum(q.volume for q in shape.parts) == pytest.approx(ring_volume, rel=1e-5)


def _ring(extents_m: tuple[float, float, float], bar_m: float) -> trimesh.Trimesh:
    """A box minus a through hole ``bar_m`` from every side edge (built with manifold3d)."""
    x, y, z = extents_m
    box = manifold3d.Manifold.cube((x, y, z), center=True)
    hole = manifold3d.Manifold.cube((x - 2 * bar_m, 2 * y, z - 2 * bar_m), center=True)
    mesh = (box - hole).to_mesh()
    return trimesh.Trimesh(mesh.vert_properties[:, :3], mesh.tri_verts)


def _open_ring() -> trimesh.Trimesh:
    """The ring without its front face: an open shell no repair can close."""
    ring = _ring((1.0, 0.1, 1.5), 0.1)
    return trimesh.Trimesh(ring.vertices, ring.faces[ring.face_normals[:, 1] < 0.5])


def test_concave_open_mesh_is_decomposed_by_vhacd() -> None:
    open_ring = _open_ring()
    assert not open_ring.is_watertight
    shape = collision_from_mesh(open_ring)
    assert shape.method is CollisionMethod.VHACD and len(shape.parts) >= 2
    assert_convex_parts(shape)


def test_vhacd_parts_stay_inside_the_mesh_bounds() -> None:
    angle = l_prism()
    lower, upper = union_bounds(tuple(vhacd_parts(angle)))
    assert np.all(lower >= angle.bounds[0] - 1e-9) and np.all(upper <= angle.bounds[1] + 1e-9)


def test_vhacd_keeps_the_section_of_a_long_i_beam(model: Model) -> None:
    """V-HACD's 64-voxel floor along the longest axis would merge a 6 m I-beam into one hull."""
    mesh = local_mesh(model.element("IfcBeam", model.extrusion(i_section(model), 6.0)))
    parts = vhacd_parts(mesh)
    assert len(parts) >= 3
    assert sum(q.volume for q in parts) < 2.5 * mesh.volume  # its one hull is 6.9 × the volume


def test_i_beam_mesh_is_cut_exactly_into_its_three_plates(model: Model) -> None:
    mesh = local_mesh(model.element("IfcBeam", model.extrusion(i_section(model), 6.0)))
    shape = collision_from_mesh(mesh)
    assert shape.method is CollisionMethod.MESH_SPLIT and len(shape.parts) == 3
    assert sum(q.volume for q in shape.parts) == pytest.approx(mesh.volume, rel=1e-4)


def test_vhacd_on_a_square_plate_is_fast_despite_the_voxeliser_axis_bug() -> None:
    """A 400×400×20 mm plate with a notch: plain p.vhacd takes >10 s here (10^8 voxels)."""
    outline = [
        (0.0, 0.0),
        (0.4, 0.0),
        (0.4, 0.4),
        (0.25, 0.4),
        (0.25, 0.2),
        (0.15, 0.2),
        (0.15, 0.4),
        (0.0, 0.4),
    ]
    cap = [(0, 1, 4), (1, 2, 4), (2, 3, 4), (0, 4, 5), (0, 5, 7), (5, 6, 7)]
    plate = prism(outline, cap, 0.02)
    start = time.process_time()  # CPU seconds: the bug costs work, which a busy machine does not add to
    parts = vhacd_parts(plate)
    assert time.process_time() - start < 3.0
    assert parts


def test_vhacd_prints_nothing_to_stdout(capfd: pytest.CaptureFixture[str]) -> None:
    collision_from_mesh(l_prism())
    assert capfd.readouterr().out == ""


def test_importing_and_using_the_module_prints_nothing(tmp_path: Path) -> None:
    """pybullet prints a build banner on import and V-HACD its progress; neither may reach CLI output."""
    mesh_file = tmp_path / "open_ring.obj"
    _open_ring().export(str(mesh_file))  # open: goes to V-HACD
    code = textwrap.dedent(
        f"""
        import trimesh
        from bimbot.services.converter.collision import collision_from_mesh
        shape = collision_from_mesh(trimesh.load({str(mesh_file)!r}))
        assert shape.method.value == "vhacd", shape
        """
    )
    root = Path(__file__).resolve().parents[2]
    result = subprocess.run(
        [sys.executable, "-c", code], cwd=root, capture_output=True, text=True, check=False
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout == "" and result.stderr == ""


def test_flat_mesh_collides_as_a_thin_box() -> None:
    square = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[0, 1, 2], [0, 2, 3]])
    shape = collision_from_mesh(square)
    assert shape.method is CollisionMethod.CONVEX_HULL and len(shape.parts) == 1
    assert shape.parts[0].volume == pytest.approx(1e-3)


def _panel(origin_m: tuple[float, ...], u_m: tuple[float, ...], v_m: tuple[float, ...]) -> trimesh.Trimesh:
    """A single-sided rectangle as a 3 × 3 grid of quads (coplanar vertices on its edges and inside)."""
    steps = np.linspace(0.0, 1.0, 4)
    vertices = [np.add(origin_m, np.multiply(u_m, i) + np.multiply(v_m, j)) for i in steps for j in steps]
    faces = []
    for i in range(3):
        for j in range(3):
            a = i * 4 + j
            faces += [[a, a + 4, a + 1], [a + 1, a + 4, a + 5]]
    return trimesh.Trimesh(vertices, faces, process=False)


def _stall() -> trimesh.Trimesh:
    """Three single-sided panels round a 1.6 m × 2.8 m toilet stall: every vertex lies on their hull."""
    return trimesh.util.concatenate(
        [
            _panel((0, 0, 0), (0, 2.8, 0), (0, 0, 2.8)),
            _panel((1.6, 0, 0), (0, 2.8, 0), (0, 0, 2.8)),
            _panel((0, 2.8, 0), (1.6, 0, 0), (0, 0, 2.8)),
        ]
    )


def test_three_sides_of_a_box_are_three_thin_panels_not_the_box() -> None:
    shape = collision_from_mesh(_stall())
    assert len(shape.parts) == 3  # one hull would fill the stall, 12.5 m³
    panels_m3 = (2 * 2.8 + 1.6) * 2.8 * 1e-3  # 1 mm thick
    assert sum(part.volume for part in shape.parts) == pytest.approx(panels_m3, rel=1e-3)
    np.testing.assert_allclose(union_bounds(shape.parts), _stall().bounds, atol=1e-3)


def test_a_sliver_face_on_the_hull_does_not_make_an_open_mesh_convex(monkeypatch: pytest.MonkeyPatch) -> None:
    """manifold3d's hull may hold a zero-area triangle; its zero normal must not pass every point."""
    open_ring = _open_ring()
    without_sliver = collision_from_mesh(open_ring)
    real_hull = collision_module._mesh_hull

    def hull_with_a_sliver(mesh: TriMesh) -> TriMesh | None:
        hull = real_hull(mesh)
        assert hull is not None
        return TriMesh(hull.vertices, np.vstack([hull.faces, [[0, 0, 1]]]))

    monkeypatch.setattr(collision_module, "_mesh_hull", hull_with_a_sliver)
    shape = collision_from_mesh(open_ring)
    assert len(without_sliver.parts) >= 2
    assert (shape.method, len(shape.parts)) == (without_sliver.method, len(without_sliver.parts))


# --- sample files -----------------------------------------------------------------------------------------


def sample_shapes(samples: Path, name: str) -> list[tuple[trimesh.Trimesh, CollisionShape]]:
    """(mesh, collision shape) of every meshed element of a sample file (``samples``: the fixture)."""
    model = ifcopenshell.open(str(samples / name))
    unit_scale_m = ifcopenshell.util.unit.calculate_unit_scale(model)
    settings = ifcopenshell.geom.settings()
    settings.set("use-world-coords", False)
    iterator = ifcopenshell.geom.iterator(settings, model)
    assert iterator.initialize()
    results = []
    while True:
        shape = iterator.get()
        faces = ifcopenshell.util.shape.get_faces(shape.geometry)
        if len(faces):
            mesh = trimesh.Trimesh(ifcopenshell.util.shape.get_vertices(shape.geometry), faces)
            results.append((mesh, collision_shape(model.by_id(shape.id), mesh, unit_scale_m)))
        if not iterator.next():
            break
    return results


def test_ifc2x3_i_shape_sample_is_decomposed_from_its_profiles(samples_dir: Path) -> None:
    shapes = sample_shapes(samples_dir, "IfcIShapeProfileDef.ifc")
    assert len(shapes) == 3  # I, I with fillet, asymmetric I
    for mesh, shape in shapes:
        assert shape.method is CollisionMethod.PROFILE_DECOMPOSITION and len(shape.parts) == 3
        np.testing.assert_allclose(union_bounds(shape.parts), mesh.bounds, atol=1e-6)


def test_ifc4_extruded_beam_sample_is_three_boxes(samples_dir: Path) -> None:
    ((_, shape),) = sample_shapes(samples_dir, "beam-extruded-solid.ifc")
    assert shape.method is CollisionMethod.PROFILE_DECOMPOSITION and len(shape.parts) == 3


def test_standard_case_beams_sample_gives_a_shape_for_every_beam(samples_dir: Path) -> None:
    """IPE220 (filleted I) and ½IPE300 (T) beams with cardinal-point offsets: all decompose from profiles."""
    shapes = sample_shapes(samples_dir, "standard_case_element_beam.ifc")
    assert len(shapes) == 18
    for _, shape in shapes:
        assert shape.method is CollisionMethod.PROFILE_DECOMPOSITION
        assert_convex_parts(shape)


def test_faceted_brep_sample_falls_back_to_the_mesh(samples_dir: Path) -> None:
    ((mesh, shape),) = sample_shapes(samples_dir, "faceted_brep.ifc")
    assert shape.method in (CollisionMethod.CONVEX_HULL, CollisionMethod.VHACD)
    assert shape.note is not None and "IfcFacetedBrep" in shape.note
    assert_convex_parts(shape)
    np.testing.assert_allclose(union_bounds(shape.parts), mesh.bounds, atol=0.02 * mesh.extents.max())


# --- physics ----------------------------------------------------------------------------------------------


def test_profile_parts_rest_on_the_ground_as_a_compound_body(model: Model, tmp_path: Path) -> None:
    beam = model.element("IfcBeam", model.extrusion(i_section(model), 3.0))
    shape = collision_shape(beam, local_mesh(beam), MM)
    centre_local = trimesh.util.concatenate(
        [trimesh.Trimesh(q.vertices, q.faces) for q in shape.parts]
    ).center_mass
    files = []
    for index, part in enumerate(shape.parts):
        files.append(str(tmp_path / f"part_{index}.obj"))
        write_obj(Path(files[-1]), part)
    client = p.connect(p.DIRECT)
    try:
        p.setGravity(0, 0, -9.81, physicsClientId=client)
        ground = p.createCollisionShape(p.GEOM_PLANE, physicsClientId=client)
        p.createMultiBody(0, ground, physicsClientId=client)
        compound = p.createCollisionShapeArray(
            shapeTypes=[p.GEOM_MESH] * len(files), fileNames=files, physicsClientId=client
        )
        # lie the beam along world y, flanges horizontal: element y (depth) → world z
        orientation = p.getQuaternionFromEuler((np.pi / 2, 0.0, 0.0))
        body = p.createMultiBody(
            baseMass=100.0,
            baseCollisionShapeIndex=compound,
            basePosition=(0.0, 0.0, 0.5),
            baseOrientation=orientation,
            baseInertialFramePosition=centre_local.tolist(),
            physicsClientId=client,
        )
        for _ in range(3 * 240):
            p.stepSimulation(physicsClientId=client)
        (lower, upper) = p.getAABB(body, physicsClientId=client)
        velocity, spin = p.getBaseVelocity(body, physicsClientId=client)
    finally:
        p.disconnect(client)
    assert lower[2] == pytest.approx(0.0, abs=0.01)  # on the ground: not sunk, not bouncing
    assert upper[2] - lower[2] == pytest.approx(0.4, abs=0.02)  # lying on its flange, 400 mm deep
    assert np.linalg.norm(velocity) < 0.01 and np.linalg.norm(spin) < 0.01


def test_an_element_of_many_separate_solids_keeps_at_most_the_parts_pybullet_keeps() -> None:
    """A railing of 24 separate posts: pybullet keeps only 16 children of a compound shape (the rest
    would be silently missing in physics), so the posts are merged into 16 hulls that still hold them all."""
    posts = [trimesh.creation.box((0.05, 0.05, 1.0)) for _ in range(24)]
    for index, post in enumerate(posts):
        post.apply_translation((0.3 * index, 0.0, 0.5))
    vertices = np.vstack([post.vertices for post in posts])
    faces = np.vstack([post.faces + 8 * index for index, post in enumerate(posts)])
    shape = collision_from_mesh(trimesh.Trimesh(vertices, faces, process=False))
    assert len(shape.parts) == MAX_COLLISION_PARTS
    for post in posts:  # every post lies inside one of the merged hulls
        low, high = post.bounds
        assert any(
            np.all(part.vertices.min(axis=0) <= low + 1e-9)
            and np.all(part.vertices.max(axis=0) >= high - 1e-9)
            for part in shape.parts
        )


def test_a_railing_of_many_extruded_posts_keeps_at_most_the_parts_pybullet_keeps(model: Model) -> None:
    """A railing whose body is 24 extruded posts (the Janesville restaurant's bridge railings: 113 profile
    pieces): its exact pieces are merged, neighbours first, into 16 hulls that still hold every post, or
    physics would keep 16 of them, and the converter's joints would be measured on pieces it does not have."""
    file = model.file
    post = model.profile("IfcRectangleProfileDef", XDim=50.0, YDim=50.0)
    items = []
    for index in range(24):
        position = file.createIfcAxis2Placement3D(file.createIfcCartesianPoint((300.0 * index, 0.0, 0.0)))
        items.append(
            file.createIfcExtrudedAreaSolid(post, position, file.createIfcDirection((0.0, 0.0, 1.0)), 1000.0)
        )
    body = file.createIfcShapeRepresentation(model.body, "Body", "SweptSolid", items)
    railing = model.element("IfcRailing", body)
    shape = collision_shape(railing, local_mesh(railing), MM)
    assert shape.method is CollisionMethod.PROFILE_DECOMPOSITION
    assert len(shape.parts) == MAX_COLLISION_PARTS
    assert shape.note == "24 profile pieces merged into 16 hulls, neighbours first"
    assert_convex_parts(shape)
    for index in range(24):  # every post lies inside one of the merged hulls
        low = np.array([0.3 * index - 0.025, -0.025, 0.0])
        high = low + np.array([0.05, 0.05, 1.0])
        assert any(
            np.all(part.vertices.min(axis=0) <= low + 1e-6)
            and np.all(part.vertices.max(axis=0) >= high - 1e-6)
            for part in shape.parts
        )


def test_convex_parts_do_not_depend_on_how_busy_the_machine_is(monkeypatch: pytest.MonkeyPatch) -> None:
    """A U-shaped solid (a wall with a door opening) is cut into three boxes whether the clock runs or
    jumps 10 s at every reading, as on a machine loaded 25 deep: the budget is counted in work, not time
    (a 0.3 s wall-clock budget had cut the hub's footings short under load and drawn them 0.33 m into their
    neighbours, which changed its joints and its order of pours)."""
    from bimbot.services.converter.plane_split import split_into_convex_parts

    wall = manifold3d.Manifold.cube((4.0, 0.2, 3.0)) - manifold3d.Manifold.cube((1.0, 1.0, 2.0)).translate(
        (1.5, -0.4, -0.5)
    )
    mesh = wall.to_mesh()
    solid = trimesh.Trimesh(np.asarray(mesh.vert_properties)[:, :3], np.asarray(mesh.tri_verts))
    quiet = split_into_convex_parts(solid)
    clock = iter(range(0, 10**9, 10))
    monkeypatch.setattr(time, "perf_counter", lambda: float(next(clock)))
    monkeypatch.setattr(time, "monotonic", lambda: float(next(clock)))
    busy = split_into_convex_parts(solid)
    assert quiet is not None and busy is not None
    assert len(quiet.parts) == len(busy.parts) == 3
    assert busy.hull_volume_ratio == pytest.approx(1.0, abs=1e-6)
